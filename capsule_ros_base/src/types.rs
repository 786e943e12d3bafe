//! ROS type names of the capsule interfaces, as ros2-client takes them (from
//! [`capsule_msgs::names::type_names`]).

use capsule_msgs::names::type_names::{self as n, split};
use ros2_client::{MessageTypeName, ServiceTypeName};

fn message(full: &str) -> MessageTypeName {
    let (package, name) = split(full);
    MessageTypeName::new(package, name)
}
fn service(full: &str) -> ServiceTypeName {
    let (package, name) = split(full);
    ServiceTypeName::new(package, name)
}
/// `capsule_msgs/msg/CapsuleState`.
pub fn state() -> MessageTypeName {
    message(n::STATE)
}
/// `capsule_msgs/msg/ActuatorForce`.
pub fn force() -> MessageTypeName {
    message(n::FORCE)
}
/// `capsule_msgs/msg/ControllerStatus`.
pub fn status() -> MessageTypeName {
    message(n::STATUS)
}
/// `sensor_msgs/msg/JointState` (joint_states and the JointState commands).
pub fn joint_state() -> MessageTypeName {
    message(n::JOINT_STATE)
}
/// `rosgraph_msgs/msg/Clock`.
pub fn clock() -> MessageTypeName {
    message(n::CLOCK)
}
/// `capsule_msgs/srv/SetMode`.
pub fn set_mode() -> ServiceTypeName {
    service(n::SET_MODE)
}
/// `diagnostic_msgs/msg/DiagnosticArray` (`/diagnostics`).
pub fn diagnostics() -> MessageTypeName {
    message(n::DIAGNOSTIC_ARRAY)
}
/// `std_msgs/msg/Bool` (the emergency-stop state).
pub fn bool() -> MessageTypeName {
    message(n::BOOL)
}
/// `std_srvs/srv/SetBool` (the emergency stop).
pub fn set_bool() -> ServiceTypeName {
    service(n::SET_BOOL)
}
