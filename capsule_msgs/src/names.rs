//! The capsule graph's names, each written once: node, topic and service names as the nodes
//! declare them ([`topics`]: relative or private, so `__ns` and `__node` move them), the same
//! names as the default graph resolves them ([`default_topics`]: what recordings hold), and the
//! ROS 2 type names of everything on them ([`type_names`]).

// Each name's text once; the modules below build the declared and resolved forms from it.
macro_rules! state {
    () => {
        "capsule/state"
    };
}
macro_rules! force {
    () => {
        "capsule/actuator_force"
    };
}
macro_rules! controller {
    () => {
        "capsule_controller"
    };
}
macro_rules! status {
    () => {
        "status"
    };
}
macro_rules! set_mode {
    () => {
        "set_mode"
    };
}

/// Node names.
pub mod nodes {
    /// The plant node.
    pub const PLANT: &str = "capsule_plant";
    /// The controller node.
    pub const CONTROLLER: &str = controller!();
    /// The recorder node.
    pub const RECORDER: &str = "capsule_recorder";
    /// The Foxglove live view.
    pub const FOXGLOVE: &str = "capsule_foxglove";
}

/// Topic and service names as the nodes declare them.
pub mod topics {
    /// Plant state (`capsule_msgs/msg/CapsuleState`).
    pub const STATE: &str = state!();
    /// Force commands (`capsule_msgs/msg/ActuatorForce`).
    pub const FORCE: &str = force!();
    /// Controller status, private to the controller node.
    pub const STATUS: &str = concat!("~/", status!());
    /// Mode service, private to the controller node.
    pub const SET_MODE: &str = concat!("~/", set_mode!());
    /// The Move action (`capsule_msgs/action/Move`), private to the controller node.
    pub const MOVE: &str = "~/move";
    /// The attractor switch as an action (`capsule_msgs/action/SwitchAttractor`), private to
    /// the controller node.
    pub const SWITCH_ATTRACTOR: &str = "~/switch_attractor";
    /// Simulation clock (absolute, as in ROS).
    pub const CLOCK: &str = "/clock";
    /// JointState commands, as topic_based_ros2_control sends them (the plant's
    /// `--joint-commands`).
    pub const JOINT_COMMANDS: &str = "capsule/joint_commands";
    /// The plant's emergency stop, latched (transient local): true while engaged.
    pub const EMERGENCY_STOP: &str = "capsule/emergency_stop";
    /// The plant's emergency-stop service (`std_srvs/srv/SetBool`: true engages, false releases).
    pub const EMERGENCY_STOP_SERVICE: &str = "~/emergency_stop";
    /// A lock-step plant's pause (`std_srvs/srv/SetBool`: true pauses, false resumes).
    pub const PAUSE_SERVICE: &str = "~/pause";
    /// A managed node's lifecycle (as rclcpp_lifecycle serves it): `(name, type)` of each
    /// service and of the event topic.
    pub mod lifecycle {
        /// `(name, type)`: a service or topic and its ROS 2 type.
        pub type Endpoint = (&'static str, &'static str);
        /// Asks for a transition.
        pub const CHANGE_STATE: Endpoint = ("~/change_state", "lifecycle_msgs/srv/ChangeState");
        /// The current state.
        pub const GET_STATE: Endpoint = ("~/get_state", "lifecycle_msgs/srv/GetState");
        /// Every state.
        pub const GET_AVAILABLE_STATES: Endpoint = (
            "~/get_available_states",
            "lifecycle_msgs/srv/GetAvailableStates",
        );
        /// The transitions from the current state.
        pub const GET_AVAILABLE_TRANSITIONS: Endpoint = (
            "~/get_available_transitions",
            "lifecycle_msgs/srv/GetAvailableTransitions",
        );
        /// Every transition (the type of `get_available_transitions`).
        pub const GET_TRANSITION_GRAPH: Endpoint = (
            "~/get_transition_graph",
            "lifecycle_msgs/srv/GetAvailableTransitions",
        );
        /// Every step taken.
        pub const TRANSITION_EVENT: Endpoint =
            ("~/transition_event", "lifecycle_msgs/msg/TransitionEvent");
    }

    /// The standard-type topics of the plant's views (what RViz, Foxglove, robot_state_publisher
    /// and diagnostics aggregators read; relative ones move with the namespace, as in ROS).
    pub mod views {
        /// Joint states (`sensor_msgs/msg/JointState`).
        pub const JOINT_STATES: &str = "joint_states";
        /// Transforms (`tf2_msgs/msg/TFMessage`).
        pub const TF: &str = "/tf";
        /// The URDF (`std_msgs/msg/String`, transient local).
        pub const ROBOT_DESCRIPTION: &str = "robot_description";
        /// Diagnostics (`diagnostic_msgs/msg/DiagnosticArray`).
        pub const DIAGNOSTICS: &str = "/diagnostics";
    }
}

