//! The managed plant (issue 29): driven through its lifecycle by independent peers with the
//! device emulator behind it on a real pty, and its emergency stop timed while the driver waits
//! (for a hello, on a silent device, inside a lock-step step): the answer as a client sees it,
//! the zero-force frame as the device sees it.

use super::harness::{assert_contains, json_number, netns_with_fastdds_peer, netns_with_peer, nth};

/// The peer's record of one transition.
fn step(out: &str, i: usize) -> &str {
    let steps = out.split("{\"transition\"").skip(1).collect::<Vec<_>>();
    nth(&steps, i, "step")
}

#[test]
fn a_managed_plant_with_the_emulator_actuates_only_while_active() {
    // rmw_cyclonedds' mapping, as `ros2 lifecycle set` from an rclpy node would do it
    let run = netns_with_peer(
        150,
        r#"
        "$B/capsule" emulate-device --scene "$SCENE" --link "$TMP/dev" > "$TMP/emu.out" 2> "$TMP/emu.err" & E=$!
        wait_line "$TMP/dev"
        start_controller --mode forward
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_plant --source "serial:$TMP/dev" --autostart false 2> "$TMP/plant.log"
        sleep 1
        peer lifecycle activate configure activate deactivate activate shutdown || exit 1
        wait $P; echo "PLANT exited $?"
        stop $C; kill -INT $E; wait $E
        cat "$TMP/emu.err" "$TMP/plant.log" >&2"#,
    );
    run.assert_ok();
    let out = run.json_with("steps");
    // activate from unconfigured: refused, the state unchanged, nothing published
    let s = step(out, 0);
    assert_contains(
        s,
        &[
            "\"success\": false",
            "\"before\": \"unconfigured\"",
            "\"after\": \"unconfigured\"",
            "\"samples\": 0",
        ],
    );
    // configured: samples, zero force; active: the controller's force; deactivated: zero again
    let expect = [
        ("configure", "inactive", false),
        ("activate", "active", true),
        ("deactivate", "inactive", false),
        ("activate", "active", true),
    ];
    for (i, (t, after, forced)) in expect.iter().enumerate() {
        let s = step(out, i + 1);
        assert_contains(
            s,
            &[&format!("\"after\": \"{after}\""), "\"success\": true"],
        );
        assert!(s.starts_with(&format!(": \"{t}\"")), "{s}");
        assert!(json_number(s, "samples").unwrap_or(0.0) > 100.0, "{s}");
        let f = json_number(s, "max_force").unwrap_or(f64::NAN);
        if *forced {
            assert!(f > 0.01, "{t}: {s}");
        } else {
            assert_eq!(f, 0.0, "{t}: {s}");
        }
        // the service answered at once: the loop takes it at its next sample (a bound of a
        // second, not of a few samples: the peer's round trip on a loaded host took 0.51 s)
        assert!(json_number(s, "answered_s").unwrap_or(9.0) < 1.0, "{s}");
    }
    assert_contains(
        step(out, 5),
        &["\"after\": \"finalized\"", "\"success\": true"],
    );
    // every step on ~/transition_event: configure's two, ..., shutdown's two
    assert_contains(
        out,
        &[
            "[1, \"unconfigured\", \"configuring\"]",
            "[10, \"configuring\", \"inactive\"]",
            "[4, \"active\", \"deactivating\"]",
            "[7, \"active\", \"shuttingdown\"]",
            "[50, \"shuttingdown\", \"finalized\"]",
            "\"available_states\": 10",
            "\"graph\": 25",
        ],
    );
    assert!(run.stdout.contains("PLANT exited 0"), "{}", run.all());
    run.assert_stderr(&[
        "lifecycle: transition `activate` is not valid from unconfigured: valid are configure (1), shutdown (5)",
        "command-to-device latency p50",
    ]);
}

#[test]
fn a_configure_that_cannot_open_the_device_ends_in_error_processing_and_names_it() {
    let run = netns_with_peer(
        90,
        r#"
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_plant --source "serial:$TMP/nothing" --autostart false 2> "$TMP/plant.log"
        sleep 1
        peer lifecycle configure shutdown || exit 1
        wait $P; echo "PLANT exited $?"
        cat "$TMP/plant.log" >&2"#,
    );
    run.assert_ok();
    let out = run.json_with("steps");
    assert_contains(
        step(out, 0),
        &["\"success\": false", "\"after\": \"unconfigured\""],
    );
    assert_contains(
        out,
        &[
            "[12, \"configuring\", \"errorprocessing\"]",
            "[60, \"errorprocessing\", \"unconfigured\"]",
        ],
    );
    run.assert_stderr(&["configure: cannot open serial ", "/nothing at 921600 baud"]);
    // and --autostart says so at once, exit status 2
    let run = netns_with_peer(
        60,
        r#"
        "$B/capsule_plant" --scene "$SCENE" --source "serial:$TMP/nothing"; echo "PLANT exited $?""#,
    );
    assert!(run.stdout.contains("PLANT exited 2"), "{}", run.all());
    run.assert_stderr(&["--autostart: configure failed"]);
}

