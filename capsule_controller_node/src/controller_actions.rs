//! The controller's actions, beside its loop: `~/move` (`capsule_msgs/action/Move`: travel a
//! distance and stop, [`capsule_controller::move_goal`]) and `~/switch_attractor`
//! (`capsule_msgs/action/SwitchAttractor`: `set_mode`'s SWITCH_ATTRACTOR with feedback and a
//! result). Served as rcl_action serves actions ([`capsule_ros_base::action`]).
//!
//! One goal at a time per action: a new goal ends the running one as ABORTED, saying so, then
//! starts; a cancel ends it as CANCELED (a move in OFF; a switch back to the mode it came from);
//! a `set_mode` call, a parameter change or the other action ends it as ABORTED, saying so.
//! Goals are refused (the reason in the log, as `send_goal` carries none) when the request is
//! bad, the plant is not under control (no fresh state, or it refuses our commands), is not
//! active (its lifecycle says so, [`crate::plant_lifecycle`], or its samples apply none of our
//! commands) or its emergency stop is engaged. Feedback
//! at 20 Hz. The decisions are the core's, on state samples, so under `/clock` in lock-step the
//! same goal gives the same result.
//!
//! The node's hook is [`CoreAccess`] (its core and its ROS time) and [`ControllerActions::run`],
//! a task of its own that polls the action servers every 10 ms.
//!
//! On Zenoh (`ControllerActions::on_zenoh`, feature `zenoh`) the same goal handling serves the
//! actions through ros2-client's Zenoh backend (`capsule_ros_base::action_zenoh`), and the
//! plant's emergency stop is read there too (a stop engaged before the controller started is
//! not seen: the plant's Zenoh publisher keeps no cache for a late reader); the plant's
//! lifecycle is not followed on Zenoh yet (its `get_state` client is DDS only): an inactive
//! plant's goal is refused only by the core's own checks (fresh states, commands applied).

use std::time::Duration;

use capsule_controller::mode::Mode;
use capsule_controller::move_goal::{MoveEnd, MoveRequest, MoveRun};
use capsule_msgs::actions::{
    GoalStatus, MoveFeedback, MoveGoal, MoveResult, SwitchAttractorFeedback, SwitchAttractorGoal,
    SwitchAttractorResult,
};
use capsule_msgs::names::{topics, type_names};
use capsule_msgs::std_types::Bool;
use capsule_msgs::{ControllerStatus, SetModeRequest, Time};
use capsule_ros_base::action::{Action, Introspection, Request};
use capsule_ros_base::clock::RosClock;
use capsule_ros_base::error::Result;
use capsule_ros_base::graph::Graph;
use capsule_ros_base::{
    endpoints::{subscribe, Wire},
    qos,
    ros_options::RosOptions,
    types,
};
use ros2_client::action::GoalId;
use ros2_client::dds::{Context, Node};
use tracing::{info, warn};

use crate::controller_core::ControllerCore;
use crate::plant_lifecycle::PlantLifecycle;

/// What the actions need of the node.
pub trait CoreAccess: Send + 'static {
    /// Runs `f` on the node's core.
    fn with_core<T>(&self, f: impl FnOnce(&mut ControllerCore) -> T) -> T;
    /// The node's ROS time (sim time under `use_sim_time`).
    fn now(&self) -> Time;
}

/// How often the servers are polled, and feedback periods per poll.
const POLL: Duration = Duration::from_millis(10);
const FEEDBACK_EVERY: u32 = 5;

/// A goal running: its id, and its acceptance stamp.
#[derive(Debug, Clone, Copy)]
struct Running {
    id: GoalId,
    accepted: Time,
}

/// The two actions and what they serve.
pub struct ControllerActions {
    moves: Action<MoveGoal, MoveResult, MoveFeedback>,
    switches: Action<SwitchAttractorGoal, SwitchAttractorResult, SwitchAttractorFeedback>,
    /// The plant's emergency stop: the next state it published, if any (DDS or Zenoh).
    estop: Box<dyn FnMut() -> Option<bool> + Send>,
    estopped: bool,
    /// The plant's lifecycle (`None` on Zenoh).
    lifecycle: Option<PlantLifecycle>,
    moving: Option<Running>,
    switching: Option<Running>,
}

