//! The nodes on Zenoh (`RMW_IMPLEMENTATION=rmw_zenoh_cpp`, cargo feature `zenoh`), against an
//! independent rmw_zenoh speaker: tests/peers/zenoh_peer.py on PyPI's `eclipse-zenoh`, written
//! from rmw_zenoh's design document, through `capsule_zenohd` on 127.0.0.1:7447 inside the
//! test's own loopback-only namespace. The hashes the peer subscribes and calls with are
//! capsule_msgs', which `type_hashes.rs` checks against independent implementations.

use std::process::Command;

use capsule_msgs::hashes;
use serde_json::Value;

use super::harness::{bin_dir, netns, Run};

/// The hash of `type_name` (`pkg/kind/Name`); panics if capsule_msgs has none.
fn hash(type_name: &str) -> &'static str {
    hashes::of(type_name).unwrap_or_else(|| panic!("no hash for {type_name}"))
}

/// Runs `script` in a namespace with the router started and `zpeer` defined; checks that the
/// peer and the router can run first.
fn with_router(timeout_s: u32, script: &str) -> Run {
    let ok = Command::new("python3")
        .args(["-c", "import zenoh"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "python3 with eclipse-zenoh needed: run .ci/ros-setup.sh"
    );
    let router = bin_dir().join("capsule_zenohd");
    assert!(
        router.is_file(),
        "{} missing: cargo build -p capsule_nodes --features zenoh",
        router.display()
    );
    netns(
        timeout_s,
        &format!(
            r#"export RMW_IMPLEMENTATION=rmw_zenoh_cpp
            zpeer() {{ python3 "$ROOT/tests/peers/zenoh_peer.py" "$@"; }}
            "$B/capsule_zenohd" 2> "$TMP/router.log" & Z=$!
            for i in $(seq 50); do (echo > /dev/tcp/127.0.0.1/7447) 2>/dev/null && break; sleep 0.1; done
            {script}
            stop $Z"#
        ),
    )
}

/// The JSON lines on stdout.
fn json_lines(run: &Run) -> Vec<Value> {
    run.stdout
        .lines()
        .filter(|l| l.starts_with('{'))
        .filter_map(|l| serde_json::from_str(l).ok())
        .collect()
}

/// The peer's `move` flags: the hashes of the Move action's services and topics.
fn move_hashes() -> String {
    format!(
        "--send-goal-hash {} --get-result-hash {} --feedback-hash {} --status-hash {} \
         --cancel-hash {}",
        hash("capsule_msgs/action/Move_SendGoal"),
        hash("capsule_msgs/action/Move_GetResult"),
        hash("capsule_msgs/action/Move_FeedbackMessage"),
        hash("action_msgs/msg/GoalStatusArray"),
        hash("action_msgs/srv/CancelGoal"),
    )
}

#[test]
fn an_rmw_zenoh_peer_sees_the_nodes_reads_states_switches_the_mode_stops_moves_and_sets_parameters()
{
    let run = with_router(
        120,
        &format!(
            "start_plant --until-s 60 2> \"$TMP/plant.log\"
            start_controller 2> \"$TMP/controller.log\"
            zpeer graph --node capsule_plant --node capsule_controller \
                --topic /capsule_controller/move/_action/send_goal || exit 1
            zpeer state --hash {state} --samples 300 || exit 1
            zpeer set-mode 1 0 --hash {set_mode} --status-hash {status} || exit 1
            zpeer estop --state-hash {state} --flag-hash {flag} --send-goal-hash {goal} || exit 1
            zpeer move 0.01 {moves} || exit 1
            zpeer move 1.0 --cancel-after 0.5 {moves} || exit 1
            zpeer params --node /capsule_controller --get gain --get mode --get alpha \
                --set 'mode=\"forward\"' --set gain=0.5 --set gain=5.0 --set alpha=150.0 || exit 1
            zpeer params --node /capsule_plant --get rate_hz --set rate_hz=10.0 || exit 1
            stop $C $P
            cat \"$TMP/plant.log\" \"$TMP/controller.log\" >&2",
            state = hash("capsule_msgs/msg/CapsuleState"),
            set_mode = hash("capsule_msgs/srv/SetMode"),
            status = hash("capsule_msgs/msg/ControllerStatus"),
            flag = hash("std_msgs/msg/Bool"),
            goal = hash("capsule_msgs/action/Move_SendGoal"),
            moves = move_hashes(),
        ),
    );
    run.assert_ok();
    // stopped by SIGTERM: the nodes' logs end without a panic (a parameter server's requests
    // end when the Zenoh session closes)
    assert!(!run.stderr.contains("panicked"), "{}", run.all());
    let lines = json_lines(&run);
    announced_with_rosidls_hashes(&run, &lines);
    states_and_set_mode(&run, &lines);
    emergency_stop(&run, &lines);
    move_goals(&run, &lines);
    parameters(&run, &lines);
}

/// The peer's graph: each entity of ours with its DDS type name and rosidl's hash.
fn announced_with_rosidls_hashes(run: &Run, lines: &[Value]) {
    let entity = |node: &str, kind: &str, topic: &str| {
        lines
            .iter()
            .find(|e| e["node"] == node && e["kind"] == kind && e["topic"] == topic)
            .unwrap_or_else(|| panic!("no {kind} {topic} of {node}\n{}", run.all()))
    };
    for (node, kind, topic, type_name, dds) in [
        (
            "capsule_plant",
            "MP",
            "/capsule/state",
            "capsule_msgs/msg/CapsuleState",
            "capsule_msgs::msg::dds_::CapsuleState_",
        ),
        (
            "capsule_plant",
            "SS",
            "/capsule_plant/emergency_stop",
            "std_srvs/srv/SetBool",
            "std_srvs::srv::dds_::SetBool_",
        ),
        (
            "capsule_plant",
            "MP",
            "/capsule/emergency_stop",
            "std_msgs/msg/Bool",
            "std_msgs::msg::dds_::Bool_",
        ),
        (
            "capsule_controller",
            "SS",
            "/capsule_controller/set_mode",
            "capsule_msgs/srv/SetMode",
            "capsule_msgs::srv::dds_::SetMode_",
        ),
        (
            "capsule_controller",
            "MP",
            "/capsule/actuator_force",
            "capsule_msgs/msg/ActuatorForce",
            "capsule_msgs::msg::dds_::ActuatorForce_",
        ),
        (
            "capsule_controller",
            "SS",
            "/capsule_controller/move/_action/send_goal",
            "capsule_msgs/action/Move_SendGoal",
            "capsule_msgs::action::dds_::Move_SendGoal_",
        ),
        (
            "capsule_controller",
            "SS",
            "/capsule_controller/move/_action/get_result",
            "capsule_msgs/action/Move_GetResult",
            "capsule_msgs::action::dds_::Move_GetResult_",
        ),
        (
            "capsule_controller",
            "MP",
            "/capsule_controller/move/_action/feedback",
            "capsule_msgs/action/Move_FeedbackMessage",
            "capsule_msgs::action::dds_::Move_FeedbackMessage_",
        ),
        (
            "capsule_controller",
            "SS",
            "/capsule_controller/switch_attractor/_action/send_goal",
            "capsule_msgs/action/SwitchAttractor_SendGoal",
            "capsule_msgs::action::dds_::SwitchAttractor_SendGoal_",
        ),
    ] {
        let e = entity(node, kind, topic);
        assert_eq!(e["type"], dds, "{e}");
        assert_eq!(e["hash"], hash(type_name), "{e}");
    }
}

/// The states at 1 kHz from one publisher, and set_mode FORWARD shown in the status.
fn states_and_set_mode(run: &Run, lines: &[Value]) {
    let state = lines
        .iter()
        .find(|l| l.get("samples").is_some())
        .unwrap_or_else(|| panic!("no state report\n{}", run.all()));
    assert_eq!(state["samples"], 300, "{state}");
    for key in ["seq_increasing", "attachment_seq_increasing", "finite"] {
        assert_eq!(state[key], true, "{key}: {state}");
    }
    assert_eq!(state["gids"], 1, "one publisher: {state}");
    let rate = state["rate_hz"].as_f64().unwrap_or(f64::NAN);
    assert!((rate - 1000.0).abs() < 1.0, "stamps at 1 kHz: {state}");
    let answer = lines
        .iter()
        .find(|l| l.get("accepted").is_some())
        .unwrap_or_else(|| panic!("no set_mode answer\n{}", run.all()));
    assert_eq!(answer["accepted"], true, "{answer}");
    assert_eq!(answer["mode"], 1, "FORWARD: {answer}");
    let status = lines
        .iter()
        .find(|l| l.get("status_mode").is_some())
        .unwrap_or_else(|| panic!("no status\n{}", run.all()));
    assert_eq!(status["mode_name"], "FORWARD", "{status}");
}

/// The emergency stop as the peer drove it.
fn emergency_stop(run: &Run, lines: &[Value]) {
    // the emergency stop, as on DDS (ros::device): engaged while the controller drives
    // FORWARD, zero force on every state from 50 ms after the answer to the release, the
    // latched flag following; released, the commands apply again
    let stop = lines
        .iter()
        .find_map(|l| l.get("estop"))
        .unwrap_or_else(|| panic!("no emergency stop report\n{}", run.all()));
    let said = |step: &str| {
        stop[step]["message"]
            .as_str()
            .unwrap_or_default()
            .to_string()
    };
    assert_eq!(stop["engage"]["success"], true, "{stop}");
    assert!(said("engage").contains("emergency stop engaged"), "{stop}");
    assert!(
        said("release").contains("emergency stop released"),
        "{stop}"
    );
    let count = |key: &str| stop[key].as_u64().unwrap_or(0);
    assert!(
        count("nonzero_before") > 0,
        "the controller commands first: {stop}"
    );
    assert!(count("states_held") >= 100, "states while engaged: {stop}");
    assert_eq!(count("nonzero_held"), 0, "zero force while engaged: {stop}");
    assert!(
        count("nonzero_after") > 0,
        "commands apply after the release: {stop}"
    );
    assert_eq!(stop["flags"], serde_json::json!([true, false]), "{stop}");
    // the controller reads the stop on Zenoh too: a goal while engaged is refused for it
    assert_eq!(stop["goal_accepted_while_engaged"], false, "{stop}");
    run.assert_stderr(&["goal 0.01 m refused: the plant's emergency stop is engaged"]);
}

/// The Move goals: one reached, one cancelled.
fn move_goals(run: &Run, lines: &[Value]) {
    // the Move goals, as on DDS (ros::actions): +10 mm SUCCEEDED within the default tolerance
    // (1 mm), feedback at 20 Hz, the status topic EXECUTING then SUCCEEDED; 1 m cancelled
    let goals: Vec<&Value> = lines
        .iter()
        .filter(|l| l.get("distance").is_some())
        .collect();
    assert_eq!(goals.len(), 2, "{}", run.all());
    let g = goals[0];
    assert_eq!(g["accepted"], true, "{g}");
    assert_eq!(g["status"], "SUCCEEDED", "{g}");
    assert_eq!(g["reached"], true, "{g}");
    assert_eq!(
        g["statuses"],
        serde_json::json!(["EXECUTING", "SUCCEEDED"]),
        "{g}"
    );
    let (travelled, err) = (g["travelled_m"].as_f64(), g["error_m"].as_f64());
    let (travelled, err) = (travelled.unwrap_or(f64::NAN), err.unwrap_or(f64::NAN));
    assert!(err.abs() <= 1e-3, "{g}");
    assert!((travelled - 0.01 - err).abs() < 1e-12, "{g}");
    assert!(g["feedback_hz"].as_f64().unwrap_or(0.0) >= 10.0, "{g}");
    let g = goals[1];
    assert_eq!(g["status"], "CANCELED", "{g}");
    assert_eq!(g["cancel_code"], 0, "{g}");
    assert_eq!(g["canceling_ours"], true, "{g}");
    assert_eq!(
        g["statuses"],
        serde_json::json!(["EXECUTING", "CANCELING", "CANCELED"]),
        "{g}"
    );
    assert!(g["feedback"].as_u64().unwrap_or(0) > 0, "{g}");
}

/// The parameters of both nodes.
fn parameters(run: &Run, lines: &[Value]) {
    // the parameters, served with the table and the rules of DDS (ros::params)
    let params: Vec<&Value> = lines.iter().filter(|l| l.get("hashes").is_some()).collect();
    assert_eq!(params.len(), 2, "{}", run.all());
    for p in &params {
        for (ty, h) in p["hashes"].as_object().into_iter().flatten() {
            let h = h.as_str().unwrap_or_default();
            assert!(
                h.starts_with("RIHS01_") && !h.ends_with("0000000000"),
                "{ty}: {p}"
            );
        }
    }
    let (controller, plant) = (params[0], params[1]);
    assert!(controller["values"]["gain"].is_f64(), "{controller}");
    assert!(controller["values"]["alpha"].is_f64(), "{controller}");
    let set = |p: &Value, i: usize| p["set"][i].clone();
    let mode = set(controller, 0);
    assert_eq!(mode["successful"], true, "{mode}");
    assert_eq!(mode["now"], "FORWARD", "{mode}");
    let gain = set(controller, 1);
    assert_eq!(gain["successful"], true, "{gain}");
    assert_eq!(gain["now"], 0.5, "{gain}");
    let refused = set(controller, 2);
    assert_eq!(refused["successful"], false, "{refused}");
    let why = refused["reason"].as_str().unwrap_or_default();
    assert!(
        why.contains("gain 5 is beyond the configured limit |k_p| <= 2"),
        "{refused}"
    );
    assert_eq!(refused["now"], 0.5, "unchanged: {refused}");
    let alpha = set(controller, 3);
    assert_eq!(alpha["successful"], false, "{alpha}");
    let why = alpha["reason"].as_str().unwrap_or_default();
    assert!(
        why.contains("parameter 'alpha': must be in [0, 100] (got 150)"),
        "{alpha}"
    );
    assert_eq!(plant["values"]["rate_hz"], 1000.0, "{plant}");
    let read_only = set(plant, 0);
    assert_eq!(read_only["successful"], false, "{read_only}");
    let why = read_only["reason"].as_str().unwrap_or_default();
    assert!(
        why.contains("parameter 'rate_hz' is read-only"),
        "{read_only}"
    );
}

/// The demo's figures (the three segment lines of its table), from its output.
fn figures(out: &str) -> Vec<&str> {
    out.lines()
        .filter(|l| {
            ["FORWARD ", "BACKWARD ", "OFF "]
                .iter()
                .any(|m| l.starts_with(m))
        })
        .collect()
}

#[test]
fn the_lockstep_demo_on_zenoh_prints_the_figures_of_dds() {
    // 9 drive periods a segment (3 settling): the same lock-step run on both middlewares, each
    // step taken with the answer to its own sample, so the same figures to the last digit
    let run = netns(
        240,
        r#"export CAPSULE_RECORD_DIR="$TMP"
        echo "== dds"; "$ROOT/launch_scripts/demo.sh" "$SCENE" 9 || exit 1
        echo "== zenoh"; "$ROOT/launch_scripts/demo.sh" --rmw zenoh "$SCENE" 9 || exit 1"#,
    );
    run.assert_ok();
    let (dds, zenoh) = run
        .stdout
        .split_once("== zenoh")
        .unwrap_or_else(|| panic!("no Zenoh run\n{}", run.all()));
    let on_dds = figures(dds);
    assert_eq!(on_dds.len(), 3, "{}", run.all());
    assert_eq!(figures(zenoh), on_dds, "{}", run.all());
    for line in [
        "on Zenoh, lock-step, separate processes",
        "scheduled BACKWARD",
        "scheduled OFF",
        "forward > 0: yes, backward < 0: yes",
        "not recorded: recording is not on Zenoh yet",
    ] {
        assert!(zenoh.contains(line), "{line:?} missing\n{}", run.all());
    }
}

#[test]
fn on_zenoh_a_lockstep_plant_started_paused_holds_its_sample_until_resumed() {
    // as on DDS (crate::pause): paused, the plant is answered but takes no step and re-sends
    // its sample; resumed through `~/pause` (false), it steps again
    let run = with_router(
        60,
        &format!(
            "start_plant --pacing lockstep --start-paused --until-s 5 2> \"$TMP/plant.log\"
            start_controller 2> \"$TMP/controller.log\"
            zpeer resume --state-hash {state} || exit 1
            stop $C $P
            cat \"$TMP/plant.log\" >&2",
            state = hash("capsule_msgs/msg/CapsuleState"),
        ),
    );
    run.assert_ok();
    let lines = json_lines(&run);
    let resumed = lines
        .iter()
        .find_map(|l| l.get("resume"))
        .unwrap_or_else(|| panic!("no resume report\n{}", run.all()));
    assert_eq!(resumed["success"], true, "{resumed}");
    let said = resumed["message"].as_str().unwrap_or_default();
    assert!(said.contains("resumed"), "{resumed}");
    let held = resumed["seqs_paused"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert_eq!(held.len(), 1, "one sample while paused: {resumed}");
    assert!(
        resumed["states_paused"].as_u64().unwrap_or(0) >= 2,
        "re-sent while paused: {resumed}"
    );
    let (held, last) = (held[0].as_u64(), resumed["last_seq"].as_u64());
    let (held, last) = (held.unwrap_or(u64::MAX), last.unwrap_or(0));
    assert!(
        last > held.saturating_add(10),
        "steps after the resume: {resumed}"
    );
}

#[test]
fn on_zenoh_a_plant_not_autostarted_is_driven_through_its_lifecycle_by_an_rmw_zenoh_peer() {
    // as `ros2 lifecycle set` over rmw_zenoh_cpp: activate refused while unconfigured, then
    // configure and activate; the states flow once configured
    let run = with_router(
        60,
        &format!(
            "start_plant --autostart false --until-s 30 2> \"$TMP/plant.log\"
            zpeer lifecycle --event-hash {event} --transition 3 --transition 1 --transition 3 \
                || exit 1
            zpeer state --hash {state} --samples 100 || exit 1
            stop $P
            cat \"$TMP/plant.log\" >&2",
            event = hash("lifecycle_msgs/msg/TransitionEvent"),
            state = hash("capsule_msgs/msg/CapsuleState"),
        ),
    );
    run.assert_ok();
    let lines = json_lines(&run);
    let lc = lines
        .iter()
        .find_map(|l| l.get("lifecycle"))
        .unwrap_or_else(|| panic!("no lifecycle report\n{}", run.all()));
    assert_eq!(lc["first"], serde_json::json!([1, "unconfigured"]), "{lc}");
    let steps = serde_json::json!([
        {"transition": 3, "success": false, "state": [1, "unconfigured"]},
        {"transition": 1, "success": true, "state": [2, "inactive"]},
        {"transition": 3, "success": true, "state": [3, "active"]},
    ]);
    assert_eq!(lc["steps"], steps, "{lc}");
    assert_eq!(
        lc["available_states"].as_array().map(Vec::len),
        Some(10),
        "{lc}"
    );
    // from active: deactivate (4) and shutdown (7)
    assert_eq!(
        lc["available_transitions"],
        serde_json::json!([[4, 3, 14], [7, 3, 12]]),
        "{lc}"
    );
    // every step on ~/transition_event: (transition, from, to)
    assert_eq!(
        lc["events"],
        serde_json::json!([[1, 1, 10], [10, 10, 2], [3, 2, 13], [30, 13, 3]]),
        "{lc}"
    );
    let state = lines
        .iter()
        .find(|l| l.get("samples").is_some())
        .unwrap_or_else(|| panic!("no state report\n{}", run.all()));
    assert_eq!(state["samples"], 100, "{state}");
}

#[test]
fn on_zenoh_security_and_the_unported_nodes_are_refused_by_name() {
    let run = with_router(
        30,
        "ROS_SECURITY_ENABLE=true \"$B/capsule_plant\" --scene \"$SCENE\" --check; echo \"secured=$?\"
        \"$B/capsule_recorder\" --output \"$TMP/r.mcap\" --idle-stop-s 1; echo \"recorder=$?\"
        \"$B/capsule_plant\" --scene \"$SCENE\" --record-dir \"$TMP\" --until-s 1; echo \"record=$?\"",
    );
    run.assert_ok();
    run.assert_stdout(&["secured=2", "recorder=2", "record=2"]);
    run.assert_stderr(&[
        "ROS_SECURITY_ENABLE=true with RMW_IMPLEMENTATION=rmw_zenoh_cpp",
        "refusing to run unsecured",
        "capsule_recorder is not available on Zenoh yet",
        "the plant's --record is not available on Zenoh yet",
    ]);
}
