//! The interface files themselves: embedded texts, ROS / DDS type names, `ros2msg` schemas,
//! and a small parser of the `.msg` / `.srv` syntax (fields and constants).

use crate::actions::{
    MoveFeedback, MoveGoal, MoveResult, SwitchAttractorFeedback, SwitchAttractorGoal,
    SwitchAttractorResult,
};
use crate::{
    ActuatorForce, CapsuleState, ControllerStatus, Header, SetModeRequest, SetModeResponse, Time,
};
use serde::Serialize;

/// `builtin_interfaces/msg/Time` as rosidl defines it.
pub const TIME_MSG: &str = include_str!("../std_interfaces/builtin_interfaces/msg/Time.msg");
/// `std_msgs/msg/Header` as rosidl defines it.
pub const HEADER_MSG: &str = include_str!("../std_interfaces/std_msgs/msg/Header.msg");
/// `unique_identifier_msgs/msg/UUID` as rosidl defines it (a goal's id).
pub const UUID_MSG: &str = include_str!("../std_interfaces/unique_identifier_msgs/msg/UUID.msg");
/// `action_msgs/msg/GoalInfo` as rosidl defines it.
pub const GOAL_INFO_MSG: &str = include_str!("../std_interfaces/action_msgs/msg/GoalInfo.msg");
/// `action_msgs/msg/GoalStatus` as rosidl defines it.
pub const GOAL_STATUS_MSG: &str = include_str!("../std_interfaces/action_msgs/msg/GoalStatus.msg");
/// `action_msgs/msg/GoalStatusArray` as rosidl defines it (every action's status topic).
pub const GOAL_STATUS_ARRAY_MSG: &str =
    include_str!("../std_interfaces/action_msgs/msg/GoalStatusArray.msg");
/// `action_msgs/srv/CancelGoal` as rosidl defines it (every action's cancel service).
pub const CANCEL_GOAL_SRV: &str = include_str!("../std_interfaces/action_msgs/srv/CancelGoal.srv");
/// The text of `srv/SetMode.srv`.
pub const SET_MODE_SRV: &str = include_str!("../srv/SetMode.srv");

/// The text of `action/Move.action`.
pub const MOVE_ACTION: &str = include_str!("../action/Move.action");
/// The text of `action/SwitchAttractor.action`.
pub const SWITCH_ATTRACTOR_ACTION: &str = include_str!("../action/SwitchAttractor.action");

/// A type with a ROS 2 interface definition, serialised field for field as its CDR layout.
pub trait RosInterface: Serialize + Default {
    /// Package name.
    const PACKAGE: &'static str;
    /// `msg`, `srv` or `action`.
    const KIND: &'static str;
    /// Type name inside the package (`CapsuleState`, `SetMode_Request`).
    const NAME: &'static str;
    /// The interface text (one `.msg` file, or one half of a `.srv` file).
    fn definition() -> &'static str;

    /// `pkg/msg/Name`, the rosbag2 / MCAP schema name.
    fn ros_type_name() -> String {
        format!("{}/{}/{}", Self::PACKAGE, Self::KIND, Self::NAME)
    }

    /// `pkg::msg::dds_::Name_`, the DDS type name that rmw implementations use.
    fn dds_type_name() -> String {
        format!("{}::{}::dds_::{}_", Self::PACKAGE, Self::KIND, Self::NAME)
    }

    /// The `ros2msg` schema: the definition, then every nested type after a `=` separator line,
    /// as rosbag2 writes it (see [`ros2msg_text`]).
    fn ros2msg_schema() -> String {
        ros2msg_text(Self::definition(), Self::PACKAGE, &|t| {
            nested_definition(t).map(|d| d.1)
        })
    }
}

/// The `ros2msg` schema text of a type whose interface text is `root` (in package `package`),
/// built the way rosbag2's local message definition source builds it: after the root text,
/// each nested type once, depth first, dependencies of a text in sorted order, each after a
/// line of 80 `=` and a line `MSG: ` + the type **as the field spells it** (`std_msgs/Header`
/// for `std_msgs/Header header`; a type without a package gets the enclosing one). Foxglove's
/// readers resolve a field's type only against a `MSG:` line of exactly that spelling.
/// `lookup` gives the text of a spelled type; types it does not know are left out.
pub fn ros2msg_text(
    root: &str,
    package: &str,
    lookup: &dyn Fn(&str) -> Option<&'static str>,
) -> String {
    let mut out = root.to_string();
    let mut seen = std::collections::BTreeSet::new();
    append_dependencies(root, package, lookup, &mut out, &mut seen);
    out
}

