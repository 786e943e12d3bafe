//! topic_based_ros2_control's way of commanding the plant: sensor_msgs/JointState on
//! capsule/joint_commands (`capsule_plant --joint-commands`), sent by a real peer (Cyclone DDS
//! Python binding) as TopicBasedSystem::write does, stamped with the sender's wall clock.

use super::harness::{json_number, netns, root};

fn peer() -> String {
    root()
        .join("tests/peers/cyclone_peer.py")
        .display()
        .to_string()
}

/// Switched on as a launch file would, by the parameter (the flag `--joint-commands` sets the
/// same parameter; the lock-step refusal below uses the flag).
#[test]
fn joint_state_commands_drive_the_plant_when_switched_on() {
    let py = peer();
    let run = netns(
        120,
        &format!(
            r#"
            $B/capsule_plant --scene "$SCENE" --until-s 90 --ros-args -p joint_commands:=true &
            P=$!
            sleep 1
            python3 {py} joint-command --effort 0.2 || exit 1
            kill -TERM $P; wait $P"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let out = run
        .stdout
        .lines()
        .find(|l| l.starts_with("{\"applied_samples\""))
        .unwrap_or("");
    assert!(
        json_number(out, "applied_samples").unwrap_or(0.0) >= 5.0,
        "{out}"
    );
    assert!(
        json_number(out, "refused_after").unwrap_or(0.0)
            > json_number(out, "refused_before").unwrap_or(f64::MAX),
        "{out}"
    );
    assert!(
        run.stderr
            .contains("taking JointState commands on /capsule/joint_commands"),
        "{}",
        run.all()
    );
}

#[test]
fn joint_state_commands_are_off_by_default_and_refused_in_lockstep() {
    let py = peer();
    let run = netns(
        90,
        &format!(
            r#"
            $B/capsule_plant --scene "$SCENE" --until-s 90 &
            P=$!
            sleep 1
            python3 {py} joint-command --effort 0.2 --stale-wait 0.2 && exit 1
            kill -TERM $P; wait $P
            $B/capsule_plant --scene "$SCENE" --joint-commands --pacing lockstep --check
            echo "rc=$?""#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    assert!(
        run.stderr.contains("plant did not apply the effort"),
        "{}",
        run.all()
    );
    assert!(run.stdout.contains("rc=2"), "{}", run.all());
    assert!(
        run.stderr
            .contains("--joint-commands (or -p joint_commands:=true) with --pacing lockstep"),
        "{}",
        run.all()
    );
}

#[test]
fn the_ros2_control_example_names_the_plants_topic_and_joint() {
    use capsule_msgs::names::topics::JOINT_COMMANDS;
    use capsule_nodes::joint_commands::JOINT;
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
