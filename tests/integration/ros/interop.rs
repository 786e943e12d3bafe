//! A real peer: the Eclipse Cyclone DDS Python binding reads the state, commands the plant and
//! calls the mode service in the rmw_cyclonedds request/reply mapping.

use super::harness::{
    assert_contains, assert_peer_read_state_and_commanded, assert_set_mode_answers, json_number,
    netns_with_peer, set_mode_calls, state_and_force_script,
};

#[test]
fn cyclone_peer_reads_state_and_commands_the_plant() {
    let run = netns_with_peer(120, &state_and_force_script("peer", 12));
    assert_peer_read_state_and_commanded(&run);
}

#[test]
fn cyclone_peer_calls_the_mode_service_in_the_cyclone_mapping() {
    let run = netns_with_peer(
        90,
        &format!(
            "RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_controller --mode forward
            {}
            stop $C",
            set_mode_calls("peer")
        ),
    );
    assert_set_mode_answers(&run);
}

#[test]
fn cyclone_peer_reads_the_controller_status() {
    let run = netns_with_peer(
        120,
        r#"
        start_controller --mode forward --use-sim-time
        start_plant --pacing lockstep --until-s 6
        peer status --periods 30; rc=$?
        kill -TERM $C $P; wait; exit $rc"#,
    );
    run.assert_ok();
    let st = run.json_with("mode_name");
    assert_contains(st, &["\"mode_name\": \"FORWARD\"", "\"commanding\": true"]);
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
