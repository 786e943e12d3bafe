//! An action server's goals as rcl_action keeps them (no DDS here; [`crate::action`] serves
//! them): every goal accepted, with its status and accept stamp, until its result has been
//! kept for the result timeout; the `get_result` requests that wait for a goal to end; and the
//! cancel policy of `action_msgs/srv/CancelGoal`.
//!
//! What rcl_action (and so rclcpp's and rclpy's servers) does, and this does too:
//! - the status topic lists every goal the server knows, terminal ones included, until they
//!   expire;
//! - `get_result` for a goal still running is answered when it ends; for an ended goal at
//!   once; for an unknown (or expired) goal at once with `STATUS_UNKNOWN`;
//! - a cancel names a goal id (zero: none), a stamp (zero: none), or both: the goal, and every
//!   goal accepted at or before the stamp; both zero cancels every goal. A named goal that is
//!   unknown gives `ERROR_UNKNOWN_GOAL_ID`, one already ended `ERROR_GOAL_TERMINATED`, no goal to
//!   cancel `ERROR_REJECTED`;
//! - a goal ends once; its result is kept for the result timeout (rcl_action's default is
//!   15 min) after it ended.

use capsule_msgs::actions::{CancelGoalResponse, GoalStatus};
use capsule_msgs::Time;

/// rcl_action's default result timeout: how long an ended goal's result is kept \[s\].
pub const RESULT_TIMEOUT_S: f64 = 900.0;

/// One goal.
#[derive(Debug, Clone)]
struct Goal<K, R> {
    id: K,
    stamp: Time,
    status: i8,
    result: Option<R>,
    /// Steady time it ended \[s\].
    ended_at: Option<f64>,
}

/// Goals by id `K` (compared by value), results `R`, and the handles `Q` of waiting
/// `get_result` requests.
#[derive(Debug, Clone)]
pub struct GoalTable<K, R, Q> {
    goals: Vec<Goal<K, R>>,
    waiting: Vec<(K, Q)>,
    result_timeout_s: f64,
}

/// What a `get_result` request gets.
#[derive(Debug, Clone, PartialEq)]
pub enum ResultAnswer<R> {
    /// Answer now: the terminal status and the result (`STATUS_UNKNOWN` and `None` for an
    /// unknown goal: the caller sends a default result).
    Now(i8, Option<R>),
    /// The goal runs: the request waits, answered by [`GoalTable::finish`].
    Later,
}

impl<K: Copy + PartialEq, R: Clone, Q> GoalTable<K, R, Q> {
    /// An empty table keeping results `result_timeout_s` after their goal ended.
    pub fn new(result_timeout_s: f64) -> Self {
        GoalTable {
            goals: Vec::new(),
            waiting: Vec::new(),
            result_timeout_s,
        }
    }

    fn find(&self, id: K) -> Option<&Goal<K, R>> {
        self.goals.iter().find(|g| g.id == id)
    }

    /// Whether a goal with this id is known.
    pub fn contains(&self, id: K) -> bool {
        self.find(id).is_some()
    }

    /// Adds an accepted goal (status ACCEPTED); false if its id is already known (a client
    /// must not reuse one: rcl_action refuses it).
    pub fn accept(&mut self, id: K, stamp: Time) -> bool {
        if self.contains(id) {
            return false;
        }
        self.goals.push(Goal {
            id,
            stamp,
            status: GoalStatus::STATUS_ACCEPTED,
            result: None,
            ended_at: None,
        });
        true
    }

    /// Sets a running goal's status (EXECUTING, CANCELING); false if unknown or ended.
    pub fn set_status(&mut self, id: K, status: i8) -> bool {
        match self.goals.iter_mut().find(|g| g.id == id) {
            Some(g) if !GoalStatus::is_terminal(g.status) => {
                g.status = status;
                true
            }
            _ => false,
        }
    }

    /// Ends a goal with a terminal `status` and its result at steady time `now`: the waiting
    /// `get_result` requests to answer with them (none if the goal is unknown or had ended).
    pub fn finish(&mut self, id: K, status: i8, result: R, now: f64) -> Vec<Q> {
        match self.goals.iter_mut().find(|g| g.id == id) {
            Some(g) if !GoalStatus::is_terminal(g.status) => {
                g.status = status;
                g.result = Some(result);
                g.ended_at = Some(now);
            }
            _ => return Vec::new(),
        }
        let (answer, keep): (Vec<_>, Vec<_>) = std::mem::take(&mut self.waiting)
            .into_iter()
            .partition(|(k, _)| *k == id);
        self.waiting = keep;
        answer.into_iter().map(|(_, q)| q).collect()
    }

    /// A `get_result` request `q` for goal `id`.
    pub fn result_request(&mut self, id: K, q: Q) -> ResultAnswer<R> {
        match self.find(id) {
            None => ResultAnswer::Now(GoalStatus::STATUS_UNKNOWN, None),
            Some(g) if GoalStatus::is_terminal(g.status) => {
                ResultAnswer::Now(g.status, g.result.clone())
            }
            Some(_) => {
                self.waiting.push((id, q));
                ResultAnswer::Later
            }
        }
    }