impl ControllerActions {
    /// The actions' endpoints on `node` (their services' events as `introspection` says,
    /// stamped with `clock`), a reader of the plant's emergency stop and a follower of its
    /// lifecycle.
    pub fn build(
        (settings, context): (&RosOptions, &Context),
        node: &mut Node,
        graph: &Graph,
        clock: &RosClock,
        introspection: Introspection,
    ) -> Result<Self> {
        let estop_topic =
            settings.topic(node, topics::EMERGENCY_STOP, types::bool(), &qos::latched())?;
        let events = (clock, introspection);
        Ok(ControllerActions {
            moves: Action::new(settings, node, graph, topics::MOVE, type_names::MOVE)?.introspect(
                context,
                settings,
                node,
                type_names::MOVE,
                events,
            )?,
            switches: Action::new(
                settings,
                node,
                graph,
                topics::SWITCH_ATTRACTOR,
                type_names::SWITCH_ATTRACTOR,
            )?
            .introspect(
                context,
                settings,
                node,
                type_names::SWITCH_ATTRACTOR,
                events,
            )?,
            estop: {
                let reader = subscribe::<Wire<Bool>>(node, &estop_topic, &qos::latched())?;
                Box::new(move || reader.take().ok().flatten().map(|s| s.0 .0.data))
            },
            estopped: false,
            lifecycle: Some(PlantLifecycle::new(settings, node)?),
            moving: None,
            switching: None,
        })
    }

    /// The actions' endpoints on the Zenoh `node`.
    #[cfg(feature = "zenoh")]
    pub fn on_zenoh(settings: &RosOptions, node: &ros2_client::zenoh::Node) -> Result<Self> {
        use capsule_ros_base::error::Context as _;
        let topic = node.create_topic(
            &settings.ros_name(topics::EMERGENCY_STOP)?,
            types::bool(),
            &qos::latched(),
        );
        let reader = node
            .create_subscription::<Bool>(&topic, Some(qos::latched()))
            .context("emergency stop subscription on Zenoh")?;
        Ok(ControllerActions {
            moves: Action::on_zenoh(settings, node, topics::MOVE, type_names::MOVE)?,
            switches: Action::on_zenoh(
                settings,
                node,
                topics::SWITCH_ATTRACTOR,
                type_names::SWITCH_ATTRACTOR,
            )?,
            estop: Box::new(move || reader.try_take().ok().flatten().map(|(b, _)| b.data)),
            estopped: false,
            lifecycle: None,
            moving: None,
            switching: None,
        })
    }

    /// Serves the actions until the task is dropped.
    pub async fn run(mut self, core: impl CoreAccess) {
        let mut tick = tokio::time::interval(POLL);
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut until_feedback = FEEDBACK_EVERY;
        loop {
            tick.tick().await;
            self.read_estop(&core);
            if let Some(id) = self.lifecycle.as_mut().and_then(|l| l.poll()) {
                core.with_core(|c| c.plant_lifecycle(id));
            }
            for request in self.moves.poll() {
                self.on_move_request(&core, request);
            }
            for request in self.switches.poll() {
                self.on_switch_request(&core, request);
            }
            self.end_moves(&core);
            self.end_switch(&core);
            until_feedback -= 1;
            if until_feedback == 0 {
                until_feedback = FEEDBACK_EVERY;
                self.feedback(&core);
            }
        }
    }

    fn read_estop(&mut self, core: &impl CoreAccess) {
        while let Some(engaged) = (self.estop)() {
            if engaged && !self.estopped {
                core.with_core(|c| c.abort_move("the plant's emergency stop was engaged"));
            }
            self.estopped = engaged;
        }
    }

