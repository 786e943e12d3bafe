//! The fault matrix (issue 12; expected behaviour of every row in docs/ros.md, "Faults"): nodes
//! killed and restarted, hostile commands, a second plant, a foreign type on the force topic,
//! a dying recorder. Each case runs real time at 1 kHz in its own loopback-only namespace,
//! bounded in time; the hostile peer is the Cyclone DDS Python binding
//! (`tests/peers/cyclone_peer.py inject|foreign`). Assertions leave room for a loaded host
//! (lost samples are not what these cases check).

use super::harness::{assert_at_least, assert_contains, json_number, json_raw, netns, Run};

/// The plant's summary JSON line (the first stdout line starting with `{"samples"`).
fn summary(run: &Run) -> &str {
    run.line("{\"samples\"")
}

/// The plant's summary, which must show that it was commanded at its end (`command_stale`
/// false: the controller's commands were not lost).
#[track_caller]
fn commanded(run: &Run) -> &str {
    let j = summary(run);
    assert_eq!(json_raw(j, "command_stale"), Some("false"), "{j}");
    j
}

/// The number the script printed after `{what} log lines: ` (not a number: u32::MAX).
fn log_lines(run: &Run, what: &str) -> u32 {
    run.after(&format!("{what} log lines: "))
        .trim()
        .parse()
        .unwrap_or(u32::MAX)
}

/// Where the zero-force watchdog is not what a case checks, the plant waits 1 s for it (not the
/// scene's 0.1 s), so a loaded host's stalls do not trip it.
const LAX: &str = "--command-timeout-s 1";

/// A plant that runs until the case's script stops it (pid `$P`), its summary in `$TMP/p.json`,
/// its log in `$TMP/p.log`.
const PLANT: &str = "start_plant --until-s 300 --summary-json $TMP/p.json 2> $TMP/p.log";

/// Runs a case's script in its namespace, with `$PLANT` and `$LAX` filled in.
fn case(timeout_s: u32, script: &str) -> Run {
    netns(
        timeout_s,
        &script.replace("$PLANT", PLANT).replace("$LAX", LAX),
    )
}

/// [`case`] with a controller in forward mode started first (pid `$C`, its stderr in
/// `$TMP/ctl.log`); the script stops it.
fn controlled(timeout_s: u32, script: &str) -> Run {
    case(
        timeout_s,
        &format!("start_controller --mode forward 2> $TMP/ctl.log\n{script}"),
    )
}

#[test]
fn a_restarted_plant_is_commanded_from_its_first_samples() {
    // before the fix the new plant waited until its seq passed the killed one's (~1500 here):
    // within its 1 s run it was never answered
    let run = controlled(
        90,
        r#"
        start_plant --until-s 20 2>/dev/null
        sleep 2
        kill -KILL $P; wait $P 2>/dev/null
        $B/capsule_plant --scene "$SCENE" --until-s 1 --wait-subscribers 1 $LAX \
            --summary-json $TMP/p2.json 2>/dev/null
        echo "plant2 rc=$?"
        cat $TMP/p2.json
        stop $C
        cat $TMP/ctl.log"#,
    );
    run.assert_stdout(&["plant2 rc=0", "a new plant publishes"]);
    let j = commanded(&run);
    // the fixed controller answers within a few samples on a quiet host; the bound leaves a
    // loaded CI host 0.25 s for the new plant's command reader to match, far below the ~2000
    // samples the bug made it wait
    let before = json_number(j, "before_first_answer").unwrap_or(f64::NAN);
    assert!(before <= 250.0, "first answer after {before} samples: {j}");
}

#[test]
fn a_killed_controller_means_zero_force_and_its_successor_resumes() {
    // the successor has 3.5 s of the plant's run to take over (a loaded host's start and
    // discovery can take more than a second)
    let run = controlled(
        90,
        r#"
        start_plant --until-s 6 --summary-json $TMP/p.json 2> $TMP/p.log
        sleep 2
        kill -KILL $C; wait $C 2>/dev/null
        sleep 0.5
        start_controller --mode forward 2>/dev/null
        wait $P; echo "plant rc=$?"
        stop $C
        cat $TMP/p.json; cat $TMP/p.log"#,
    );
    run.assert_stdout(&["plant rc=0"]);
    // the fallback, then commanded again
    let zero = run
        .stdout
        .find("applying zero force")
        .unwrap_or_else(|| panic!("no fallback\n{}", run.all()));
    assert_contains(&run.stdout[zero..], &["applying commanded force"]);
}

