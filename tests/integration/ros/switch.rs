//! The controller's attractor switch (SWITCH_ATTRACTOR, issue 13 point 3) live: closed loop in
//! lock-step at alpha 1.5, and the request's checks through the Cyclone DDS peer.

use super::harness::{assert_contains, netns, netns_with_peer};

/// `key=value` of the client's `SWITCH ...` summary line.
fn field<'a>(line: &'a str, key: &str) -> &'a str {
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix(key).and_then(|r| r.strip_prefix('=')))
        .unwrap_or_else(|| panic!("no {key} in {line}"))
}

#[test]
fn switch_attractor_moves_period_3_to_period_1_in_lockstep_and_releases_the_gain() {
    // scenes/switch_alpha15.toml: alpha 1.5, k_p 0, start (-1.5, 0, 0, 0) on period 3; offline
    // (`capsule switch --alpha 1.5 --pulse-kp 0.3 --pulse-at 300 --kp-after 0 --scan 6`) a
    // one-period pulse of 0.3 succeeds at one phase of the three, so 3 tries always suffice.
    // The plant's command timeout is raised: a zero-force step under load would kick the orbit.
    let run = netns(
        300,
        r#"S="$ROOT/scenes/switch_alpha15.toml"
           $B/capsule_controller --scene "$S" &
           C=$!
           $B/capsule_ros switch-attractor --scene "$S" --gain 0.3 --pulse-periods 1 --target-period 1 \
               --max-tries 3 --before-periods 40 --after-periods 30 --timeout-s 250 &
           R=$!
           $B/capsule_plant --scene "$S" --pacing lockstep --command-timeout-s 60 --until-s 100 \
               --wait-subscribers 2 --record-output $TMP/switch.mcap &
           P=$!
           wait $R; rc=$?
           kill -TERM $P $C; wait
           # the recorded run, pulses and all, re-driven through the controller library
           $B/capsule replay --check-controller $TMP/switch.mcap || exit 1
           exit $rc"#,
    );
    run.assert_ok();
    run.assert_stdout(&[
        "ok: the controller reproduces the recorded commands",
        "(1 mode requests, 0 answered differently",
    ]);
    let line = run.line("SWITCH ");
    // period 3 before, period 1 after (state and status), back to the previous mode, the gain
    // released
    for (key, want) in [
        ("result", "SUCCEEDED"),
        ("before", "3"),
        ("after", "1"),
        ("status_orbit_period", "1"),
        ("mode", "OFF"),
        ("gain", "0"),
    ] {
        assert_eq!(field(line, key), want, "{key}: {line}");
    }
    let tries: i32 = field(line, "tries").parse().unwrap_or(-1);
    assert!((1..=3).contains(&tries), "{line}");
    // the last pulse lasted one drive period: 2 pi / 0.95 / Omega0 = 0.1046 s, to a sample
    let start: f64 = field(line, "pulse_start_s").parse().unwrap_or(f64::NAN);
    let end: f64 = field(line, "pulse_end_s").parse().unwrap_or(f64::NAN);
    let period_s = std::f64::consts::TAU / 0.95 / (200.0f64 / 0.05).sqrt();
    assert!(
        start > 0.0 && (end - start - period_s).abs() <= 0.0015,
        "pulse {start}..{end} s vs period {period_s}: {line}"
    );
    // the status showed each pulse on, with the pulse gain, and released after it
    let pulsing = run
        .stdout
        .lines()
        .filter(|l| l.starts_with("status: switch PULSING") && l.contains("k_p 0.3 "))
        .count();
    assert_eq!(pulsing, tries as usize, "{}", run.stdout);
}

#[test]
fn switch_requests_are_checked_through_the_cyclone_peer() {
    let run = netns_with_peer(
        120,
        r#"
        sm() { peer set-mode "$@" || exit 1; }
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_controller --mode forward
        sm 5 0.3 --pulse-periods 11 --target-period 1 --max-tries 3
        sm 5 nan --pulse-periods 1 --target-period 1 --max-tries 3
        sm 5 0.3 --pulse-periods 0 --target-period 1 --max-tries 3
        sm 5 0.3 --pulse-periods -2 --target-period 1 --max-tries 3
        sm 5 0.3 --pulse-periods 1 --target-period 1 --max-tries 0
        sm 5 0.3 --pulse-periods 1 --target-period 0 --max-tries 3
        sm 5 0.3 --pulse-periods 1 --target-period 1 --max-tries 3
        sm 1 0.0
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp $B/capsule_ros set-mode switch-attractor --gain 0.3 --max-tries -1; echo "rust client rc=$?"
        stop $C"#,
    );
    run.assert_ok();
    let answers = run.lines_exactly("{\"accepted\"", 8);
    for (a, why) in answers[..6].iter().zip([
        "pulse_periods = 11",
        "not finite",
        "pulse_periods = 0",
        "pulse_periods = -2",
        "max_tries = 0",
        "target_period = 0",
    ]) {
        // refused naming the reason; FORWARD 0.2 stays
        assert_contains(
            a,
            &["\"accepted\": false", why, "\"mode\": 1", "\"gain\": 0.2"],
        );
    }
    assert_contains(answers[6], &["\"accepted\": true", "\"mode\": 5"]);
    // a mode request ends the switch: FORWARD again (the switch had nothing to act on)
    assert_contains(answers[7], &["\"accepted\": true", "\"mode\": 1"]);
    run.assert_stdout(&["accepted=false", "max_tries = -1", "rust client rc=3"]);
}