    fn on_move_request(&mut self, core: &impl CoreAccess, request: Request<MoveGoal>) {
        match request {
            Request::Goal { id, req, goal } => {
                let request = MoveRequest {
                    distance_m: goal.distance_m,
                    tolerance_m: goal.tolerance_m,
                    timeout_s: goal.timeout_s,
                };
                let started = if self.estopped {
                    Err("the plant's emergency stop is engaged".to_string())
                } else if self.moves.knows(id) {
                    Err("goal id reused".to_string())
                } else {
                    core.with_core(|c| c.start_move(request))
                };
                match started {
                    Err(why) => {
                        warn!(
                            "{}: goal {} m refused: {why}",
                            self.moves.name(),
                            goal.distance_m
                        );
                        self.moves.refuse(req);
                    }
                    Ok(replaced) => {
                        if let Some(old) = replaced {
                            self.report_move(old);
                        }
                        // a running attractor switch was cancelled by the mode change
                        self.end_switch(core);
                        let accepted = core.now();
                        self.moves.accept(id, req, accepted);
                        info!(
                            "{}: goal {} m accepted (tolerance {} m, timeout {} s)",
                            self.moves.name(),
                            goal.distance_m,
                            goal.tolerance_m,
                            goal.timeout_s
                        );
                        self.moving = Some(Running { id, accepted });
                    }
                }
            }
            Request::Cancel { req, id, stamp } => {
                let canceled = self.moves.cancel(req, id, stamp);
                if self.moving.is_some_and(|r| canceled.contains(&r.id)) {
                    core.with_core(|c| c.cancel_move());
                    self.end_moves(core);
                }
            }
        }
    }

    /// Reports the move goal that ended, if one did.
    fn end_moves(&mut self, core: &impl CoreAccess) {
        if let Some(run) = core.with_core(|c| c.take_ended_move()) {
            self.report_move(run);
        }
    }

    fn report_move(&mut self, run: MoveRun) {
        let Some(running) = self.moving.take() else {
            return;
        };
        let Some(out) = run.outcome() else { return };
        let distance = run.request().distance_m;
        let status = match out.end {
            MoveEnd::Reached => GoalStatus::STATUS_SUCCEEDED,
            MoveEnd::Canceled => GoalStatus::STATUS_CANCELED,
            MoveEnd::Aborted(_) => GoalStatus::STATUS_ABORTED,
        };
        let result = MoveResult {
            reached: out.end == MoveEnd::Reached,
            travelled_m: out.travelled_m,
            error_m: out.error_m,
            elapsed_s: out.elapsed_s,
            message: out.message(distance),
        };
        info!("{}: {}", self.moves.name(), result.message);
        self.moves.finish(running.id, status, result);
    }

    fn on_switch_request(&mut self, core: &impl CoreAccess, request: Request<SwitchAttractorGoal>) {
        match request {
            Request::Goal { id, req, goal } => {
                let set = SetModeRequest {
                    mode: SetModeRequest::SWITCH_ATTRACTOR,
                    gain: goal.gain,
                    pulse_periods: goal.pulse_periods,
                    target_period: goal.target_period,
                    max_tries: goal.max_tries,
                    ..SetModeRequest::default()
                };
                let answer = if self.estopped {
                    Err("the plant's emergency stop is engaged".to_string())
                } else if self.switches.knows(id) {
                    Err("goal id reused".to_string())
                } else if !core.with_core(|c| c.commanding() && !c.plant_refuses()) {
                    Err("the plant is not under control (no fresh state, or it refuses our commands)".to_string())
                } else if core.with_core(|c| c.plant_inactive()) {
                    Err("the plant is not active (it applies none of our commands)".to_string())
                } else {
                    let r = core.with_core(|c| c.set_mode(&set));
                    if r.accepted {
                        Ok(())
                    } else {
                        Err(r.reason)
                    }
                };
                match answer {
                    Err(why) => {
                        warn!("{}: goal refused: {why}", self.switches.name());
                        self.switches.refuse(req);
                    }
                    Ok(()) => {
                        // the switch's mode change ended a move goal, and a running switch
                        self.end_moves(core);
                        self.finish_switch(core, "a new goal preempted it");
                        let accepted = core.now();
                        self.switches.accept(id, req, accepted);
                        self.switching = Some(Running { id, accepted });
                    }
                }
            }
            Request::Cancel { req, id, stamp } => {
                let canceled = self.switches.cancel(req, id, stamp);
                if let Some(r) = self.switching.filter(|r| canceled.contains(&r.id)) {
                    core.with_core(|c| c.cancel_switch());
                    let result = self.switch_result(core, r, "canceled".into());
                    self.switches
                        .finish(r.id, GoalStatus::STATUS_CANCELED, result);
                    self.switching = None;
                }
            }
        }
    }

