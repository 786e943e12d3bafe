//! ROS parameters over a real peer: the Cyclone DDS Python binding calls the nodes'
//! rcl_interfaces services in the rmw_cyclonedds mapping (as `ros2 param` on
//! rmw_cyclonedds_cpp does) and reads /parameter_events.

use super::harness::{assert_contains, json_raw, netns_with_peer, Run};

/// Runs `script` with the Cyclone DDS rmw's conventions (as `ros2 param` on
/// rmw_cyclonedds_cpp); it must succeed. Returns the run and the peer's `params` JSON line.
#[track_caller]
fn params_run(timeout_s: u32, script: &str) -> (Run, String) {
    let run = netns_with_peer(
        timeout_s,
        &format!("export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp\n{script}"),
    );
    run.assert_ok();
    let p = run.line("{\"names\"").to_string();
    (run, p)
}

#[test]
fn controller_parameters_get_set_and_refuse_over_the_cyclone_peer() {
    let (run, p) = params_run(
        120,
        r#"
        start_controller --mode forward
        peer params --node /capsule_controller \
            --set 'gain=0.5' --set 'mode="backward"' --set 'alpha=1.5' \
            --refuse 'gain="x"' --refuse 'gain=nan' --refuse 'gain=5.0' --refuse 'gain=1' \
            --refuse 'no_such=1.0' --refuse 'm1_kg=0.1' --refuse 'mode="sideways"' \
            --refuse 'gain_limit=-1.0' --refuse 'gain=1e308' --refuse 'alpha=150.0' || exit 1
        # the controller runs what the parameters say
        peer status --periods 0 --timeout 5 || exit 1
        # set_mode refuses the same gain for the same reason
        peer set-mode 2 5.0 || exit 1
        # and a huge gain, written short in both reasons
        peer set-mode 4 1e308 || exit 1
        stop $C"#,
    );
    let p = p.as_str();
    for name in [
        "mode",
        "gain",
        "direction_gain",
        "chaos_gain",
        "gain_limit",
        "alpha",
        "omega",
        "use_sim_time",
    ] {
        assert!(p.contains(&format!("\"{name}\"")), "{name} not listed: {p}");
    }
    // before the sets: FORWARD with the default gain; m1_kg read-only, gain writable
    assert_contains(
        p,
        &[
            "\"gain\": 0.2",
            "\"mode\": \"FORWARD\"",
            "\"m1_kg\": true",
            "\"gain\": false",
        ],
    );
    assert_eq!(
        json_raw(p, "no_such"),
        Some("0"),
        "unknown type NOT_SET: {p}"
    );
    // sets: the value read back and the event; BACKWARD keeps |k_p| and takes the sign;
    // refusals, with their reasons (the peer checked: nothing changed, no event)
    assert_contains(
        p,
        &[
            "\"name\": \"gain\", \"value\": 0.5, \"now\": 0.5",
            "\"now\": \"BACKWARD\", \"events\": [{\"gain\": -0.5, \"mode\": \"BACKWARD\"}]",
            "wrong parameter type: 'gain' is of type double, setting it to string",
            "parameter 'gain': must be a finite number (got NaN)",
            "gain -5 is beyond the configured limit |k_p| <= 2",
            "setting it to integer",
            "parameter 'no_such' is not declared",
            "parameter 'm1_kg' is read-only",
            "unknown mode \\\"sideways\\\"",
            "must be in [",
            "\"atomic_refused\": \"parameter 'no_such' is not declared\"",
            // the settings table's range, as the flag and the scene key refuse it (bad_input)
            "parameter 'alpha': must be in [0, 100] (got 150)",
            // numbers as short as they round-trip, not 309 digits (BACKWARD by then: -1e308)
            "\"reason\": \"gain -1e308 is beyond the configured limit |k_p| <= 2\"",
        ],
    );
    assert_contains(
        run.json_with("mode_name"),
        &[
            "\"mode_name\": \"BACKWARD\"",
            "\"gain\": -0.5",
            "\"drive_amplitude\": 1.5",
        ],
    );
    // set_mode's reason is the parameter's
    let answers = run.lines_starting("{\"accepted\"");
    assert_eq!(answers.len(), 2, "{answers:?}");
    assert_contains(
        answers[0],
        &["\"reason\": \"gain -5 is beyond the configured limit |k_p| <= 2\""],
    );
    assert_contains(
        answers[1],
        &["\"reason\": \"gain 1e308 is beyond the configured limit |k_p| <= 2\""],
    );
}

#[test]
fn plant_parameters_are_read_only_and_say_so() {
    let (_, p) = params_run(
        90,
        r#"
        start_plant --until-s 30
        peer params --node /capsule_plant --refuse 'rate_hz=10.0' --refuse 'scene="x"' || exit 1
        stop $P"#,
    );
    // the values, rate_hz read-only and refused as such
    assert_contains(
        &p,
        &[
            "\"rate_hz\": 1000.0",
            "\"pacing\": \"realtime\"",
            "\"rate_hz\": true",
            "parameter 'rate_hz' is read-only",
        ],
    );
    let read_only = p
        .split("\"read_only\": {")
        .nth(1)
        .and_then(|r| r.split('}').next())
        .unwrap_or("");
    assert!(
        read_only.contains("true") && !read_only.contains("false"),
        "every plant parameter read-only: {p}"
    );
}

#[test]
fn ros_args_name_the_node_and_set_its_parameters_and_bad_ones_stop_it() {
    let (run, p) = params_run(
        90,
        r#"
        printf '/**:\n  ros__parameters:\n    mode: custom\n    some_other_nodes_param: 1\n/robot1/ctl:\n  ros__parameters:\n    alpha: 1.2\n' > $TMP/p.yaml
        printf '/robot1/ctl:\n  ros__parameters:\n    gain: fast\n' > $TMP/bad.yaml
        $B/capsule_controller --scene "$SCENE" --ros-args --params-file $TMP/bad.yaml -r __ns:=/robot1 -r __node:=ctl
        echo "bad file rc=$?"
        $B/capsule_controller --scene "$SCENE" --ros-args -p gain
        echo "bad arg rc=$?"
        start_controller --ros-args -r __ns:=/robot1 -r __node:=ctl \
            --params-file $TMP/p.yaml -p gain:=0.3
        peer params --node /robot1/ctl || exit 1
        stop $C"#,
    );
    run.assert_stdout(&["bad file rc=2", "bad arg rc=2"]);
    run.assert_stderr(&[
        "bad.yaml: /robot1/ctl.ros__parameters.gain: wrong parameter type",
        "-p \"gain\": expected NAME:=VALUE",
    ]);
    assert_contains(
        &p,
        &["\"mode\": \"CUSTOM\"", "\"gain\": 0.3", "\"alpha\": 1.2"],
    );
}
