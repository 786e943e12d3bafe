//! ROS 2's own interface tools read capsule_msgs (#19, #38): rosidl_adapter turns every
//! .msg/.srv/.action into IDL, rosidl_parser parses it, rosidl_generator_c and rosidl_typesupport_introspection_c
//! generate the C type support, which is compiled and run (tests/peers/rosidl_check.py, with
//! Debian's python3-rosidl, rosidl-generator-c-cpp, librcutils-dev, librosidl-*-dev;
//! `.ci/ros-setup.sh` installs what is missing). What those tools read must be what our crate
//! serialises: the fields, their order and types, and the constants, compared with
//! `capsule_msgs::interface`.

use crate::common::succeeded;
use capsule_msgs::interface::{
    for_each_interface, parse_definition, InterfaceVisitor, RosInterface, HEADER_MSG, TIME_MSG,
};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;

/// The IDL spelling rosidl_parser reports for a `.msg` type.
fn idl_type(msg_type: &str) -> String {
    match msg_type {
        "float64" => "double".into(),
        "float32" => "float".into(),
        "bool" => "boolean".into(),
        "byte" => "octet".into(),
        t if t.contains('/') => {
            let (pkg, name) = t.split_once('/').unwrap_or((t, ""));
            format!("{pkg}/msg/{name}")
        }
        t => t.into(),
    }
}

/// Runs ROS 2's tools once and returns their report.
fn rosidl_report() -> Value {
    let work = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("rosidl");
    let deps = work.join("deps");
    for (pkg, name, text) in [
        ("builtin_interfaces", "Time", TIME_MSG),
        ("std_msgs", "Header", HEADER_MSG),
        (
            "unique_identifier_msgs",
            "UUID",
            include_str!("../../capsule_msgs/std_interfaces/unique_identifier_msgs/msg/UUID.msg"),
        ),
    ] {
        let dir = deps.join(pkg).join("msg");
        std::fs::create_dir_all(&dir).expect("create the dependency directory");
        std::fs::write(dir.join(format!("{name}.msg")), text).expect("write a dependency");
    }
    let out = Command::new("/usr/bin/python3")
        .arg(crate::root().join("tests/peers/rosidl_check.py"))
        .arg(crate::root().join("capsule_msgs"))
        .arg(&deps)
        .arg(work.join("out"))
        .output()
        .expect("run /usr/bin/python3 (Debian's, where python3-rosidl lives)");
    succeeded(
        &out,
        "ROS 2's rosidl tools on capsule_msgs (run .ci/ros-setup.sh for the packages)",
    );
    let text = std::fs::read_to_string(work.join("out/rosidl.json")).expect("the tools' report");
    serde_json::from_str(&text).expect("the report is JSON")
}

/// The members (name, type) rosidl_parser reports for the interface `key`, in order.
fn idl_members(report: &Value, key: &str) -> Vec<(String, String)> {
    report["idl"][key]["members"]
        .as_array()
        .unwrap_or_else(|| panic!("rosidl_parser did not report {key}"))
        .iter()
        .map(|m| {
            (
                m[0].as_str().unwrap_or("").into(),
                m[1].as_str().unwrap_or("").into(),
            )
        })
        .collect()
}

/// One interface as rosidl read it matches our definition of it.
fn check<T: RosInterface>(report: &Value) {
    let key = format!("{}/{}", T::PACKAGE, T::NAME);
    let ours = parse_definition(T::definition());
    let idl = &report["idl"][&key];
    let members = idl_members(report, &key);
    let expected: Vec<(String, String)> = ours
        .fields
        .iter()
        .map(|f| (f.name.clone(), idl_type(&f.type_name)))
        .collect();
    assert_eq!(
        members, expected,
        "{key}: fields as rosidl_parser reads them"
    );

    let constants: Vec<(String, String, String)> = idl["constants"]
        .as_array()
        .map(|cs| {
            cs.iter()
                .map(|c| {
                    (
                        c[0].as_str().unwrap_or("").into(),
                        c[1].as_str().unwrap_or("").into(),
                        c[2].to_string(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    let expected: Vec<(String, String, String)> = ours
        .constants
        .iter()
        .map(|c| (c.name.clone(), idl_type(&c.type_name), c.value.clone()))
        .collect();
    assert_eq!(
        constants, expected,
        "{key}: constants as rosidl_parser reads them"
    );

    // the generated C type support: same members in the same order, in the namespace that
    // rmw implementations turn into our DDS type name
    let c = &report["introspection"][&key];
    let names: Vec<&str> = c["members"]
        .as_array()
        .unwrap_or_else(|| panic!("the C introspection did not list {key}"))
        .iter()
        .map(|m| m[0].as_str().unwrap_or(""))
        .collect();
    let ours_names: Vec<&str> = ours.fields.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names, ours_names,
        "{key}: members of the generated C struct"
    );
    let namespace = c["namespace"].as_str().unwrap_or("").replace("__", "::");
    assert_eq!(
        format!("{namespace}::dds_::{}_", T::NAME),
        T::dds_type_name(),
        "{key}: the DDS type name follows rosidl's namespace"
    );
}

/// The types rosidl derives from an action (its services' halves and its feedback message)
/// have the members `capsule_msgs::actions`' generic wire types serialise, in that order, and
/// the C namespace that gives their DDS names.
fn check_derived(report: &Value, action: &str) {
    let uuid = "unique_identifier_msgs/msg/UUID";
    let own = |part: &str| format!("capsule_msgs/action/{action}_{part}");
    let expected: [(&str, Vec<(&str, String)>); 5] = [
        (
            "SendGoal_Request",
            vec![("goal_id", uuid.into()), ("goal", own("Goal"))],
        ),
        (
            "SendGoal_Response",
            vec![
                ("accepted", "boolean".into()),
                ("stamp", "builtin_interfaces/msg/Time".into()),
            ],
        ),
        ("GetResult_Request", vec![("goal_id", uuid.into())]),
        (
            "GetResult_Response",
            vec![("status", "int8".into()), ("result", own("Result"))],
        ),
        (
            "FeedbackMessage",
            vec![("goal_id", uuid.into()), ("feedback", own("Feedback"))],
        ),
    ];
    for (part, members) in expected {
        let key = format!("capsule_msgs/{action}_{part}");
        let idl = idl_members(report, &key);
        let expected: Vec<(String, String)> = members
            .iter()
            .map(|(n, t)| (n.to_string(), t.clone()))
            .collect();
        assert_eq!(idl, expected, "{key}: members as rosidl derives them");
        let c = &report["introspection"][&key];
        assert_eq!(
            c["namespace"].as_str(),
            Some("capsule_msgs__action"),
            "{key}: the C namespace (DDS capsule_msgs::action::dds_::{action}_{part}_)"
        );
    }
}

#[test]
fn rosidl_reads_every_interface_of_capsule_msgs() {
    let report = rosidl_report();
    // 3 packages' worth of generated C: every message and service compiled and ran
    assert!(report["generated_c_files"].as_u64().unwrap_or(0) >= 12);
    /// Checks each interface against the report.
    struct Check<'a>(&'a Value);
    impl InterfaceVisitor for Check<'_> {
        fn visit<T: RosInterface>(&mut self) {
            check::<T>(self.0);
        }
    }
    for_each_interface(&mut Check(&report));
    for action in ["Move", "SwitchAttractor"] {
        check_derived(&report, action);
    }
    // the C structs of the two standard types have the layout ROS 2 gives them everywhere
    assert_eq!(
        report["introspection"]["builtin_interfaces/Time"]["size"],
        8
    );
}