/// The nested (non-primitive) types a text's fields name, spelled as rosbag2 spells them in
/// `MSG:` lines, in sorted order.
pub fn field_dependencies(text: &str, package: &str) -> std::collections::BTreeSet<String> {
    parse_definition(text)
        .fields
        .iter()
        .map(|f| f.base_type())
        .filter(|t| !is_primitive(t))
        .map(|t| {
            if t.contains('/') {
                t.to_string()
            } else {
                format!("{package}/{t}")
            }
        })
        .collect()
}

/// A ROS 2 primitive type (`string<=10` counts as `string`).
pub fn is_primitive(type_name: &str) -> bool {
    let base = type_name.split("<=").next().unwrap_or(type_name);
    matches!(
        base,
        "bool"
            | "byte"
            | "char"
            | "float32"
            | "float64"
            | "int8"
            | "uint8"
            | "int16"
            | "uint16"
            | "int32"
            | "uint32"
            | "int64"
            | "uint64"
            | "string"
            | "wstring"
    )
}

fn append_dependencies(
    text: &str,
    package: &str,
    lookup: &dyn Fn(&str) -> Option<&'static str>,
    out: &mut String,
    seen: &mut std::collections::BTreeSet<String>,
) {
    for dep in field_dependencies(text, package) {
        let Some(def) = lookup(&dep) else { continue };
        if seen.insert(dep.clone()) {
            out.push_str(&format!("\n{}\nMSG: {dep}\n{def}", "=".repeat(80)));
            let dep_package = dep.split('/').next().unwrap_or(package).to_string();
            append_dependencies(def, &dep_package, lookup, out, seen);
        }
    }
}

/// The full name and text of a nested message type this package uses.
pub fn nested_definition(type_name: &str) -> Option<(&'static str, &'static str)> {
    match type_name {
        "std_msgs/Header" | "std_msgs/msg/Header" | "Header" => {
            Some(("std_msgs/msg/Header", HEADER_MSG))
        }
        "builtin_interfaces/Time" | "builtin_interfaces/msg/Time" => {
            Some(("builtin_interfaces/msg/Time", TIME_MSG))
        }
        "unique_identifier_msgs/UUID" | "unique_identifier_msgs/msg/UUID" => {
            Some(("unique_identifier_msgs/msg/UUID", UUID_MSG))
        }
        "action_msgs/GoalInfo" | "action_msgs/msg/GoalInfo" => {
            Some(("action_msgs/msg/GoalInfo", GOAL_INFO_MSG))
        }
        _ => None,
    }
}

/// One field line of an interface file: `type name`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldDef {
    /// The type as written (`float64`, `std_msgs/Header`, `uint8[]`).
    pub type_name: String,
    /// The field name.
    pub name: String,
}

impl FieldDef {
    /// The type without array brackets.
    pub fn base_type(&self) -> &str {
        self.type_name.split('[').next().unwrap_or(&self.type_name)
    }
}

/// One constant line of an interface file: `type NAME=value`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ConstantDef {
    /// The constant's type.
    pub type_name: String,
    /// The constant's name.
    pub name: String,
    /// The value as written.
    pub value: String,
}

/// Fields and constants of one message (or one half of a service).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Definition {
    /// Fields in order.
    pub fields: Vec<FieldDef>,
    /// Constants in order.
    pub constants: Vec<ConstantDef>,
}

/// Parses `.msg` syntax: comments (`#`), blank lines, `type name [default]`, `type NAME=value`.
pub fn parse_definition(text: &str) -> Definition {
    let mut def = Definition::default();
    for raw in text.lines() {
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let mut parts = line.splitn(2, char::is_whitespace);
        let ty = parts.next().unwrap_or("").to_string();
        let rest = parts.next().unwrap_or("").trim();
        if let Some((name, value)) = rest.split_once('=') {
            def.constants.push(ConstantDef {
                type_name: ty,
                name: name.trim().to_string(),
                value: value.trim().to_string(),
            });
        } else {
            let name = rest.split_whitespace().next().unwrap_or("").to_string();
            def.fields.push(FieldDef {
                type_name: ty,
                name,
            });
        }
    }
    def
}