    /// The goals a cancel request names (`id` and `stamp`, `zero` being the zero id), by the
    /// policy of `CancelGoal.srv`: the return code and the running goals to cancel, with their
    /// accept stamps. The caller cancels them (CANCELING, then CANCELED when stopped).
    pub fn cancel_request(&self, id: K, stamp: Time, zero: K) -> (i8, Vec<(K, Time)>) {
        let running = |g: &&Goal<K, R>| !GoalStatus::is_terminal(g.status);
        if id != zero {
            match self.find(id) {
                None => return (CancelGoalResponse::ERROR_UNKNOWN_GOAL_ID, Vec::new()),
                Some(g) if stamp.is_zero() && GoalStatus::is_terminal(g.status) => {
                    return (CancelGoalResponse::ERROR_GOAL_TERMINATED, Vec::new())
                }
                _ => {}
            }
        }
        let picked: Vec<(K, Time)> = self
            .goals
            .iter()
            .filter(running)
            .filter(|g| {
                let by_id = id != zero && g.id == id;
                let by_stamp = !stamp.is_zero() && g.stamp <= stamp;
                let all = id == zero && stamp.is_zero();
                by_id || by_stamp || all
            })
            .map(|g| (g.id, g.stamp))
            .collect();
        if picked.is_empty() {
            (CancelGoalResponse::ERROR_REJECTED, picked)
        } else {
            (CancelGoalResponse::ERROR_NONE, picked)
        }
    }

    /// Drops the goals whose result was kept long enough at steady time `now`; true if any.
    pub fn expire(&mut self, now: f64) -> bool {
        let before = self.goals.len();
        let timeout = self.result_timeout_s;
        self.goals
            .retain(|g| g.ended_at.is_none_or(|t| now - t < timeout));
        self.goals.len() != before
    }

    /// Every goal known: id, accept stamp, status (the status topic's list).
    pub fn statuses(&self) -> impl Iterator<Item = (K, Time, i8)> + '_ {
        self.goals.iter().map(|g| (g.id, g.stamp, g.status))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(s: i32) -> Time {
        Time { sec: s, nanosec: 0 }
    }

    #[test]
    fn results_wait_for_the_end_and_stay_until_they_expire() {
        let mut g: GoalTable<u8, &str, u32> = GoalTable::new(10.0);
        assert!(g.accept(1, t(5)));
        assert!(!g.accept(1, t(6)), "a reused id is refused");
        assert_eq!(
            g.result_request(9, 100),
            ResultAnswer::Now(GoalStatus::STATUS_UNKNOWN, None)
        );
        assert!(g.set_status(1, GoalStatus::STATUS_EXECUTING));
        assert_eq!(g.result_request(1, 101), ResultAnswer::Later);
        assert_eq!(g.result_request(1, 102), ResultAnswer::Later);
        assert_eq!(
            g.finish(1, GoalStatus::STATUS_SUCCEEDED, "done", 3.0),
            vec![101, 102]
        );
        assert!(
            g.finish(1, GoalStatus::STATUS_ABORTED, "again", 3.5)
                .is_empty(),
            "a goal ends once"
        );
        assert!(!g.set_status(1, GoalStatus::STATUS_CANCELING));
        assert_eq!(
            g.result_request(1, 103),
            ResultAnswer::Now(GoalStatus::STATUS_SUCCEEDED, Some("done"))
        );
        assert_eq!(
            g.statuses().collect::<Vec<_>>(),
            vec![(1, t(5), GoalStatus::STATUS_SUCCEEDED)],
            "ended goals stay on the status topic"
        );
        assert!(!g.expire(12.9));
        assert!(g.expire(13.0));
        assert_eq!(g.statuses().count(), 0);
        assert_eq!(
            g.result_request(1, 104),
            ResultAnswer::Now(GoalStatus::STATUS_UNKNOWN, None)
        );
    }

    #[test]
    fn cancels_follow_the_cancel_goal_policy() {
        let mut g: GoalTable<u8, (), ()> = GoalTable::new(10.0);
        for (id, s) in [(1, 1), (2, 2), (3, 3)] {
            g.accept(id, t(s));
        }
        g.finish(3, GoalStatus::STATUS_ABORTED, (), 0.0);
        let ids = |r: (i8, Vec<(u8, Time)>)| (r.0, r.1.iter().map(|p| p.0).collect::<Vec<_>>());
        assert_eq!(
            ids(g.cancel_request(2, Time::ZERO, 0)),
            (CancelGoalResponse::ERROR_NONE, vec![2])
        );
        assert_eq!(
            ids(g.cancel_request(7, Time::ZERO, 0)),
            (CancelGoalResponse::ERROR_UNKNOWN_GOAL_ID, vec![])
        );
        assert_eq!(
            ids(g.cancel_request(3, Time::ZERO, 0)),
            (CancelGoalResponse::ERROR_GOAL_TERMINATED, vec![])
        );
        assert_eq!(
            ids(g.cancel_request(0, Time::ZERO, 0)),
            (CancelGoalResponse::ERROR_NONE, vec![1, 2])
        );
        assert_eq!(
            ids(g.cancel_request(0, t(1), 0)),
            (CancelGoalResponse::ERROR_NONE, vec![1])
        );
        assert_eq!(
            ids(g.cancel_request(2, t(1), 0)),
            (CancelGoalResponse::ERROR_NONE, vec![1, 2])
        );
        g.finish(1, GoalStatus::STATUS_CANCELED, (), 0.0);
        g.finish(2, GoalStatus::STATUS_CANCELED, (), 0.0);
        assert_eq!(
            ids(g.cancel_request(0, Time::ZERO, 0)),
            (CancelGoalResponse::ERROR_REJECTED, vec![])
        );
    }
}
