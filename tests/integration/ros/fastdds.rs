//! The default ROS 2 middleware as a real peer (#19): an eProsima Fast DDS 2.9 C++ program
//! (tests/peers/fastdds/, Debian libfastrtps-dev) with the types as rosidl generates them for
//! rmw_fastrtps_cpp and its request/reply correlation reads the state, commands the plant, calls
//! set_mode and the parameter services, sends a Move goal (send_goal, get_result, feedback);
//! bad input from it is refused and the nodes keep serving.
//! The nodes run with RMW_IMPLEMENTATION unset, i.e. in the Fast DDS ("enhanced") mapping, as
//! next to an rclcpp node on a default installation.

use super::harness::{
    assert_at_least, assert_contains, assert_peer_read_state_and_commanded,
    assert_set_mode_answers, assert_state_at_1khz, json_number, netns_with_fastdds_peer,
    set_mode_calls, state_and_force_script,
};

#[test]
fn fastdds_peer_reads_state_and_commands_the_plant() {
    let run = netns_with_fastdds_peer(120, &state_and_force_script("fpeer", 14));
    assert_peer_read_state_and_commanded(&run);
}

#[test]
fn fastdds_peer_calls_set_mode_and_the_parameter_services_in_the_fastrtps_mapping() {
    let run = netns_with_fastdds_peer(
        120,
        &format!(
            "start_controller --mode forward
            start_plant
            {}
            fpeer params --node /capsule_controller --set gain=0.5 --set gain=5.0 || exit 1
            # the Move action as an rclcpp ActionClient on rmw_fastrtps calls it
            fpeer move 0.005 || exit 1
            fpeer move nan || exit 1
            stop $P $C",
            set_mode_calls("fpeer")
        ),
    );
    assert_set_mode_answers(&run);
    // 5 mm: SUCCEEDED (4) within the default tolerance, feedback on the way; NaN refused
    let goals = run.lines_exactly("{\"distance\"", 2);
    assert_contains(
        goals[0],
        &["\"accepted\": true", "\"status\": 4", "\"reached\": true"],
    );
    assert!(
        json_number(goals[0], "error_m").is_some_and(|e| e.abs() <= 1e-3),
        "{}",
        goals[0]
    );
    assert_at_least(goals[0], "feedback", 5.0);
    assert_contains(goals[1], &["\"accepted\": false"]);
    let p = run.json_with("names");
    for name in [
        "mode",
        "gain",
        "direction_gain",
        "alpha",
        "omega",
        "use_sim_time",
    ] {
        assert!(p.contains(&format!("\"{name}\"")), "{name} not listed: {p}");
    }
    // listed and got as the set_mode calls left them; then one set taken (BACKWARD: the sign
    // follows the mode) and one refused beyond the limit, the value unchanged
    assert_contains(
        p,
        &[
            "\"mode\": \"BACKWARD\"",
            "{\"name\": \"gain\", \"successful\": true, \"reason\": \"\", \"now\": -0.5}",
            "{\"name\": \"gain\", \"successful\": false",
            "beyond the configured limit",
        ],
    );
    assert!(p.ends_with("\"now\": -0.5}]}"), "{p}");
}

#[test]
fn fastdds_bad_input_is_refused_and_the_nodes_keep_serving() {
    let run = netns_with_fastdds_peer(
        150,
        r#"
        start_controller --mode forward 2>"$TMP/controller.log"
        # a request naming no reply reader: rmw_fastrtps answers to the request's own identity
        fpeer bad identity || exit 1
        # the request in rmw_cyclonedds's layout on the Fast DDS topic
        fpeer bad cyclone || exit 1
        fpeer params --node /capsule_controller || exit 1
        fpeer set-mode 1 0.3 || exit 1
        stop $C
        # the peer is the plant's only commander from here
        start_plant --until-s 14 2>"$TMP/plant.log"
        # the ActuatorForce name with another layout, then a well-formed controller
        fpeer bad layout || exit 1
        fpeer force --force 0.05 || exit 1
        stop $P
        echo "undecodable logs: $(grep -c 'undecodable command' "$TMP/plant.log")"
        grep -m1 'undecodable command' "$TMP/plant.log" >&2"#,
    );
    run.assert_ok();
    assert_contains(run.json_with("bad"), &["\"reply\": \"request\""]);
    // the identity case's own request (FORWARD 0.2) was answered, then BACKWARD 0.1 taken; the
    // Cyclone-layout request (BACKWARD 0.1 behind a 16-byte header) changed nothing
    let p = run.json_with("names");
    assert_contains(p, &["\"mode\": \"BACKWARD\""]);
    assert_eq!(json_number(p, "gain"), Some(-0.1), "{p}");
    let answers = run.lines_starting("{\"accepted\"");
    assert_contains(
        answers[answers.len() - 1],
        &["\"accepted\": true", "\"mode\": 1"],
    );
    // the foreign layout was undecodable, said so (rate-limited), and the plant still obeys
    let logged: u64 = run.after("undecodable logs: ").trim().parse().unwrap_or(0);
    assert!(
        (1..=20).contains(&logged),
        "{logged} undecodable logs\n{}",
        run.all()
    );
    assert_at_least(run.json_with("applied_samples"), "applied_samples", 5.0);
}

/// A plant whose RTPS user port another process holds (as a Fast DDS participant started at
/// the same instant sometimes does) still reaches a reliable Fast DDS reader: RustDDS alone
/// would listen elsewhere but announce its writers at the held port, so the reader's
/// acknowledgements went astray and it delivered nothing (capsule_ros_base::ports).
#[test]
fn a_plant_whose_user_port_is_taken_still_reaches_a_reliable_reader() {
    let run = netns_with_fastdds_peer(
        120,
        r#"
        python3 -c 'import socket, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM); s.bind(("0.0.0.0", 7411))
open(sys.argv[1], "w").close(); time.sleep(60)' "$TMP/held" & H=$!
        wait_line "$TMP/held" || exit 1
        start_plant --until-s 14
        fpeer state --samples 200 || exit 1
        stop $P
        kill $H"#,
    );
    run.assert_ok();
    assert_state_at_1khz(&run);
}