/// Splits a `.srv` text into its request and response halves at the `---` line.
pub fn split_service(text: &str) -> (&str, &str) {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        if line.trim() == "---" {
            return (&text[..offset], &text[offset + line.len()..]);
        }
        offset += line.len();
    }
    (text, "")
}

/// Splits a `.action` text into its goal, result and feedback parts at the `---` lines.
pub fn split_action(text: &str) -> (&str, &str, &str) {
    let (goal, rest) = split_service(text);
    let (result, feedback) = split_service(rest);
    (goal, result, feedback)
}

/// What is done for each interface type of this crate (see [`for_each_interface`]).
pub trait InterfaceVisitor {
    /// Called once with the interface type `T`.
    fn visit<T: RosInterface>(&mut self);
}

/// `impl RosInterface` for every type of every row, and [`for_each_interface`] over them all,
/// in the order of the rows. A row is one file: `Type: "package" / "msg" / "Name" = text;`, or
/// a service's two types (`Request, Response: ... / "srv" / ...`) or an action's three (`Goal,
/// Result, Feedback: ... / "action" / ...`) named `Name_Request` and so on and cut from the
/// file's text at its `---` lines.
macro_rules! interfaces {
    (@impl $ty:ident, $package:literal, $kind:literal, $name:expr, $definition:expr) => {
        impl RosInterface for $ty {
            const PACKAGE: &'static str = $package;
            const KIND: &'static str = $kind;
            const NAME: &'static str = $name;
            fn definition() -> &'static str {
                $definition
            }
        }
    };
    (@rows [$($done:ident)*]) => {
        /// Hands every interface type of this crate to `visitor`, in the order of the files.
        pub fn for_each_interface(visitor: &mut impl InterfaceVisitor) {
            $(visitor.visit::<$done>();)*
        }
    };
    (@rows [$($done:ident)*] $ty:ident: $package:literal / "msg" / $name:literal = $text:expr;
        $($rest:tt)*) => {
        interfaces!(@impl $ty, $package, "msg", $name, $text);
        interfaces!(@rows [$($done)* $ty] $($rest)*);
    };
    (@rows [$($done:ident)*] $request:ident, $response:ident:
        $package:literal / "srv" / $name:literal = $text:expr; $($rest:tt)*) => {
        interfaces!(@impl $request, $package, "srv", concat!($name, "_Request"), split_service($text).0);
        interfaces!(@impl $response, $package, "srv", concat!($name, "_Response"), split_service($text).1);
        interfaces!(@rows [$($done)* $request $response] $($rest)*);
    };
    (@rows [$($done:ident)*] $goal:ident, $result:ident, $feedback:ident:
        $package:literal / "action" / $name:literal = $text:expr; $($rest:tt)*) => {
        interfaces!(@impl $goal, $package, "action", concat!($name, "_Goal"), split_action($text).0);
        interfaces!(@impl $result, $package, "action", concat!($name, "_Result"), split_action($text).1);
        interfaces!(@impl $feedback, $package, "action", concat!($name, "_Feedback"), split_action($text).2);
        interfaces!(@rows [$($done)* $goal $result $feedback] $($rest)*);
    };
    ($($rows:tt)*) => {
        interfaces!(@rows [] $($rows)*);
    };
}

interfaces! {
    CapsuleState: "capsule_msgs" / "msg" / "CapsuleState" =
        include_str!("../msg/CapsuleState.msg");
    ActuatorForce: "capsule_msgs" / "msg" / "ActuatorForce" =
        include_str!("../msg/ActuatorForce.msg");
    ControllerStatus: "capsule_msgs" / "msg" / "ControllerStatus" =
        include_str!("../msg/ControllerStatus.msg");
    SetModeRequest, SetModeResponse: "capsule_msgs" / "srv" / "SetMode" = SET_MODE_SRV;
    MoveGoal, MoveResult, MoveFeedback: "capsule_msgs" / "action" / "Move" = MOVE_ACTION;
    SwitchAttractorGoal, SwitchAttractorResult, SwitchAttractorFeedback:
        "capsule_msgs" / "action" / "SwitchAttractor" = SWITCH_ATTRACTOR_ACTION;
    Header: "std_msgs" / "msg" / "Header" = HEADER_MSG;
    Time: "builtin_interfaces" / "msg" / "Time" = TIME_MSG;
}

#[cfg(test)]
mod tests;
