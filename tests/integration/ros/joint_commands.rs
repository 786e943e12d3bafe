//! topic_based_ros2_control's way of commanding the plant: sensor_msgs/JointState on
//! capsule/joint_commands (`capsule_plant --joint-commands`), sent by a real peer (Cyclone DDS
//! Python binding) as TopicBasedSystem::write does, stamped with the sender's wall clock.

use super::harness::{assert_at_least, json_number, netns_with_peer, root};

/// Switched on as a launch file would, by the parameter (the flag `--joint-commands` sets the
/// same parameter; the lock-step refusal below uses the flag).
#[test]
fn joint_state_commands_drive_the_plant_when_switched_on() {
    let run = netns_with_peer(
        120,
        r#"
        start_plant --until-s 90 --ros-args -p joint_commands:=true
        sleep 1
        peer joint-command --effort 0.2 || exit 1
        stop $P"#,
    );
    run.assert_ok();
    run.assert_stderr(&["taking JointState commands on /capsule/joint_commands"]);
    let out = run.line("{\"applied_samples\"");
    assert_at_least(out, "applied_samples", 5.0);
    assert!(
        json_number(out, "refused_after").unwrap_or(0.0)
            > json_number(out, "refused_before").unwrap_or(f64::MAX),
        "{out}"
    );
}

#[test]
fn joint_state_commands_are_off_by_default_and_refused_in_lockstep() {
    let run = netns_with_peer(
        90,
        r#"
        start_plant --until-s 90
        sleep 1
        peer joint-command --effort 0.2 --stale-wait 0.2 && exit 1
        stop $P
        $B/capsule_plant --scene "$SCENE" --joint-commands --pacing lockstep --check
        echo "rc=$?""#,
    );
    run.assert_ok();
    run.assert_stdout(&["rc=2"]);
    run.assert_stderr(&[
        "plant did not apply the effort",
        "--joint-commands (or -p joint_commands:=true) with --pacing lockstep",
    ]);
}

#[test]
fn the_ros2_control_example_names_the_plants_topic_and_joint() {
    use capsule_msgs::names::topics::JOINT_COMMANDS;
    use capsule_plant_node::joint_commands::JOINT;
    let read = |p: &str| {
        let path = root().join(p);
        std::fs::read_to_string(&path)
            .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
    };
    let xacro = read("docs/ros2_control/capsule_ros2_control.urdf.xacro");
    let yaml = read("docs/ros2_control/capsule_controllers.yaml");
    for needle in [
        "<plugin>topic_based_ros2_control/TopicBasedSystem</plugin>".to_string(),
        format!("joint_commands_topic:=/{JOINT_COMMANDS}"),
        "joint_states_topic:=/joint_states".to_string(),
        format!("<joint name=\"{JOINT}\">"),
        "<command_interface name=\"effort\"/>".to_string(),
    ] {
        assert!(xacro.contains(&needle), "xacro lacks {needle}");
    }
    assert!(yaml.contains(&format!("- {JOINT}")), "{yaml}");
    assert!(yaml.contains("interface_name: effort"), "{yaml}");
}