/// Runs `script` (a plant, a device writing its force log to `FORCES`, the peer timing the
/// stop); the slowest answer \[ms\] and the slowest zero-force frame on the device \[ms\], both
/// from the request's write.
fn estop_timed(script: &str) -> (f64, f64) {
    let run = netns_with_peer(120, script);
    run.assert_ok();
    let out = run.json_with("estop");
    let log = run.after("FORCES ");
    let mut worst = (0.0f64, 0.0f64);
    let mut each: Vec<String> = Vec::new();
    for call in out.split("{\"sent_ns\"").skip(1) {
        let sent_ns: u128 = call
            .trim_start_matches(':')
            .split(',')
            .next()
            .and_then(|v| v.trim().parse().ok())
            .unwrap_or_else(|| panic!("no sent_ns: {call}"));
        let answer = json_number(call, "answer_ms").unwrap_or(f64::NAN);
        // the first zero-force frame the device got after the call went out
        let zero_ns = log
            .split(';')
            .filter_map(|l| {
                let mut f = l.split(',');
                let t: u128 = f.next()?.trim().parse().ok()?;
                let force: f64 = f.next()?.trim().parse().ok()?;
                (t >= sent_ns && force == 0.0).then_some(t)
            })
            .min()
            .unwrap_or_else(|| panic!("no zero-force frame after {sent_ns}: {}", run.all()));
        let zero_ms = (zero_ns - sent_ns) as f64 * 1e-6;
        worst = (worst.0.max(answer), worst.1.max(zero_ms));
        each.push(format!("{answer:.2}/{zero_ms:.2}"));
    }
    println!(
        "estop (answer/zero frame, ms): {}; worst {:.3} / {:.3}",
        each.join(" "),
        worst.0,
        worst.1
    );
    worst
}

#[test]
fn the_emergency_stop_is_answered_and_zeroes_the_device_while_the_driver_waits() {
    // waiting for a hello: a pty on which no device speaks; and a device that went silent
    for quiet in ["", "--hello --measurements 50"] {
        let (answer, zero) = estop_timed(&format!(
            r#"
            python3 "$ROOT/tests/peers/quiet_device.py" "$TMP/dev" "$TMP/forces.csv" {quiet} --seconds 40 & Q=$!
            wait_line "$TMP/dev"
            RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_plant --source "serial:$TMP/dev" --startup-timeout-s 30 2> "$TMP/plant.log"
            sleep 1.5
            peer estop-time --repeat 5 || exit 1
            stop $P; kill $Q; wait $Q
            echo "FORCES $(tr '\n' ';' < "$TMP/forces.csv")"
            cat "$TMP/plant.log" >&2"#
        ));
        // bounds a loaded host holds (before the device thread: no answer in 5 s); the zero
        // frame leaves on the service's thread before the answer, but the device is a Python
        // process that stamps a frame when it gets to read it (seen 7.2 ms against a 5.7 ms
        // answer with the whole suite running). The figures for "within a sample" are measured
        // and printed, and kept in docs/perf/hardware.md
        assert!(answer < 100.0, "{quiet}: answer {answer} ms");
        assert!(
            zero < 100.0,
            "{quiet}: zero frame {zero} ms, answer {answer} ms"
        );
    }
    // inside a lock-step step: emulator and plant in lock-step, the controller answering
    let (answer, zero) = estop_timed(
        r#"
        "$B/capsule" emulate-device --scene "$SCENE" --link "$TMP/dev" --pacing lockstep --force-log "$TMP/forces.csv" > "$TMP/emu.out" 2> "$TMP/emu.err" & E=$!
        wait_line "$TMP/dev"
        start_controller --mode forward
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp start_plant --source "serial:$TMP/dev" --pacing lockstep --command-timeout-s 10 2> "$TMP/plant.log"
        sleep 2
        peer estop-time --repeat 5 || exit 1
        stop $P $C; kill -INT $E; wait $E
        echo "FORCES $(tr '\n' ';' < "$TMP/forces.csv")"
        cat "$TMP/plant.log" >&2"#,
    );
    assert!(answer < 500.0, "lock-step: answer {answer} ms");
    assert!(zero < 500.0, "lock-step: zero frame {zero} ms");
}

#[test]
fn fastdds_peer_drives_the_lifecycle_and_stops_a_plant_whose_device_is_silent() {
    // the issue's case: a plant on a line where no device speaks, which before did not answer
    // the stop for its whole start-up wait; the Fast DDS C++ peer in rmw_fastrtps' mapping
    let run = netns_with_fastdds_peer(
        120,
        r#"
        python3 "$ROOT/tests/peers/quiet_device.py" "$TMP/dev" "$TMP/forces.csv" --seconds 60 & Q=$!
        wait_line "$TMP/dev"
        start_plant --source "serial:$TMP/dev" --autostart false --startup-timeout-s 20 2> "$TMP/plant.log"
        fpeer lifecycle configure activate || exit 1
        fpeer estop || exit 1
        fpeer estop || exit 1
        fpeer lifecycle deactivate shutdown || exit 1
        wait $P; echo "PLANT exited $?"
        kill $Q; wait $Q
        cat "$TMP/plant.log" >&2"#,
    );
    run.assert_ok();
    let steps = run.lines_exactly("{\"lifecycle\"", 2);
    assert_contains(
        steps[0],
        &[
            "{\"transition\": \"configure\", \"success\": true, \"state\": \"inactive\", \"id\": 2}",
            "{\"transition\": \"activate\", \"success\": true, \"state\": \"active\", \"id\": 3}",
        ],
    );
    assert_contains(
        steps[1],
        &[
            "\"deactivate\", \"success\": true, \"state\": \"inactive\"",
            "\"state\": \"finalized\"",
        ],
    );
    let stops = run.lines_exactly("{\"engaged\"", 2);
    for s in stops {
        assert_contains(s, &["\"engaged\": true", "\"released\": true"]);
        assert!(
            json_number(s, "answer_ms").unwrap_or(f64::NAN) < 200.0,
            "{s}"
        );
    }
    assert!(run.stdout.contains("PLANT exited 0"), "{}", run.all());
}
