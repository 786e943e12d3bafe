//! Standard ROS 2 message types the capsule's views publish (`sensor_msgs/JointState`,
//! `tf2_msgs/TFMessage`, `std_msgs/String`, `diagnostic_msgs/DiagnosticArray`) and the clock
//! (`rosgraph_msgs/Clock`), as plain serde
//! types in the field order and CDR layout of their `.msg` files (ROS 2 Jazzy).

use serde::{Deserialize, Serialize};

use crate::{constants, Header, Time};

/// `rosgraph_msgs/msg/Clock`: the simulation time on `/clock`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The current simulation time.
    pub clock: Time,
}

/// `sensor_msgs/JointState`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct JointState {
    /// Stamp and frame.
    pub header: Header,
    /// Joint names.
    pub name: Vec<String>,
    /// Positions \[m\] (prismatic joints).
    pub position: Vec<f64>,
    /// Velocities [m/s].
    pub velocity: Vec<f64>,
    /// Efforts \[N\].
    pub effort: Vec<f64>,
}

/// `geometry_msgs/Vector3`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Quaternion {
    /// No rotation.
    pub const IDENTITY: Quaternion = Quaternion {
        x: 0.0,
        y: 0.0,
        z: 0.0,
        w: 1.0,
    };
}

/// `geometry_msgs/Transform`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Transform {
    /// Translation \[m\].
    pub translation: Vector3,
    /// Rotation.
    pub rotation: Quaternion,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// Pose of the child in the parent.
    pub transform: Transform,
}

/// `tf2_msgs/TFMessage`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// Transforms.
    pub transforms: Vec<TransformStamped>,
}

/// `std_msgs/String`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    /// The text.
    pub data: String,
}

/// `std_msgs/Bool` (the latched emergency-stop state).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Bool {
    /// The value.
    pub data: bool,
}

/// `std_srvs/SetBool` request (the emergency stop: true engages, false releases).
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct SetBoolRequest {
    /// The value asked for.
    pub data: bool,
}

/// `std_srvs/SetBool` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetBoolResponse {
    /// Whether the value was set.
    pub success: bool,
    /// What happened, for a person.
    pub message: String,
}

/// `diagnostic_msgs/KeyValue`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct KeyValue {
    /// Key.
    pub key: String,
    /// Value.
    pub value: String,
}

/// `diagnostic_msgs/DiagnosticStatus`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticStatus {
    /// OK, WARN, ERROR or STALE.
    pub level: u8,
    /// Component name (`node: what`, as aggregators group by prefix).
    pub name: String,
    /// One line.
    pub message: String,
    /// Hardware id.
    pub hardware_id: String,
    /// Values.
    pub values: Vec<KeyValue>,
}

constants!(DiagnosticStatus: u8 {
    /// Level OK.
    OK: 0,
    /// Level WARN.
    WARN: 1,
    /// Level ERROR.
    ERROR: 2,
    /// Level STALE.
    STALE: 3,
});

/// `diagnostic_msgs/DiagnosticArray`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct DiagnosticArray {
    /// Stamp.
    pub header: Header,
    /// Statuses.
    pub status: Vec<DiagnosticStatus>,
}

/// `lifecycle_msgs/msg/State`: a lifecycle state (ids 1-4 primary, 10-15 transition states).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LifecycleState {
    /// The state's id.
    pub id: u8,
    /// Its label (`unconfigured`, `inactive`, ...).
    pub label: String,
}

/// `lifecycle_msgs/msg/Transition`: a lifecycle transition (1 configure, 2 cleanup, 3 activate,
/// 4 deactivate, 5-7 shutdown; 10-61 the results of the callbacks).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct LifecycleTransition {
    /// The transition's id.
    pub id: u8,
    /// Its label (`configure`, ...; a request's label takes precedence over its id).
    pub label: String,
}

/// `lifecycle_msgs/msg/TransitionDescription`: a transition between two states.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransitionDescription {
    /// The transition.
    pub transition: LifecycleTransition,
    /// Where it starts.
    pub start_state: LifecycleState,
    /// Where it goes.
    pub goal_state: LifecycleState,
}

/// `lifecycle_msgs/msg/TransitionEvent`: published on `~/transition_event` for every step.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TransitionEvent {
    /// When \[ns since the epoch\].
    pub timestamp: u64,
    /// The transition taken.
    pub transition: LifecycleTransition,
    /// From.
    pub start_state: LifecycleState,
    /// To.
    pub goal_state: LifecycleState,
}

/// `lifecycle_msgs/srv/ChangeState` request.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeStateRequest {
    /// The transition asked for.
    pub transition: LifecycleTransition,
}

/// `lifecycle_msgs/srv/ChangeState` response.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ChangeStateResponse {
    /// Whether the transition was taken and succeeded.
    pub success: bool,
}

/// An empty request (`lifecycle_msgs/srv/GetState`, `GetAvailableStates`,
/// `GetAvailableTransitions`): one placeholder byte on the wire, as rosidl generates it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct EmptyRequest {
    /// rosidl's placeholder member of an empty structure.
    pub structure_needs_at_least_one_member: u8,
}

/// `lifecycle_msgs/srv/GetState` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetStateResponse {
    /// The current state.
    pub current_state: LifecycleState,
}

/// `lifecycle_msgs/srv/GetAvailableStates` response.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetAvailableStatesResponse {
    /// Every state of the machine.
    pub available_states: Vec<LifecycleState>,
}

/// `lifecycle_msgs/srv/GetAvailableTransitions` response (also `~/get_transition_graph`'s).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GetAvailableTransitionsResponse {
    /// The transitions from the current state (the whole graph for `~/get_transition_graph`).
    pub available_transitions: Vec<TransitionDescription>,
}
