//! The ROS 2 types a capsule recording holds, their `ros2msg` schemas, the service-event type
//! (ROS 2 service introspection), and the QoS text rosbag2 writes on every channel.

use capsule_msgs::{
    actions::{
        CancelGoalRequest, CancelGoalResponse, GetResultRequest, GetResultResponse,
        SendGoalRequest, SendGoalResponse,
    },
    constants,
    interface::{
        nested_definition, ros2msg_text, split_action, split_service, CANCEL_GOAL_SRV,
        GOAL_STATUS_ARRAY_MSG, GOAL_STATUS_MSG, MOVE_ACTION, SWITCH_ATTRACTOR_ACTION,
    },
    names::type_names,
    ActuatorForce, CapsuleState, ControllerStatus, RosInterface, SetModeRequest, SetModeResponse,
    Time,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::sync::LazyLock;

/// `service_msgs/msg/ServiceEventInfo` (ROS 2 Jazzy): what a service event reports.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceEventInfo {
    /// One of the `REQUEST_*` / `RESPONSE_*` constants.
    pub event_type: u8,
    /// When the event happened.
    pub stamp: Time,
    /// The calling client's GID.
    pub client_gid: [u8; 16],
    /// The request's sequence number (pairs a response with its request).
    pub sequence_number: i64,
}

constants!(ServiceEventInfo: u8 {
    /// A client sent the request.
    REQUEST_SENT: 0,
    /// The server received the request.
    REQUEST_RECEIVED: 1,
    /// The server sent the response.
    RESPONSE_SENT: 2,
    /// The client received the response.
    RESPONSE_RECEIVED: 3,
});

/// One service event: the layout rosidl generates for service introspection (`S_Event`: info,
/// then request and response as bounded sequences of at most one, empty when not introspected
/// or not of the event's kind).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ServiceEvent<Q, A> {
    /// Event kind, time, client and sequence number.
    pub info: ServiceEventInfo,
    /// The request (on request events).
    pub request: Vec<Q>,
    /// The response (on response events).
    pub response: Vec<A>,
}

/// One service event of `set_mode`, recorded as `capsule_msgs/msg/SetModeEvent`. Why not the
/// rosidl name: both Python reference readers refuse `srv` types in MCAP schemas
/// (`mcap-ros2-support` rejects the `_` in `SetMode_Event`, `rosbags` files it under
/// `capsule_msgs/srv/msg/...`), so the recording uses an underscore-free `msg` name with
/// byte-identical CDR. (The actions' events keep rosidl's names: rosbags and Foxglove read
/// them, see [`ACTION_EVENT_TYPES`].)
pub type SetModeEvent = ServiceEvent<SetModeRequest, SetModeResponse>;

/// An action's `send_goal` service event (rosidl's `A_SendGoal_Event`), goals `G`.
pub type SendGoalEvent<G> = ServiceEvent<SendGoalRequest<G>, SendGoalResponse>;

/// An action's `get_result` service event (rosidl's `A_GetResult_Event`), results `R`.
pub type GetResultEvent<R> = ServiceEvent<GetResultRequest, GetResultResponse<R>>;

/// An action's `cancel_goal` service event (`action_msgs/srv/CancelGoal_Event`).
pub type CancelGoalEvent = ServiceEvent<CancelGoalRequest, CancelGoalResponse>;

/// `service_msgs/msg/ServiceEventInfo` text (Jazzy).
pub const SERVICE_EVENT_INFO_MSG: &str = "uint8 REQUEST_SENT = 0\nuint8 REQUEST_RECEIVED = 1\nuint8 RESPONSE_SENT = 2\nuint8 RESPONSE_RECEIVED = 3\n\nuint8 event_type\nbuiltin_interfaces/Time stamp\nchar[16] client_gid\nint64 sequence_number\n";

