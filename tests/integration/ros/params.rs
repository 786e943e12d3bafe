//! ROS parameters over a real peer: the Cyclone DDS Python binding calls the nodes'
//! rcl_interfaces services in the rmw_cyclonedds mapping (as `ros2 param` on
//! rmw_cyclonedds_cpp does) and reads /parameter_events.

use super::harness::{json_raw, netns, root};

fn peer() -> String {
    root()
        .join("tests/peers/cyclone_peer.py")
        .display()
        .to_string()
}

/// The JSON line of the peer's `params` command.
fn params_line(stdout: &str) -> &str {
    stdout
        .lines()
        .find(|l| l.starts_with("{\"names\""))
        .unwrap_or("")
}

#[test]
fn controller_parameters_get_set_and_refuse_over_the_cyclone_peer() {
    let py = peer();
    let run = netns(
        120,
        &format!(
            r#"
            export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp
            $B/capsule_controller --scene "$SCENE" --mode forward &
            C=$!
            python3 {py} params --node /capsule_controller \
                --set 'gain=0.5' --set 'mode="backward"' --set 'alpha=1.5' \
                --refuse 'gain="x"' --refuse 'gain=nan' --refuse 'gain=5.0' --refuse 'gain=1' \
                --refuse 'no_such=1.0' --refuse 'm1_kg=0.1' --refuse 'mode="sideways"' \
                --refuse 'gain_limit=-1.0' || exit 1
            # the controller runs what the parameters say
            python3 {py} status --periods 0 --timeout 5 || exit 1
            # set_mode refuses the same gain for the same reason
            python3 {py} set-mode 2 5.0 || exit 1
            kill -TERM $C; wait $C"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let p = params_line(&run.stdout);
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
    // before the sets: FORWARD with the default gain
    assert!(p.contains("\"gain\": 0.2"), "{p}");
    assert!(p.contains("\"mode\": \"FORWARD\""), "{p}");
    assert!(p.contains("\"m1_kg\": true"), "m1_kg read-only: {p}");
    assert!(p.contains("\"gain\": false"), "gain writable: {p}");
    assert_eq!(
        json_raw(p, "no_such"),
        Some("0"),
        "unknown type NOT_SET: {p}"
    );
    // sets: the value read back and the event; BACKWARD keeps |k_p| and takes the sign
    assert!(
        p.contains("\"name\": \"gain\", \"value\": 0.5, \"now\": 0.5"),
        "{p}"
    );
    assert!(
        p.contains("\"now\": \"BACKWARD\", \"events\": [{\"gain\": -0.5, \"mode\": \"BACKWARD\"}]"),
        "{p}"
    );
    // refusals, with their reasons (the peer checked: nothing changed, no event)
    for reason in [
        "wrong parameter type: 'gain' is of type double, setting it to string",
        "parameter 'gain' = NaN: not finite",
        "gain -5 is beyond the configured limit |k_p| <= 2",
        "setting it to integer",
        "parameter 'no_such' is not declared",
        "parameter 'm1_kg' is read-only",
        "unknown mode \\\"sideways\\\"",
        "out of range",
    ] {
        assert!(p.contains(reason), "reason {reason:?} missing: {p}");
    }
    assert!(
        p.contains("\"atomic_refused\": \"parameter 'no_such' is not declared\""),
        "{p}"
    );
    let status = run
        .stdout
        .lines()
        .find(|l| l.contains("\"mode_name\""))
        .unwrap_or("");
    assert!(status.contains("\"mode_name\": \"BACKWARD\""), "{status}");
    assert!(status.contains("\"gain\": -0.5"), "{status}");
    assert!(status.contains("\"drive_amplitude\": 1.5"), "{status}");
    let answer = run
        .stdout
        .lines()
        .find(|l| l.starts_with("{\"accepted\""))
        .unwrap_or("");
    assert!(
        answer.contains("\"reason\": \"gain -5 is beyond the configured limit |k_p| <= 2\""),
        "set_mode's reason differs: {answer}"
    );
}

#[test]
fn plant_parameters_are_read_only_and_say_so() {
    let py = peer();
    let run = netns(
        90,
        &format!(
            r#"
            export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp
            $B/capsule_plant --scene "$SCENE" --until-s 30 &
            P=$!
            python3 {py} params --node /capsule_plant --refuse 'rate_hz=10.0' --refuse 'scene="x"' || exit 1
            kill -TERM $P; wait $P"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let p = params_line(&run.stdout);
    assert!(p.contains("\"rate_hz\": 1000.0"), "{p}");
    assert!(p.contains("\"pacing\": \"realtime\""), "{p}");
    assert!(p.contains("\"rate_hz\": true"), "read-only: {p}");
    let read_only = p
        .split("\"read_only\": {")
        .nth(1)
        .and_then(|r| r.split('}').next())
        .unwrap_or("");
    assert!(
        read_only.contains("true") && !read_only.contains("false"),
        "every plant parameter read-only: {p}"
    );
    assert!(p.contains("parameter 'rate_hz' is read-only"), "{p}");
}

#[test]
fn ros_args_name_the_node_and_set_its_parameters_and_bad_ones_stop_it() {
    let py = peer();
    let run = netns(
        90,
        &format!(
            r#"
            export RMW_IMPLEMENTATION=rmw_cyclonedds_cpp
            printf '/**:\n  ros__parameters:\n    mode: custom\n    some_other_nodes_param: 1\n/robot1/ctl:\n  ros__parameters:\n    alpha: 1.2\n' > $TMP/p.yaml
            printf '/robot1/ctl:\n  ros__parameters:\n    gain: fast\n' > $TMP/bad.yaml
            $B/capsule_controller --scene "$SCENE" --ros-args --params-file $TMP/bad.yaml -r __ns:=/robot1 -r __node:=ctl
            echo "bad file rc=$?"
            $B/capsule_controller --scene "$SCENE" --ros-args -p gain
            echo "bad arg rc=$?"
            $B/capsule_controller --scene "$SCENE" --ros-args -r __ns:=/robot1 -r __node:=ctl \
                --params-file $TMP/p.yaml -p gain:=0.3 &
            C=$!
            python3 {py} params --node /robot1/ctl || exit 1
            kill -TERM $C; wait $C"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    assert!(run.stdout.contains("bad file rc=2"), "{}", run.all());
    assert!(
        run.stderr
            .contains("bad.yaml: /robot1/ctl.ros__parameters.gain: wrong parameter type"),
        "{}",
        run.all()
    );
    assert!(run.stdout.contains("bad arg rc=2"), "{}", run.all());
    assert!(
        run.stderr.contains("-p \"gain\": expected NAME:=VALUE"),
        "{}",
        run.all()
    );
    let p = params_line(&run.stdout);
    assert!(p.contains("\"mode\": \"CUSTOM\""), "{p}");
    assert!(p.contains("\"gain\": 0.3"), "{p}");
    assert!(p.contains("\"alpha\": 1.2"), "{p}");
}