#[test]
fn huge_and_non_finite_forces_never_kill_the_plant() {
    // before the fix 1e308 N ended the plant ("state became non-finite", exit 2)
    let run = case(
        120,
        r#"
        $PLANT
        peer inject --force=nan,inf,1e308,-1e308,1000 --seconds 0.5 --min-states 50 \
            || echo "peer failed"
        stop $P; echo "plant rc=$?"
        cat $TMP/p.json
        echo "saturation log lines: $(grep -c 'beyond the force limit' $TMP/p.log)"
        echo "refusal log lines: $(grep -c 'command refused' $TMP/p.log)""#,
    );
    let all = run.all();
    run.assert_stdout(&["plant rc=0"]);
    assert!(!run.stdout.contains("peer failed"), "{all}");
    let j = summary(&run);
    assert_at_least(j, "saturated_commands", 3.0);
    // NaN and inf
    assert_at_least(j, "rejected_commands", 2.0);
    // 1e308, -1e308 and 1000 N: applied saturated at 100 P_f = 10 N; every state finite
    let phases = run.lines_starting("{\"force\"");
    assert_eq!(phases.len(), 5, "{all}");
    for p in &phases {
        assert_eq!(json_raw(p, "finite"), Some("true"), "{p}");
        // each phase waited for 50 states (a loaded CI host once delivered none in 0.5 s)
        assert_at_least(p, "received", 50.0);
    }
    for p in &phases[2..] {
        assert_eq!(json_number(p, "max_abs_applied"), Some(10.0), "{p}");
    }
    // logged rate-limited: hundreds of commands, a few lines
    for what in ["saturation", "refusal"] {
        let n = log_lines(&run, what);
        assert!((1..=25).contains(&n), "{what}: {n} lines\n{all}");
    }
}

#[test]
fn a_command_stamped_in_the_far_future_blocks_nothing() {
    // before the fix every later command was refused as late and the force went to 0
    let run = controlled(
        120,
        r#"
        $PLANT $LAX
        peer inject --force 0.05 --seconds 0 --stamp-sec 2147483647 --until-refused >/dev/null
        sleep 1
        stop $P; echo "plant rc=$?"
        stop $C
        cat $TMP/p.json; cat $TMP/ctl.log"#,
    );
    run.assert_stdout(&["plant rc=0"]);
    let j = commanded(&run);
    let refused = json_number(j, "rejected_commands").unwrap_or(f64::NAN);
    assert!((1.0..=3.0).contains(&refused), "refused {refused}: {j}");
    assert!(
        !run.stdout.contains("does not take our commands"),
        "{}",
        run.all()
    );
}

/// A burst of commands far above the sample rate (20 kHz asked; what the Python peer reaches
/// on a loaded host is printed: 1.4-2.9 kHz on this 2-core machine at load 14): the plant
/// takes the newest per sample, ignores repeats (not refused), applies the force and goes on.
/// The state seqs the peer missed (`gaps`) are printed, not asserted: on a loaded host they
/// measure the peer.
#[test]
fn a_command_burst_is_taken_newest_first_and_repeats_are_not_refused() {
    let run = case(
        120,
        r#"
        $PLANT
        peer inject --force 0.05 --hz 20000 --seconds 2
        stop $P; echo "plant rc=$?"
        cat $TMP/p.json"#,
    );
    run.assert_stdout(&["plant rc=0"]);
    let peer = run.json_with("sent");
    println!("burst: {peer}");
    assert_eq!(json_number(peer, "max_abs_applied"), Some(0.05), "{peer}");
    let j = summary(&run);
    assert_eq!(json_number(j, "rejected_commands"), Some(0.0), "{j}");
}