/// `capsule_msgs/msg/SetModeEvent` text (the fields of rosidl's `SetMode_Event`).
pub const SET_MODE_EVENT_MSG: &str = "service_msgs/ServiceEventInfo info\ncapsule_msgs/SetModeRequest[<=1] request\ncapsule_msgs/SetModeResponse[<=1] response\n";

/// `rosgraph_msgs/msg/Clock` text.
pub const CLOCK_MSG: &str = "builtin_interfaces/Time clock\n";

/// `diagnostic_msgs/msg/DiagnosticArray` text (Jazzy; nested types spelled with their package,
/// as Foxglove resolves a field only against a `MSG:` line of its exact spelling).
pub const DIAGNOSTIC_ARRAY_MSG: &str = "# This message is used to send diagnostic information about the state of the robot.\nstd_msgs/Header header # for timestamp\ndiagnostic_msgs/DiagnosticStatus[] status # an array of components being reported on\n";

/// `diagnostic_msgs/msg/DiagnosticStatus` text (Jazzy).
pub const DIAGNOSTIC_STATUS_MSG: &str = "# This message holds the status of an individual component of the robot.\n\n# Possible levels of operations.\nbyte OK=0\nbyte WARN=1\nbyte ERROR=2\nbyte STALE=3\n\n# Level of operation enumerated above.\nbyte level\n# A description of the test/component reporting.\nstring name\n# A description of the status.\nstring message\n# A hardware unique string.\nstring hardware_id\n# An array of values associated with the status.\ndiagnostic_msgs/KeyValue[] values\n";

/// `diagnostic_msgs/msg/KeyValue` text (Jazzy).
pub const KEY_VALUE_MSG: &str = "# What to label this value when viewing.\nstring key\n# A value to track over time.\nstring value\n";

/// `action_msgs/msg/GoalStatusArray` text, its nested type spelled with its package (as
/// Foxglove resolves a field only against a `MSG:` line of its exact spelling).
static GOAL_STATUS_ARRAY_TEXT: LazyLock<String> =
    LazyLock::new(|| GOAL_STATUS_ARRAY_MSG.replace("GoalStatus[]", "action_msgs/GoalStatus[]"));

/// `action_msgs/msg/GoalStatus` text, spelled likewise.
static GOAL_STATUS_TEXT: LazyLock<String> = LazyLock::new(|| {
    GOAL_STATUS_MSG.replace("\nGoalInfo goal_info", "\naction_msgs/GoalInfo goal_info")
});

/// The text of a nested type a recording's schemas name, by its spelling in a field.
fn nested_text(spelled: &str) -> Option<&'static str> {
    match spelled {
        "diagnostic_msgs/DiagnosticStatus" => Some(DIAGNOSTIC_STATUS_MSG),
        "diagnostic_msgs/KeyValue" => Some(KEY_VALUE_MSG),
        "service_msgs/ServiceEventInfo" => Some(SERVICE_EVENT_INFO_MSG),
        "capsule_msgs/SetModeRequest" => Some(SetModeRequest::definition()),
        "capsule_msgs/SetModeResponse" => Some(SetModeResponse::definition()),
        "action_msgs/GoalStatus" => Some(GOAL_STATUS_TEXT.as_str()),
        other => nested_definition(other).map(|d| d.1),
    }
}

