//! capsule's actions (`action/Move.action`, `action/SwitchAttractor.action`) and the wire
//! types every ROS 2 action is made of, as rosidl generates them and rcl_action uses them:
//! the goal, result and feedback of each action, its `_SendGoal` and `_GetResult` services,
//! its `_FeedbackMessage`, and the standard `action_msgs` types (status, cancel).
//!
//! An action `/a` of type `pkg/action/A` is, on DDS: the services
//! `/a/_action/send_goal` (`A_SendGoal`), `/a/_action/cancel_goal` (`action_msgs/srv/CancelGoal`)
//! and `/a/_action/get_result` (`A_GetResult`), and the topics `/a/_action/feedback`
//! (`A_FeedbackMessage`) and `/a/_action/status` (`action_msgs/msg/GoalStatusArray`).

use serde::{Deserialize, Serialize};

use crate::{constants, Time};

/// `unique_identifier_msgs/msg/UUID`: a goal's id, chosen by the client.
pub type Uuid = [u8; 16];

/// `capsule_msgs/action/Move` goal.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MoveGoal {
    /// Signed travel from where the goal is accepted \[m\]: > 0 forward, < 0 backward.
    pub distance_m: f64,
    /// Landing tolerance \[m\] (0 = the controller's default).
    pub tolerance_m: f64,
    /// Time limit \[s\] (0 = none).
    pub timeout_s: f64,
}

/// `capsule_msgs/action/Move` result.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MoveResult {
    /// Landed within the tolerance.
    pub reached: bool,
    /// Travel since the goal was accepted \[m\].
    pub travelled_m: f64,
    /// `travelled_m - distance_m` \[m\].
    pub error_m: f64,
    /// Time from acceptance to the end \[s\] (the node's ROS time).
    pub elapsed_s: f64,
    /// How it ended, or why it was refused.
    pub message: String,
}

/// `capsule_msgs/action/Move` feedback.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct MoveFeedback {
    /// Travel so far \[m\].
    pub travelled_m: f64,
    /// Distance left \[m\] (signed).
    pub remaining_m: f64,
    /// Mean capsule speed over the last drive period [m/s].
    pub speed_m_per_s: f64,
    /// The `SetMode` constant in use.
    pub mode: u8,
}

/// `capsule_msgs/action/SwitchAttractor` goal: `SetMode`'s switch fields.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SwitchAttractorGoal {
    /// `k_p` during the pulses.
    pub gain: f64,
    /// Pulse length [drive periods].
    pub pulse_periods: i32,
    /// Period of the orbit wanted [drive periods].
    pub target_period: i32,
    /// Most pulses to apply.
    pub max_tries: i32,
}

/// `capsule_msgs/action/SwitchAttractor` result.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SwitchAttractorResult {
    /// The orbit has the period wanted.
    pub reached: bool,
    /// The orbit's period at the end (0: not periodic or not known).
    pub final_period: i32,
    /// Pulses applied.
    pub tries: i32,
    /// Time from acceptance to the end \[s\].
    pub elapsed_s: f64,
    /// How it ended, or why it was refused.
    pub message: String,
}

/// `capsule_msgs/action/SwitchAttractor` feedback.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SwitchAttractorFeedback {
    /// A `ControllerStatus::SWITCH_*` constant.
    pub switch_state: u8,
    /// Pulses applied so far.
    pub tries: i32,
    /// The orbit's period observed (0: not periodic yet).
    pub orbit_period: i32,
}

/// `A_SendGoal_Request`: a goal and the id its client gave it.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SendGoalRequest<G> {
    /// The goal's id.
    pub goal_id: Uuid,
    /// The goal.
    pub goal: G,
}

/// `A_SendGoal_Response`: accepted or not, and when.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SendGoalResponse {
    /// The server took the goal.
    pub accepted: bool,
    /// When it was accepted (zero when refused).
    pub stamp: Time,
}

/// `A_GetResult_Request`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct GetResultRequest {
    /// The goal whose result is wanted.
    pub goal_id: Uuid,
}

/// `A_GetResult_Response`: the goal's terminal status (a [`GoalStatus`] constant;
/// `STATUS_UNKNOWN` for a goal the server does not know) and its result.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetResultResponse<R> {
    /// A [`GoalStatus`] constant.
    pub status: i8,
    /// The result.
    pub result: R,
}

/// `A_FeedbackMessage`: a goal's feedback.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FeedbackMessage<F> {
    /// The goal's id.
    pub goal_id: Uuid,
    /// The feedback.
    pub feedback: F,
}

/// `action_msgs/msg/GoalInfo`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalInfo {
    /// The goal's id.
    pub goal_id: Uuid,
    /// When it was accepted.
    pub stamp: Time,
}

/// `action_msgs/msg/GoalStatus`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalStatus {
    /// The goal.
    pub goal_info: GoalInfo,
    /// One of the `STATUS_*` constants.
    pub status: i8,
}

constants!(GoalStatus: i8 {
    /// Not known (also a refused goal's, and `get_result`'s for an unknown goal).
    STATUS_UNKNOWN: 0,
    /// Accepted, not yet executing.
    STATUS_ACCEPTED: 1,
    /// Executing.
    STATUS_EXECUTING: 2,
    /// A cancel was accepted; the goal is ending.
    STATUS_CANCELING: 3,
    /// Ended, reached.
    STATUS_SUCCEEDED: 4,
    /// Ended by a cancel.
    STATUS_CANCELED: 5,
    /// Ended by the server, not reached.
    STATUS_ABORTED: 6,
});

impl GoalStatus {
    /// True for the three terminal statuses.
    pub fn is_terminal(status: i8) -> bool {
        matches!(
            status,
            Self::STATUS_SUCCEEDED | Self::STATUS_CANCELED | Self::STATUS_ABORTED
        )
    }

    /// The constant's name without `STATUS_`, for humans (`UNKNOWN` for an unknown value).
    pub fn name(status: i8) -> &'static str {
        Self::constant_name(status).map_or("UNKNOWN", |n| n.trim_start_matches("STATUS_"))
    }
}

/// `action_msgs/msg/GoalStatusArray`: every goal the server still knows, the action's status
/// topic.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct GoalStatusArray {
    /// One entry per goal.
    pub status_list: Vec<GoalStatus>,
}

/// `action_msgs/srv/CancelGoal` request: by id, by acceptance time, or all (see
/// `CancelGoal.srv`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CancelGoalRequest {
    /// The goal (zero id: any), accepted at or before the stamp (zero stamp: any time).
    pub goal_info: GoalInfo,
}

/// `action_msgs/srv/CancelGoal` response.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct CancelGoalResponse {
    /// One of the `ERROR_*` constants.
    pub return_code: i8,
    /// The goals now canceling.
    pub goals_canceling: Vec<GoalInfo>,
}

constants!(CancelGoalResponse: i8 {
    /// One goal or more are now canceling.
    ERROR_NONE: 0,
    /// Refused: none is canceling.
    ERROR_REJECTED: 1,
    /// The goal id is not known.
    ERROR_UNKNOWN_GOAL_ID: 2,
    /// The goal has already ended.
    ERROR_GOAL_TERMINATED: 3,
});
