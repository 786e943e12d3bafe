//! The ROS 2 types a capsule recording holds, their `ros2msg` schemas, the service-event type
//! (ROS 2 service introspection), `/clock`, and the QoS text rosbag2 writes on every channel.

use capsule_msgs::{
    interface::TIME_MSG, ActuatorForce, CapsuleState, ControllerStatus, RosInterface,
    SetModeRequest, SetModeResponse, Time,
};
use serde::{Deserialize, Serialize};

/// `rosgraph_msgs/msg/Clock`: the simulation time on `/clock`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct Clock {
    /// The current simulation time.
    pub clock: Time,
}

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

impl ServiceEventInfo {
    /// A client sent the request.
    pub const REQUEST_SENT: u8 = 0;
    /// The server received the request.
    pub const REQUEST_RECEIVED: u8 = 1;
    /// The server sent the response.
    pub const RESPONSE_SENT: u8 = 2;
    /// The client received the response.
    pub const RESPONSE_RECEIVED: u8 = 3;
}

/// One service event of `set_mode`: the layout rosidl generates for service introspection
/// (`SetMode_Event`: info, then request and response as bounded sequences of at most one),
/// recorded as `capsule_msgs/msg/SetModeEvent`. Why not the rosidl name: both reference
/// readers refuse `srv` types in MCAP schemas (`mcap-ros2-support` rejects the `_` in
/// `SetMode_Event`, `rosbags` files it under `capsule_msgs/srv/msg/...`), so the recording uses
/// an underscore-free `msg` name with byte-identical CDR.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SetModeEvent {
    /// Event kind, time, client and sequence number.
    pub info: ServiceEventInfo,
    /// The request (empty when not introspected).
    pub request: Vec<SetModeRequest>,
    /// The response (empty on request events).
    pub response: Vec<SetModeResponse>,
}

/// `service_msgs/msg/ServiceEventInfo` text (Jazzy).
pub const SERVICE_EVENT_INFO_MSG: &str = "uint8 REQUEST_SENT = 0\nuint8 REQUEST_RECEIVED = 1\nuint8 RESPONSE_SENT = 2\nuint8 RESPONSE_RECEIVED = 3\n\nuint8 event_type\nbuiltin_interfaces/Time stamp\nchar[16] client_gid\nint64 sequence_number\n";

/// `capsule_msgs/msg/SetModeEvent` text (the fields of rosidl's `SetMode_Event`).
pub const SET_MODE_EVENT_MSG: &str = "service_msgs/ServiceEventInfo info\ncapsule_msgs/SetModeRequest[<=1] request\ncapsule_msgs/SetModeResponse[<=1] response\n";

/// `rosgraph_msgs/msg/Clock` text.
pub const CLOCK_MSG: &str = "builtin_interfaces/Time clock\n";

/// ROS 2 type names (`pkg/msg/Type`) of every type a capsule recording holds.
pub mod names {
    /// `/capsule/state`.
    pub const STATE: &str = "capsule_msgs/msg/CapsuleState";
    /// `/capsule/actuator_force`.
    pub const FORCE: &str = "capsule_msgs/msg/ActuatorForce";
    /// `/capsule_controller/status`.
    pub const STATUS: &str = "capsule_msgs/msg/ControllerStatus";
    /// `/clock`.
    pub const CLOCK: &str = "rosgraph_msgs/msg/Clock";
    /// `/capsule_controller/set_mode/_service_event`.
    pub const SET_MODE_EVENT: &str = "capsule_msgs/msg/SetModeEvent";
}

/// The topic names of a default capsule graph.
pub mod topics {
    /// Plant state.
    pub const STATE: &str = "/capsule/state";
    /// Force commands.
    pub const FORCE: &str = "/capsule/actuator_force";
    /// Controller status.
    pub const STATUS: &str = "/capsule_controller/status";
    /// Simulation clock.
    pub const CLOCK: &str = "/clock";
    /// Mode changes (service introspection of `/capsule_controller/set_mode`).
    pub const SET_MODE_EVENT: &str = "/capsule_controller/set_mode/_service_event";
}

fn section(out: &mut String, name: &str, text: &str) {
    if !out.ends_with('\n') {
        out.push('\n');
    }
    out.push_str(&"=".repeat(80));
    out.push_str("\nMSG: ");
    out.push_str(name);
    out.push('\n');
    out.push_str(text);
}

/// The `ros2msg` schema (the type's text, then every dependency after a `=` line) of a type
/// this crate knows, or `None`.
pub fn ros2msg_schema(type_name: &str) -> Option<String> {
    Some(match type_name {
        names::STATE => CapsuleState::ros2msg_schema(),
        names::FORCE => ActuatorForce::ros2msg_schema(),
        names::STATUS => ControllerStatus::ros2msg_schema(),
        names::CLOCK => {
            let mut s = CLOCK_MSG.to_string();
            section(&mut s, "builtin_interfaces/msg/Time", TIME_MSG);
            s
        }
        names::SET_MODE_EVENT => {
            let mut s = SET_MODE_EVENT_MSG.to_string();
            section(
                &mut s,
                "service_msgs/msg/ServiceEventInfo",
                SERVICE_EVENT_INFO_MSG,
            );
            section(&mut s, "builtin_interfaces/msg/Time", TIME_MSG);
            section(
                &mut s,
                "capsule_msgs/msg/SetModeRequest",
                SetModeRequest::definition(),
            );
            section(
                &mut s,
                "capsule_msgs/msg/SetModeResponse",
                SetModeResponse::definition(),
            );
            s
        }
        _ => return None,
    })
}

/// Every type name [`ros2msg_schema`] knows.
pub const KNOWN_TYPES: [&str; 5] = [
    names::STATE,
    names::FORCE,
    names::STATUS,
    names::CLOCK,
    names::SET_MODE_EVENT,
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
        let s = ros2msg_schema(names::STATE).unwrap_or_default();
        let h = s.find("MSG: std_msgs/msg/Header").unwrap_or(usize::MAX);
        let t = s
            .find("MSG: builtin_interfaces/msg/Time")
            .unwrap_or(usize::MAX);
        assert!(h < t && t < usize::MAX, "{s}");
        assert!(s.starts_with(CapsuleState::definition()));
    }

    #[test]
    fn every_known_type_has_a_schema_and_unknown_types_none() {
        for t in KNOWN_TYPES {
            let s = ros2msg_schema(t).unwrap_or_default();
            assert!(!s.is_empty(), "{t}");
            // every nested type the text names is defined after a separator
            for line in s.lines() {
                let ty = line.split_whitespace().next().unwrap_or("");
                if ty.contains('/') && !line.starts_with("MSG:") {
                    let base = ty.split('[').next().unwrap_or(ty);
                    let (pkg, name) = base.split_once('/').unwrap_or(("", ""));
                    assert!(
                        s.contains(&format!("MSG: {pkg}/msg/{name}\n"))
                            || s.contains(&format!("MSG: {pkg}/srv/{name}\n")),
                        "{t}: {base} not appended"
                    );
                }
            }
        }
        assert!(ros2msg_schema("sensor_msgs/msg/Imu").is_none());
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