/// The `ros2msg` schema (the type's text, then every dependency after a `=` line, named as
/// the field spells it: see [`ros2msg_text`]) of a type this crate knows, or `None`.
pub fn ros2msg_schema(type_name: &str) -> Option<String> {
    let (root, package) = match type_name {
        type_names::STATE => return Some(CapsuleState::ros2msg_schema()),
        type_names::FORCE => return Some(ActuatorForce::ros2msg_schema()),
        type_names::STATUS => return Some(ControllerStatus::ros2msg_schema()),
        type_names::CLOCK => (CLOCK_MSG, "rosgraph_msgs"),
        type_names::SET_MODE_EVENT => (SET_MODE_EVENT_MSG, "capsule_msgs"),
        type_names::DIAGNOSTIC_ARRAY => (DIAGNOSTIC_ARRAY_MSG, "diagnostic_msgs"),
        type_names::GOAL_STATUS_ARRAY => (GOAL_STATUS_ARRAY_TEXT.as_str(), "action_msgs"),
        type_names::MOVE_FEEDBACK_MESSAGE => {
            return Some(feedback_message_schema(type_names::MOVE, MOVE_ACTION))
        }
        type_names::SWITCH_ATTRACTOR_FEEDBACK_MESSAGE => {
            return Some(feedback_message_schema(
                type_names::SWITCH_ATTRACTOR,
                SWITCH_ATTRACTOR_ACTION,
            ))
        }
        t if ACTION_EVENT_TYPES.contains(&t) => return action_event_schema(t),
        _ => return None,
    };
    Some(ros2msg_text(root, package, &nested_text))
}

/// The schema of `action`'s `_FeedbackMessage` (`pkg/action/A`, its `.action` text): the goal
/// id and the feedback part, as rosidl derives the message (`unique_identifier_msgs/UUID
/// goal_id`, `A_Feedback feedback`; spelled with its package here, as Foxglove resolves it).
fn feedback_message_schema(action: &str, action_text: &'static str) -> String {
    let (package, name) = type_names::split(action);
    let feedback = format!("{package}/{name}_Feedback");
    let root = format!("unique_identifier_msgs/UUID goal_id\n{feedback} feedback\n");
    let (_, _, feedback_text) = split_action(action_text);
    ros2msg_text(&root, package, &|t| {
        if t == feedback {
            Some(feedback_text)
        } else {
            nested_text(t)
        }
    })
}

/// The types of the actions' topics a recording holds (feedback and status).
pub const ACTION_TOPIC_TYPES: [&str; 3] = [
    type_names::MOVE_FEEDBACK_MESSAGE,
    type_names::SWITCH_ATTRACTOR_FEEDBACK_MESSAGE,
    type_names::GOAL_STATUS_ARRAY,
];

/// The types of the actions' service events a recording holds (`<action>/_action/<service>/
/// _service_event`, as rosbag2 records an action): rosidl's names, as rcl publishes them.
pub const ACTION_EVENT_TYPES: [&str; 5] = [
    type_names::MOVE_SEND_GOAL_EVENT,
    type_names::MOVE_GET_RESULT_EVENT,
    type_names::SWITCH_ATTRACTOR_SEND_GOAL_EVENT,
    type_names::SWITCH_ATTRACTOR_GET_RESULT_EVENT,
    type_names::CANCEL_GOAL_EVENT,
];

/// The REP-2016 hash of a type as recorded: capsule_msgs' hash of it, or of the rosidl type a
/// recording names otherwise (`cancel_goal`'s events, see
/// [`type_names::CANCEL_GOAL_EVENT`]).
pub fn type_hash(recorded: &str) -> Option<&'static str> {
    match recorded {
        type_names::CANCEL_GOAL_EVENT => {
            capsule_msgs::hashes::of("action_msgs/srv/CancelGoal_Event")
        }
        other => capsule_msgs::hashes::of(other),
    }
}

