//! The plant's standard-type views read by a real peer (Cyclone DDS Python binding):
//! joint_states and /tf checked against the state sample of the same stamp, the URDF on
//! robot_description reaching a late (transient-local) reader, /diagnostics levels; each view
//! switched off by a flag or a parameter stays silent.

use super::harness::{assert_at_least, assert_contains, json_number, netns_with_peer, Run};

/// The `n` JSON lines of the peer starting with `prefix` (the run must have succeeded).
#[track_caller]
fn peer_lines<'a>(run: &'a Run, prefix: &str, n: usize) -> Vec<&'a str> {
    run.assert_ok();
    run.lines_exactly(prefix, n)
}

#[test]
fn views_map_the_state_and_diagnostics_follow_the_loop() {
    let run = netns_with_peer(
        150,
        r#"
        start_controller --mode forward
        start_plant --until-s 90
        sleep 2
        peer views --seconds 3 || exit 1
        stop $C
        sleep 1.5
        peer views --seconds 2.5 || exit 1
        stop $P"#,
    );
    let lines = peer_lines(&run, "{\"state\"", 2);
    let live = lines[0];
    // 100 Hz views of a 1 kHz loop (every 10th sample; the thinning is unit-tested): the peer
    // matched at least 10 of each to a state sample, value for value
    assert_at_least(live, "joint_states_matched", 10.0);
    assert_at_least(live, "tf_matched", 10.0);
    assert!(live.contains("\"name\": \"capsule_plant: loop\""), "{live}");
    // commanded: answers counted, latency measured (the level itself depends on the host's
    // load here; the unit test checks the levels)
    assert!(!live.contains("\"answers_last_s\": \"0\""), "{live}");
    assert!(!live.contains("\"latency_p99_ms\": \"n/a\""), "{live}");
    // the controller gone: the watchdog fired, ERROR
    let gone = lines[1];
    assert_eq!(json_number(gone, "level"), Some(2.0), "{gone}");
    assert_contains(gone, &["\"watchdog\": \"fired (zero force)\""]);
}

#[test]
fn views_switched_off_stay_silent() {
    let run = netns_with_peer(
        90,
        r#"
        start_plant --until-s 90 --no-tf --no-diagnostics \
            --ros-args -p views.joint_states:=false -p views.robot_description:=false
        sleep 1
        peer views --seconds 2 --absent joint_states tf diagnostics robot_description || exit 1
        stop $P"#,
    );
    let out = peer_lines(&run, "{\"state\"", 1)[0];
    assert!(json_number(out, "state").unwrap_or(0.0) > 10.0, "{out}");
    for view in ["joint_states", "tf", "diagnostics", "robot_description"] {
        assert_eq!(json_number(out, view), Some(0.0), "{view}: {out}");
    }
}

#[test]
fn the_controller_reports_on_diagnostics() {
    let run = netns_with_peer(
        150,
        r#"
        start_controller --mode forward
        peer diagnostics --name capsule_controller --seconds 1.5 || exit 1
        start_plant --until-s 90 --no-diagnostics
        sleep 2
        peer diagnostics --name capsule_controller --seconds 2.5 || exit 1
        stop $P
        sleep 1.5
        peer diagnostics --name capsule_controller --seconds 2.5 || exit 1
        stop $C"#,
    );
    let lines = peer_lines(&run, "{\"capsule_controller\"", 3);
    for l in &lines {
        assert_contains(
            l,
            &["\"capsule_controller: control\"", "\"mode\": \"FORWARD\""],
        );
    }
    // no plant yet: WARN, not seen
    assert_eq!(json_number(lines[0], "level"), Some(1.0), "{}", lines[0]);
    assert_contains(
        lines[0],
        &["\"plant\": \"not seen yet\"", "\"commands_sent\": \"0\""],
    );
    // the plant running: commands went out in the last second, the plant is seen
    let live = lines[1];
    assert!(!live.contains("\"commands_last_s\": \"0\""), "{live}");
    assert_contains(
        live,
        &["\"plant\": \"seen\"", "\"plant_takes_commands\": \"true\""],
    );
    // the plant gone: the watchdog fired, ERROR
    let gone = lines[2];
    assert_eq!(json_number(gone, "level"), Some(2.0), "{gone}");
    assert_contains(gone, &["\"plant\": \"lost (watchdog fired)\""]);
}
