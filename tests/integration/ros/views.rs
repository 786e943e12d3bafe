//! The plant's standard-type views read by a real peer (Cyclone DDS Python binding):
//! joint_states and /tf checked against the state sample of the same stamp, the URDF on
//! robot_description reaching a late (transient-local) reader, /diagnostics levels; each view
//! switched off by a flag or a parameter stays silent.

use super::harness::{json_number, netns, root};

fn peer() -> String {
    root()
        .join("tests/peers/cyclone_peer.py")
        .display()
        .to_string()
}

#[test]
fn views_map_the_state_and_diagnostics_follow_the_loop() {
    let py = peer();
    let run = netns(
        150,
        &format!(
            r#"
            $B/capsule_controller --scene "$SCENE" --mode forward &
            C=$!
            $B/capsule_plant --scene "$SCENE" --until-s 90 &
            P=$!
            sleep 2
            python3 {py} views --seconds 3 || exit 1
            kill -TERM $C; wait $C
            sleep 1.5
            python3 {py} views --seconds 2.5 || exit 1
            kill -TERM $P; wait $P"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let lines: Vec<&str> = run
        .stdout
        .lines()
        .filter(|l| l.contains("\"joint_states_matched\""))
        .collect();
    assert_eq!(lines.len(), 2, "{}", run.all());
    let live = lines[0];
    // 100 Hz views of a 1 kHz loop (every 10th sample; the thinning is unit-tested): the peer
    // matched at least 10 of each to a state sample, value for value
    assert!(
        json_number(live, "joint_states_matched").unwrap_or(0.0) >= 10.0,
        "{live}"
    );
    assert!(
        json_number(live, "tf_matched").unwrap_or(0.0) >= 10.0,
        "{live}"
    );
    assert!(live.contains("\"name\": \"capsule_plant: loop\""), "{live}");
    // commanded: answers counted, latency measured (the level itself depends on the host's
    // load here; the unit test checks the levels)
    assert!(!live.contains("\"answers_last_s\": \"0\""), "{live}");
    assert!(!live.contains("\"latency_p99_ms\": \"n/a\""), "{live}");
    // the controller gone: the watchdog fired, ERROR
    let gone = lines[1];
    assert_eq!(json_number(gone, "level"), Some(2.0), "{gone}");
    assert!(
        gone.contains("\"watchdog\": \"fired (zero force)\""),
        "{gone}"
    );
}

#[test]
fn views_switched_off_stay_silent() {
    let py = peer();
    let run = netns(
        90,
        &format!(
            r#"
            $B/capsule_plant --scene "$SCENE" --until-s 90 --no-tf --no-diagnostics \
                --ros-args -p views.joint_states:=false -p views.robot_description:=false &
            P=$!
            sleep 1
            python3 {py} views --seconds 2 --absent joint_states tf diagnostics robot_description || exit 1
            kill -TERM $P; wait $P"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let out = run
        .stdout
        .lines()
        .find(|l| l.starts_with("{\"state\""))
        .unwrap_or("");
    assert!(json_number(out, "state").unwrap_or(0.0) > 10.0, "{out}");
    assert_eq!(json_number(out, "joint_states"), Some(0.0), "{out}");
}

#[test]
fn the_controller_reports_on_diagnostics() {
    let py = peer();
    let run = netns(
        150,
        &format!(
            r#"
            $B/capsule_controller --scene "$SCENE" --mode forward &
            C=$!
            python3 {py} diagnostics --name capsule_controller --seconds 1.5 || exit 1
            $B/capsule_plant --scene "$SCENE" --until-s 90 --no-diagnostics &
            P=$!
            sleep 2
            python3 {py} diagnostics --name capsule_controller --seconds 2.5 || exit 1
            kill -TERM $P; wait $P
            sleep 1.5
            python3 {py} diagnostics --name capsule_controller --seconds 2.5 || exit 1
            kill -TERM $C; wait $C"#
        ),
    );
    assert_eq!(run.code, Some(0), "{}", run.all());
    let lines: Vec<&str> = run
        .stdout
        .lines()
        .filter(|l| l.starts_with("{\"capsule_controller\""))
        .collect();
    assert_eq!(lines.len(), 3, "{}", run.all());
    for l in &lines {
        assert!(l.contains("\"capsule_controller: control\""), "{l}");
        assert!(l.contains("\"mode\": \"FORWARD\""), "{l}");
    }
    // no plant yet: WARN, not seen
    assert_eq!(json_number(lines[0], "level"), Some(1.0), "{}", lines[0]);
    assert!(
        lines[0].contains("\"plant\": \"not seen yet\""),
        "{}",
        lines[0]
    );
    assert!(
        lines[0].contains("\"commands_sent\": \"0\""),
        "{}",
        lines[0]
    );
    // the plant running: commands went out in the last second, the plant is seen
    let live = lines[1];
    assert!(live.contains("\"plant\": \"seen\""), "{live}");
    assert!(!live.contains("\"commands_last_s\": \"0\""), "{live}");
    assert!(
        live.contains("\"plant_takes_commands\": \"true\""),
        "{live}"
    );
    // the plant gone: the watchdog fired, ERROR
    let gone = lines[2];
    assert_eq!(json_number(gone, "level"), Some(2.0), "{gone}");
    assert!(
        gone.contains("\"plant\": \"lost (watchdog fired)\""),
        "{gone}"
    );
}
