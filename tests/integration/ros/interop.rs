//! A real peer: the Eclipse Cyclone DDS Python binding reads the state, commands the plant and
//! calls the mode service in the rmw_cyclonedds request/reply mapping.

use super::harness::{json_number, netns, root};

fn peer() -> String {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import cyclonedds"])
        .status()
        .is_ok_and(|s| s.success());
    assert!(ok, "python3 with cyclonedds needed: run .ci/ros-setup.sh");
    root()
        .join("tests/peers/cyclone_peer.py")
        .display()
        .to_string()
}

#[test]
fn cyclone_peer_reads_state_and_commands_the_plant() {
    let py = peer();
    let run = netns(
        120,
        &format!(
            r#"
            $B/capsule_plant --scene "$SCENE" --until-s 12 &
            P=$!
            python3 {py} state --samples 200 || exit 1
            python3 {py} force --force 0.05 || exit 1
            kill -TERM $P; wait $P"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let state = run
        .stdout
        .lines()
        .find(|l| l.contains("\"rate_hz\""))
        .unwrap_or_else(|| panic!("{}", run.all()));
    let rate = json_number(state, "rate_hz").unwrap_or(f64::NAN);
    assert!((rate - 1000.0).abs() < 1e-6, "rate {rate}: {state}");
    let force = run
        .stdout
        .lines()
        .find(|l| l.contains("applied_samples"))
        .unwrap_or_else(|| panic!("{}", run.all()));
    assert!(
        json_number(force, "applied_samples").unwrap_or(0.0) >= 5.0,
        "{force}"
    );
    assert!(
        json_number(force, "refused_after") > json_number(force, "refused_before"),
        "{force}"
    );
}

#[test]
fn cyclone_peer_calls_the_mode_service_in_the_cyclone_mapping() {
    let py = peer();
    let run = netns(
        90,
        &format!(
            r#"
            RMW_IMPLEMENTATION=rmw_cyclonedds_cpp $B/capsule_controller --scene "$SCENE" --mode forward &
            C=$!
            python3 {py} set-mode 2 0.1 || exit 1
            python3 {py} set-mode 9 0.1 || exit 1
            python3 {py} set-mode 4 nan || exit 1
            kill -TERM $C; wait $C"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let answers: Vec<&str> = run
        .stdout
        .lines()
        .filter(|l| l.starts_with("{\"accepted\""))
        .collect();
    assert_eq!(answers.len(), 3, "{}", run.all());
    assert!(
        answers[0].contains("\"accepted\": true") && answers[0].contains("\"gain\": -0.1"),
        "{}",
        answers[0]
    );
    assert!(
        answers[1].contains("\"accepted\": false") && answers[1].contains("unknown mode 9"),
        "{}",
        answers[1]
    );
    assert!(
        answers[1].contains("\"mode\": 2"),
        "mode must stay BACKWARD: {}",
        answers[1]
    );
    assert!(
        answers[2].contains("\"accepted\": false") && answers[2].contains("not finite"),
        "{}",
        answers[2]
    );
}

#[test]
fn cyclone_peer_reads_the_controller_status() {
    let py = peer();
    let run = netns(
        120,
        &format!(
            r#"
            $B/capsule_controller --scene "$SCENE" --mode forward --use-sim-time &
            C=$!
            $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 6 &
            P=$!
            python3 {py} status --periods 30; rc=$?
            kill -TERM $C $P; wait; exit $rc"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let st = run
        .stdout
        .lines()
        .find(|l| l.contains("\"mode_name\""))
        .unwrap_or_else(|| panic!("{}", run.all()));
    assert!(st.contains("\"mode_name\": \"FORWARD\""), "{st}");
    assert!(st.contains("\"commanding\": true"), "{st}");
    assert_eq!(json_number(st, "gain"), Some(0.2), "{st}");
    assert_eq!(json_number(st, "drive_amplitude"), Some(1.6), "{st}");
    let prog = json_number(st, "progression_per_period").unwrap_or(f64::NAN);
    let eff = json_number(st, "efficiency").unwrap_or(f64::NAN);
    // forward motion from rest: positive progression (the steady state is ~3.08 per period)
    assert!(prog > 1.0 && prog < 4.0, "{st}");
    assert!(eff > 0.0 && eff.is_finite(), "{st}");
    // use_sim_time: the status is stamped with /clock (sim time, about seq / 1 kHz after 30
    // periods = 2.7 s), not wall time (~1.7e9 s) nor zero (no clock); the node's clock may lag a
    // little behind the samples under load
    let stamp = json_number(st, "stamp_s").unwrap_or(f64::NAN);
    let sent = json_number(st, "commands_sent").unwrap_or(f64::NAN);
    assert!(
        stamp > 2.0 && (stamp - (sent - 1.0) / 1000.0).abs() < 0.5,
        "stamp {stamp} vs {sent} commands: {st}"
    );
}