/// The texts of the types an action's service events nest, by the spelling their fields use
/// (`capsule_msgs/Move_SendGoal_Request`; with the package, as Foxglove resolves a field only
/// against a `MSG:` line of its exact spelling): each action's goal, result, and its two
/// services' halves as rosidl derives them, and `action_msgs/srv/CancelGoal`'s halves.
static ACTION_PARTS: LazyLock<BTreeMap<String, String>> = LazyLock::new(|| {
    let mut parts = BTreeMap::new();
    for (action, text) in [
        (type_names::MOVE, MOVE_ACTION),
        (type_names::SWITCH_ATTRACTOR, SWITCH_ATTRACTOR_ACTION),
    ] {
        let (package, name) = type_names::split(action);
        let part = |p: &str| format!("{package}/{name}_{p}");
        let (goal, result, _) = split_action(text);
        let uuid = "unique_identifier_msgs/UUID goal_id\n";
        for (p, t) in [
            ("Goal", goal.to_string()),
            ("Result", result.to_string()),
            ("SendGoal_Request", format!("{uuid}{} goal\n", part("Goal"))),
            (
                "SendGoal_Response",
                "bool accepted\nbuiltin_interfaces/Time stamp\n".to_string(),
            ),
            ("GetResult_Request", uuid.to_string()),
            (
                "GetResult_Response",
                format!("int8 status\n{} result\n", part("Result")),
            ),
        ] {
            parts.insert(part(p), t);
        }
    }
    let (request, response) = split_service(CANCEL_GOAL_SRV);
    // its fields name `GoalInfo` without the package
    let spelled = |t: &str| -> String {
        t.lines()
            .map(|l| match l.starts_with("GoalInfo") {
                true => format!("action_msgs/{l}\n"),
                false => format!("{l}\n"),
            })
            .collect()
    };
    parts.insert("action_msgs/CancelGoal_Request".into(), spelled(request));
    parts.insert("action_msgs/CancelGoal_Response".into(), spelled(response));
    parts
});

/// The schema of an action's service-event type (one of [`ACTION_EVENT_TYPES`]): rosidl's
/// `S_Event` fields, its request and response spelled as in [`ACTION_PARTS`].
fn action_event_schema(event_type: &str) -> Option<String> {
    let (package, name) = type_names::split(event_type);
    let service = name.strip_suffix("_Event")?;
    let root = format!(
        "service_msgs/ServiceEventInfo info\n{package}/{service}_Request[<=1] request\n{package}/{service}_Response[<=1] response\n"
    );
    Some(ros2msg_text(&root, package, &|t| {
        ACTION_PARTS
            .get(t)
            .map(String::as_str)
            .or_else(|| nested_text(t))
    }))
}

/// Every type name [`ros2msg_schema`] knows.
pub const KNOWN_TYPES: [&str; 6] = [
    type_names::STATE,
    type_names::FORCE,
    type_names::STATUS,
    type_names::CLOCK,
    type_names::SET_MODE_EVENT,
    type_names::DIAGNOSTIC_ARRAY,
];

/// Reliability of an offered QoS profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reliability {
    /// Every sample is delivered (retransmitted when lost).
    Reliable,
    /// Samples may be dropped.
    BestEffort,
}

/// Durability of an offered QoS profile.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Durability {
    /// Late joiners get nothing from the past.
    Volatile,
    /// Late joiners get the last `depth` samples.
    TransientLocal,
}

/// The QoS a publisher offered, as rosbag2 stores it in `offered_qos_profiles`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OfferedQos {
    /// Reliability.
    pub reliability: Reliability,
    /// Durability.
    pub durability: Durability,
    /// Keep-last depth.
    pub depth: u32,
}

impl OfferedQos {
    /// Reliable, volatile, keep last `depth` (the ROS 2 default profile).
    pub const fn reliable(depth: u32) -> Self {
        OfferedQos {
            reliability: Reliability::Reliable,
            durability: Durability::Volatile,
            depth,
        }
    }