    fn switch_result(
        &self,
        core: &impl CoreAccess,
        running: Running,
        message: String,
    ) -> SwitchAttractorResult {
        let now = core.now();
        let st = core.with_core(|c| c.status(now));
        SwitchAttractorResult {
            reached: st.switch_state == ControllerStatus::SWITCH_SUCCEEDED,
            final_period: st.orbit_period,
            tries: st.switch_tries,
            elapsed_s: now.as_secs_f64() - running.accepted.as_secs_f64(),
            message,
        }
    }

    /// Ends the running switch goal as ABORTED for `why` (when another goal or mode replaced
    /// the switch).
    fn finish_switch(&mut self, core: &impl CoreAccess, why: &str) {
        if let Some(r) = self.switching.take() {
            let result = self.switch_result(core, r, format!("aborted: {why}"));
            self.switches
                .finish(r.id, GoalStatus::STATUS_ABORTED, result);
        }
    }

    /// Reports the switch goal's end, once the core's switch is done or gone.
    fn end_switch(&mut self, core: &impl CoreAccess) {
        let Some(r) = self.switching else { return };
        let (mode, state) =
            core.with_core(|c| (c.mode(), c.attractor_switch().map(|s| s.state().code())));
        let status = match state {
            Some(ControllerStatus::SWITCH_SUCCEEDED) => GoalStatus::STATUS_SUCCEEDED,
            Some(ControllerStatus::SWITCH_FAILED) => GoalStatus::STATUS_ABORTED,
            Some(ControllerStatus::SWITCH_CANCELLED) | None => GoalStatus::STATUS_ABORTED,
            _ if mode != Mode::SwitchAttractor => GoalStatus::STATUS_ABORTED,
            _ => return,
        };
        let message = match state {
            Some(ControllerStatus::SWITCH_SUCCEEDED) => "reached the orbit wanted".to_string(),
            Some(ControllerStatus::SWITCH_FAILED) => {
                "aborted: the tries were used up without reaching the orbit wanted".to_string()
            }
            _ => "aborted: another mode or goal ended the switch".to_string(),
        };
        let result = self.switch_result(core, r, message);
        info!("{}: {}", self.switches.name(), result.message);
        self.switches.finish(r.id, status, result);
        self.switching = None;
    }

    fn feedback(&self, core: &impl CoreAccess) {
        if let Some(r) = self.moving {
            if let Some((p, mode)) = core.with_core(|c| c.move_progress()) {
                self.moves.feedback(
                    r.id,
                    MoveFeedback {
                        travelled_m: p.travelled_m,
                        remaining_m: p.remaining_m,
                        speed_m_per_s: p.speed_m_per_s,
                        mode: mode.code(),
                    },
                );
            }
        }
        if let Some(r) = self.switching {
            let now = core.now();
            let st = core.with_core(|c| c.status(now));
            self.switches.feedback(
                r.id,
                SwitchAttractorFeedback {
                    switch_state: st.switch_state,
                    tries: st.switch_tries,
                    orbit_period: st.orbit_period,
                },
            );
        }
    }
}