#[test]
fn a_second_plant_of_the_same_name_is_reported_by_both_nodes() {
    // before the fix nothing said so (the second plant applied the first one's commands)
    let run = controlled(
        90,
        r#"
        $B/capsule_plant --scene "$SCENE" --until-s 8 $LAX --summary-json $TMP/a.json 2> $TMP/a.log &
        A=$!
        sleep 1.5
        # 3 s: both nodes must discover it while it lives, also on a loaded host
        $B/capsule_plant --scene "$SCENE" --until-s 3 2>/dev/null
        wait $A; echo "plant A rc=$?"
        stop $C
        cat $TMP/a.json; cat $TMP/a.log $TMP/ctl.log"#,
    );
    run.assert_stdout(&[
        "plant A rc=0",
        "A SECOND PLANT publishes",
        "GRAPH CONFLICT",
        "ANOTHER PLANT",
    ]);
    // the controller kept plant A
    assert_at_least(commanded(&run), "graph_conflicts", 1.0);
}

#[test]
fn foreign_writers_on_the_force_topic_are_named_and_logged_rate_limited() {
    // before the fix an undecodable command was logged once per sample
    let run = controlled(
        120,
        r#"
        $PLANT $LAX
        peer foreign --kind type --seconds 1.5
        peer foreign --kind layout --seconds 1.5
        stop $P; echo "plant rc=$?"
        stop $C
        cat $TMP/p.json
        echo "undecodable log lines: $(grep -c 'undecodable command' $TMP/p.log)"
        grep 'GRAPH CONFLICT' $TMP/p.log"#,
    );
    run.assert_stdout(&[
        "plant rc=0",
        "GRAPH CONFLICT: a publisher of type std_msgs::msg::dds_::String_",
    ]);
    let n = log_lines(&run, "undecodable");
    assert!(
        (1..=25).contains(&n),
        "{n} undecodable lines\n{}",
        run.all()
    );
    commanded(&run);
}

#[test]
fn the_launcher_keeps_control_when_only_the_recorder_dies() {
    // before the fix the launcher stopped the whole graph
    let run = case(
        120,
        r#"
        $ROOT/launch_scripts/capsule_launch.sh --separate --scene "$SCENE" --until-s 4 --mode forward \
            --record-dir $TMP/runs --plant-arg --summary-json --plant-arg $TMP/p.json \
            --plant-arg --command-timeout-s --plant-arg 1 2> $TMP/l.log &
        L=$!
        # the recorder proper (not its --check run) once its file exists
        for i in $(seq 300); do ls $TMP/runs/*.mcap >/dev/null 2>&1 && break; sleep 0.1; done
        R=$(pgrep -P $L -f capsule_recorder)
        sleep 1.5
        kill -KILL $R || echo "no recorder to kill: '$R'"
        wait $L; echo "launcher rc=$?"
        cat $TMP/p.json
        grep capsule_launch $TMP/l.log
        $B/capsule record recover $TMP/runs/*.mcap > /dev/null; echo "recover rc=$?""#,
    );
    run.assert_stdout(&["RECORDER DIED", "control goes on"]);
    // the plant ran to its end, commanded
    let j = commanded(&run);
    assert_eq!(json_number(j, "stamp_ns"), Some(4e9), "{j}");
    // the run is still reported as failed: the recording is incomplete, and recoverable
    run.assert_stdout(&["launcher rc=1", "recover rc=0"]);
}

#[test]
fn out_of_range_requests_are_refused_with_a_reason() {
    let run = controlled(
        60,
        r#"
        $B/capsule_ros set-mode forward --at-s 1e308; echo "at-s rc=$?"
        $B/capsule_ros set-mode 200; echo "mode rc=$?"
        $B/capsule_controller --scene "$SCENE" --alpha 1e308 --check; echo "alpha rc=$?"
        stop $C"#,
    );
    run.assert_stdout(&[
        "at-s rc=2",
        "accepted=false mode=FORWARD",
        "mode rc=3",
        "alpha rc=2",
    ]);
    // --alpha refused by the flag's range (clap names it) before the force-limit check
    run.assert_stderr(&["--at-s 1e308: must be finite", "'1e308' for '--alpha"]);
}