/// Topic names in the default graph (no namespace, default node names).
pub mod default_topics {
    /// Plant state.
    pub const STATE: &str = concat!("/", state!());
    /// Force commands.
    pub const FORCE: &str = concat!("/", force!());
    /// Controller status.
    pub const STATUS: &str = concat!("/", controller!(), "/", status!());
    /// Mode changes (service introspection of the mode service).
    pub const SET_MODE_EVENT: &str =
        concat!("/", controller!(), "/", set_mode!(), "/_service_event");
    /// Simulation clock.
    pub const CLOCK: &str = super::topics::CLOCK;
}

/// ROS 2 type names (`package/msg/Type`, as rosbag2 and MCAP schemas write them).
pub mod type_names {
    /// Plant state.
    pub const STATE: &str = "capsule_msgs/msg/CapsuleState";
    /// Force command.
    pub const FORCE: &str = "capsule_msgs/msg/ActuatorForce";
    /// Controller status.
    pub const STATUS: &str = "capsule_msgs/msg/ControllerStatus";
    /// The mode service.
    pub const SET_MODE: &str = "capsule_msgs/srv/SetMode";
    /// A recorded mode change (see `capsule_record::types::SetModeEvent` for why not `srv`).
    pub const SET_MODE_EVENT: &str = "capsule_msgs/msg/SetModeEvent";
    /// Simulation clock.
    pub const CLOCK: &str = "rosgraph_msgs/msg/Clock";
    /// The Move action.
    pub const MOVE: &str = "capsule_msgs/action/Move";
    /// The attractor switch as an action.
    pub const SWITCH_ATTRACTOR: &str = "capsule_msgs/action/SwitchAttractor";
    /// The Move action's feedback topic (rosidl's derived message).
    pub const MOVE_FEEDBACK_MESSAGE: &str = "capsule_msgs/action/Move_FeedbackMessage";
    /// The SwitchAttractor action's feedback topic (rosidl's derived message).
    pub const SWITCH_ATTRACTOR_FEEDBACK_MESSAGE: &str =
        "capsule_msgs/action/SwitchAttractor_FeedbackMessage";
    /// Every action's status topic.
    pub const GOAL_STATUS_ARRAY: &str = "action_msgs/msg/GoalStatusArray";
    /// The Move action's `send_goal` service events (rosidl's derived message).
    pub const MOVE_SEND_GOAL_EVENT: &str = "capsule_msgs/action/Move_SendGoal_Event";
    /// The Move action's `get_result` service events (rosidl's derived message).
    pub const MOVE_GET_RESULT_EVENT: &str = "capsule_msgs/action/Move_GetResult_Event";
    /// The SwitchAttractor action's `send_goal` service events.
    pub const SWITCH_ATTRACTOR_SEND_GOAL_EVENT: &str =
        "capsule_msgs/action/SwitchAttractor_SendGoal_Event";
    /// The SwitchAttractor action's `get_result` service events.
    pub const SWITCH_ATTRACTOR_GET_RESULT_EVENT: &str =
        "capsule_msgs/action/SwitchAttractor_GetResult_Event";
    /// Every action's `cancel_goal` service events as a recording names them. rosidl's name is
    /// `action_msgs/srv/CancelGoal_Event` (on DDS `action_msgs::srv::dds_::CancelGoal_Event_`,
    /// as published), but rosbags 0.11 reads no `srv` type in an MCAP schema (it files it under
    /// `action_msgs/srv/msg/`, then fails to open the file: KeyError), so the recording files it
    /// under `msg`, with the same fields and bytes.
    pub const CANCEL_GOAL_EVENT: &str = "action_msgs/msg/CancelGoal_Event";
    /// Every action's cancel service.
    pub const CANCEL_GOAL: &str = "action_msgs/srv/CancelGoal";
    /// Joint states and JointState commands.
    pub const JOINT_STATE: &str = "sensor_msgs/msg/JointState";

    /// Diagnostics (every node's, on `/diagnostics`).
    pub const DIAGNOSTIC_ARRAY: &str = "diagnostic_msgs/msg/DiagnosticArray";

    /// The emergency-stop state.
    pub const BOOL: &str = "std_msgs/msg/Bool";
    /// The emergency-stop service.
    pub const SET_BOOL: &str = "std_srvs/srv/SetBool";

    /// `(package, Type)` of a `package/msg/Type` or `package/srv/Type` name.
    pub fn split(full: &str) -> (&str, &str) {
        let package = full.split('/').next().unwrap_or(full);
        let name = full.rsplit('/').next().unwrap_or(full);
        (package, name)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolved_names_are_the_declared_ones_in_the_default_graph() {
        assert_eq!(default_topics::STATE, "/capsule/state");
        assert_eq!(default_topics::STATUS, "/capsule_controller/status");
        assert_eq!(
            default_topics::SET_MODE_EVENT,
            "/capsule_controller/set_mode/_service_event"
        );
        assert_eq!(
            type_names::split(type_names::SET_MODE),
            ("capsule_msgs", "SetMode")
        );
    }
}