    /// The YAML list rosbag2 writes in channel metadata `offered_qos_profiles`
    /// (numeric enums: history 1 = keep last, reliability 1 = reliable / 2 = best effort,
    /// durability 1 = transient local / 2 = volatile, liveliness 1 = automatic).
    pub fn to_yaml(&self) -> String {
        let rel = match self.reliability {
            Reliability::Reliable => 1,
            Reliability::BestEffort => 2,
        };
        let dur = match self.durability {
            Durability::TransientLocal => 1,
            Durability::Volatile => 2,
        };
        let inf = "\n    sec: 2147483647\n    nsec: 4294967295";
        format!(
            "- history: 1\n  depth: {}\n  reliability: {rel}\n  durability: {dur}\n  deadline:{inf}\n  lifespan:{inf}\n  liveliness: 1\n  liveliness_lease_duration:{inf}\n  avoid_ros_namespace_conventions: false",
            self.depth
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn state_schema_appends_header_then_time() {
        let s = ros2msg_schema(type_names::STATE).unwrap_or_default();
        let h = s.find("\nMSG: std_msgs/Header\n").unwrap_or(usize::MAX);
        let t = s
            .find("\nMSG: builtin_interfaces/Time\n")
            .unwrap_or(usize::MAX);
        assert!(h < t && t < usize::MAX, "{s}");
        assert!(s.starts_with(CapsuleState::definition()));
    }

    #[test]
    fn every_field_type_has_a_msg_block_of_exactly_its_spelling() {
        for t in KNOWN_TYPES
            .into_iter()
            .chain(ACTION_TOPIC_TYPES)
            .chain(ACTION_EVENT_TYPES)
        {
            let s = ros2msg_schema(t).unwrap_or_default();
            assert!(!s.is_empty(), "{t}");
            let blocks: Vec<&str> = s.lines().filter_map(|l| l.strip_prefix("MSG: ")).collect();
            // every nested type a line names is defined once, under the field's spelling
            // (Foxglove's `@foxglove/rosmsg` resolves nothing else)
            for line in s.lines().filter(|l| !l.starts_with("MSG:")) {
                let ty = line.split_whitespace().next().unwrap_or("");
                if ty.contains('/') {
                    let base = ty.split('[').next().unwrap_or(ty);
                    assert_eq!(
                        blocks.iter().filter(|b| **b == base).count(),
                        1,
                        "{t}: {base} not appended once:\n{s}"
                    );
                }
            }
            assert!(blocks.iter().all(|b| !b.contains("/msg/")), "{t}:\n{s}");
        }
        assert!(ros2msg_schema("sensor_msgs/msg/Imu").is_none());
    }

    #[test]
    fn action_event_schemas_nest_the_request_and_response_rosidl_derives() {
        let s = ros2msg_schema(type_names::MOVE_SEND_GOAL_EVENT).unwrap_or_default();
        assert!(s.starts_with(
            "service_msgs/ServiceEventInfo info\ncapsule_msgs/Move_SendGoal_Request[<=1] request\n"
        ));
        for block in [
            "MSG: capsule_msgs/Move_SendGoal_Request\nunique_identifier_msgs/UUID goal_id\ncapsule_msgs/Move_Goal goal\n",
            "MSG: capsule_msgs/Move_SendGoal_Response\nbool accepted\nbuiltin_interfaces/Time stamp\n",
        ] {
            assert!(s.contains(block), "{s}");
        }
        let r = ros2msg_schema(type_names::SWITCH_ATTRACTOR_GET_RESULT_EVENT).unwrap_or_default();
        assert!(
            r.contains("int8 status\ncapsule_msgs/SwitchAttractor_Result result\n"),
            "{r}"
        );
        let c = ros2msg_schema(type_names::CANCEL_GOAL_EVENT).unwrap_or_default();
        assert!(
            c.contains("\naction_msgs/GoalInfo[] goals_canceling"),
            "{c}"
        );
        // rosbag2's metadata names each with its REP-2016 hash
        for t in ACTION_EVENT_TYPES {
            assert!(
                type_hash(t).is_some_and(|h| h.starts_with("RIHS01_")),
                "{t}"
            );
        }
        assert_eq!(
            type_hash(type_names::STATE),
            capsule_msgs::hashes::of(type_names::STATE)
        );
    }

    #[test]
    fn qos_yaml_names_the_policies() {
        let y = OfferedQos::reliable(10).to_yaml();
        assert!(y.starts_with("- history: 1\n  depth: 10\n  reliability: 1\n  durability: 2"));
        let be = OfferedQos {
            reliability: Reliability::BestEffort,
            durability: Durability::TransientLocal,
            depth: 1,
        };
        assert!(be.to_yaml().contains("reliability: 2\n  durability: 1"));
    }
}
