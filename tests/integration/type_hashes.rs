//! The REP-2016 hashes capsule_msgs computes at build time, against rosbags' (PyPI), an
//! independent implementation with its own .msg parser, its own definitions of the standard
//! messages and its own hashing (tests/peers/type_hashes.py), and against ROS 2's own rosidl
//! (tests/peers/rosidl_type_hashes.py); both installed by .ci/record-setup.sh.

use std::process::Command;

use capsule_msgs::hashes::{self, TYPE_HASHES};
use capsule_msgs::names::type_names;

use crate::root;

/// Runs `peer` (a script under tests/peers/ printing `{type: hash}` for capsule_msgs' types) and
/// panics unless it gives every type in the table our hash; `who` names it in the messages.
fn assert_same_hashes(peer: &str, who: &str) {
    let mut cmd = Command::new("python3");
    cmd.arg(root().join("tests/peers").join(peer))
        .arg(root().join("capsule_msgs"));
    cmd.args(TYPE_HASHES.iter().map(|(name, _)| name));
    let out = cmd.output().expect("run python3 tests/peers/...");
    let printed = crate::common::succeeded(&out, &format!("{peer} (run .ci/record-setup.sh)"));
    let peer: serde_json::Map<String, serde_json::Value> =
        serde_json::from_str(&printed).expect("the peer prints a JSON object");
    let differ: Vec<String> = TYPE_HASHES
        .iter()
        .filter(|(name, hash)| peer.get(*name).and_then(|v| v.as_str()) != Some(*hash))
        .map(|(name, hash)| format!("{name}: ours {hash}, {who} {:?}", peer.get(*name)))
        .collect();
    assert!(
        differ.is_empty(),
        "{} of {} differ:\n{}",
        differ.len(),
        TYPE_HASHES.len(),
        differ.join("\n")
    );
    assert!(
        TYPE_HASHES.len() >= 50,
        "only {} types hashed",
        TYPE_HASHES.len()
    );
}

#[test]
fn every_type_hash_is_the_one_an_independent_implementation_computes() {
    assert_same_hashes("type_hashes.py", "rosbags");
}

/// ROS 2's own: rosidl_adapter, rosidl_parser and rosidl_generator_type_description (Jazzy's
/// 4.6.6, PyPI), the code that gives rmw_zenoh_cpp its hashes (tests/peers/rosidl_type_hashes.py).
#[test]
fn every_type_hash_is_the_one_ros2s_rosidl_computes() {
    assert_same_hashes("rosidl_type_hashes.py", "rosidl");
}

#[test]
fn every_type_the_graph_uses_has_a_hash() {
    let used = [
        type_names::STATE,
        type_names::FORCE,
        type_names::STATUS,
        type_names::SET_MODE,
        type_names::CLOCK,
        type_names::JOINT_STATE,
        type_names::DIAGNOSTIC_ARRAY,
        type_names::BOOL,
        type_names::SET_BOOL,
        type_names::MOVE,
        type_names::SWITCH_ATTRACTOR,
        type_names::GOAL_STATUS_ARRAY,
        type_names::CANCEL_GOAL,
        "capsule_msgs/action/Move_SendGoal",
        "capsule_msgs/action/Move_GetResult",
        "capsule_msgs/action/Move_FeedbackMessage",
        "capsule_msgs/action/SwitchAttractor_SendGoal",
        "capsule_msgs/action/SwitchAttractor_GetResult",
        "capsule_msgs/action/SwitchAttractor_FeedbackMessage",
        "tf2_msgs/msg/TFMessage",
        "std_msgs/msg/String",
        "lifecycle_msgs/msg/TransitionEvent",
        "lifecycle_msgs/srv/ChangeState",
        "lifecycle_msgs/srv/GetState",
        "lifecycle_msgs/srv/GetAvailableStates",
        "lifecycle_msgs/srv/GetAvailableTransitions",
    ];
    let missing: Vec<&str> = used
        .into_iter()
        .filter(|t| hashes::of(t).is_none())
        .collect();
    assert!(missing.is_empty(), "no hash for {missing:?}");
}
