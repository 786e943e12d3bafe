//! Bad input and faults: refused mode requests, bad scenes and flags, a plant or controller
//! that goes away, clean shutdown on SIGTERM.

use super::harness::{assert_contains, json_number, json_raw, last_sample, netns, Run};

#[test]
fn bad_mode_requests_are_refused_with_a_reason_and_change_nothing() {
    let run = netns(
        90,
        r#"
        start_controller --mode forward
        set_mode() { $B/capsule_ros set-mode "$@"; echo "rc=$?"; }
        set_mode 9
        set_mode custom --gain nan
        set_mode custom --gain inf
        set_mode custom --gain 5
        set_mode backward --gain 0.15
        set_mode 17 --gain 0.1
        stop $C; echo "controller rc=$?""#,
    );
    run.assert_ok();
    run.assert_stdout(&["controller rc=0"]);
    let answers = run.lines_starting("accepted=");
    let codes = run.lines_starting("rc=");
    // a non-finite gain is refused by capsule_ros's own range check before it is sent (the
    // controller's refusal of one is unit-tested in capsule_controller::mode)
    assert_eq!(answers.len(), 4, "{}", run.all());
    assert_eq!(
        codes,
        ["rc=3", "rc=2", "rc=2", "rc=3", "rc=0", "rc=3"],
        "{}",
        run.all()
    );
    assert_eq!(
        run.stderr.matches("must be a finite number").count(),
        2,
        "{}",
        run.all()
    );
    assert_contains(
        answers[0],
        &["accepted=false mode=FORWARD gain=0.2", "unknown mode 9"],
    );
    assert_contains(answers[1], &["mode=FORWARD", "limit"]);
    assert!(
        answers[2].starts_with("accepted=true mode=BACKWARD gain=-0.15"),
        "{}",
        answers[2]
    );
    assert_contains(answers[3], &["accepted=false mode=BACKWARD gain=-0.15"]);
}

#[test]
fn bad_scenes_and_flags_are_named_and_nothing_starts() {
    let run = netns(
        60,
        r#"
        printf '[capsule]\ngamma = -1\n' > $TMP/bad.toml
        $B/capsule_plant --scene $TMP/nope.toml; echo "rc1=$?"
        $B/capsule_plant --scene $TMP/bad.toml; echo "rc2=$?"
        $B/capsule_plant --scene "$SCENE" --rate-hz=-5; echo "rc3=$?"
        $B/capsule_controller --scene "$SCENE" --mode sideways; echo "rc4=$?"
        ROS_DOMAIN_ID=banana $B/capsule_controller --scene "$SCENE"; echo "rc5=$?"
        $ROOT/launch_scripts/capsule_launch.sh --scene $TMP/bad.toml --pacing lockstep; echo "rc6=$?"
        $B/capsule_plant --scene "$SCENE" --record-output $TMP/no/such/dir/run.mcap; echo "rc7=$?"
        $B/capsule_controller --scene "$SCENE" --cpu-affinity 1023; echo "rc8=$?"
        $B/capsule_plant --scene "$SCENE" --cpu-affinity 2-1; echo "rc9=$?""#,
    );
    let all = run.all();
    for (rc, needle) in [
        ("rc1=2", "nope.toml"),
        ("rc2=2", "bad.toml"),
        ("rc3=2", "--rate-hz"),
        ("rc4=2", "--mode"),
        ("rc5=2", "ROS_DOMAIN_ID"),
        ("rc7=2", "no/such/dir is not a directory"),
        ("rc8=2", "--cpu-affinity 1023: CPU 1023 is not available"),
        ("rc9=2", "--cpu-affinity"),
    ] {
        assert!(run.stdout.contains(rc), "{rc} expected\n{all}");
        assert!(
            run.stderr.contains(needle),
            "error should name {needle}\n{all}"
        );
    }
    assert!(
        run.stdout.contains("rc6=2"),
        "launcher must refuse the bad scene\n{all}"
    );
    // no node got as far as creating its ROS node (that logs "node /...")
    assert!(
        !run.stderr.contains("node /capsule_"),
        "a node started\n{all}"
    );
}

#[test]
fn controller_gone_means_zero_force_and_plant_gone_means_no_commands() {
    let run = netns(
        90,
        r#"
        start_controller --mode forward --state-timeout-s 0.3 2> $TMP/ctl.log
        start_plant --until-s 3 --summary-json $TMP/plant.json
        sleep 2
        stop $C
        wait $P; echo "plant rc=$?"
        cat $TMP/plant.json
        start_controller --mode forward --state-timeout-s 0.3 2> $TMP/ctl2.log
        # the plant starts once the controller reads its state (a loaded host's discovery
        # could take its whole second)
        $B/capsule_plant --scene "$SCENE" --until-s 1 --wait-subscribers 1 2>/dev/null
        sleep 1.5
        stop $C
        cat $TMP/ctl2.log"#,
    );
    run.assert_stdout(&["plant rc=0", "state stale", "stopped commanding"]);
    // the plant's summary
    let json = run.line("{");
    assert_eq!(
        json_raw(json, "command_stale"),
        Some("true"),
        "plant did not fall back: {json}"
    );
    assert_eq!(json_number(json, "actuator_force"), Some(0.0), "{json}");
    // and said so
    run.assert_stderr(&["applying zero force"]);
}

#[test]
fn launcher_forwards_sigterm_and_exits_cleanly() {
    let run = netns(
        60,
        r#"
        $ROOT/launch_scripts/capsule_launch.sh --separate --scene "$SCENE" --mode forward --record-dir "$TMP/runs" &
        L=$!
        wait_nodes_of $L 3
        KIDS=$(pgrep -P $L)
        echo "children: $(echo $KIDS | wc -w)"
        kill -TERM $L
        wait $L; echo "launcher rc=$?"
        left=0; for k in $KIDS; do kill -0 $k 2>/dev/null && left=$((left+1)); done
        echo "left=$left""#,
    );
    run.assert_stdout(&["launcher rc=0", "left=0"]);
    // both nodes got the signal and shut down by themselves
    let stops = run.stderr.matches("SIGTERM: shutting down").count();
    assert_eq!(stops, 2, "{}", run.all());
}

#[test]
fn launcher_pins_every_thread_of_every_node_to_the_cpus_asked() {
    let run = netns(
        60,
        r#"
        CPU=$(grep Cpus_allowed_list /proc/self/status | awk '{print $2}' | tr ',' '\n' | tail -1 | sed 's/.*-//')
        echo "cpu=$CPU"
        $ROOT/launch_scripts/capsule_launch.sh --separate --scene "$SCENE" --mode forward --until-s 20 \
            --record-dir "$TMP/runs" --cpu-affinity "$CPU" &
        L=$!
        wait_nodes_of $L 3
        for k in $(pgrep -P $L); do
            for t in /proc/$k/task/*; do
                echo "thread $(cat /proc/$k/comm)/$(tr ' ' _ < $t/comm) $(awk '/Cpus_allowed_list/ {print $2}' $t/status)"
            done
        done
        kill -TERM $L
        wait $L; echo "launcher rc=$?""#,
    );
    run.assert_stdout(&["launcher rc=0"]);
    let all = run.all();
    let cpu = run.after("cpu=");
    let threads: Vec<&str> = run
        .lines_starting("thread ")
        .iter()
        .map(|l| &l["thread ".len()..])
        .collect();
    for node in ["capsule_plant/", "capsule_control", "capsule_recorde"] {
        let of_node: Vec<_> = threads.iter().filter(|t| t.starts_with(node)).collect();
        // the node's own threads and DDS's (event loop, discovery)
        assert!(of_node.len() >= 3, "{node}: threads {of_node:?}\n{all}");
        for t in of_node {
            assert!(
                t.ends_with(&format!(" {cpu}")),
                "{t} not on CPU {cpu}\n{all}"
            );
        }
    }
}

#[test]
fn namespaces_remaps_and_help_work_end_to_end() {
    let run = netns(
        90,
        r#"
        for b in capsule_plant capsule_controller capsule_ros capsule_foxglove; do $B/$b --help > /dev/null || exit 1; done
        echo "help ok"
        NS="--namespace robot1 -r capsule/state:=/robot1/sim_state"
        start_controller --mode forward $NS
        $B/capsule_ros set-mode backward --service /robot1/capsule_controller/set_mode || exit 1
        $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 0.5 --wait-subscribers 1 \
            --summary-json $TMP/ns.json $NS || exit 1
        stop $C
        echo "SUMMARY $(cat $TMP/ns.json)""#,
    );
    run.assert_ok();
    run.assert_stdout(&["help ok", "accepted=true mode=BACKWARD"]);
    run.assert_stderr(&["state /robot1/sim_state <- force /robot1/capsule/actuator_force"]);
    let json = run.after("SUMMARY ");
    assert_eq!(json_number(json, "samples"), Some(501.0), "{json}");
    assert_eq!(json_number(json, "unanswered"), Some(0.0), "{json}");
}

/// [`netns`] with the network faults of tests/peers/net_faults.sh (`lossy`, `dupes`, `delayed`,
/// `partition`, `heal`, `unfault`, `wait_log`); fails with the set-up command when iptables is
/// missing.
fn with_faults(timeout_s: u32, script: &str) -> Run {
    let ok = std::process::Command::new("iptables")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(
        ok,
        "iptables needed for the network faults: run .ci/ros-setup.sh"
    );
    netns(
        timeout_s,
        &format!(". \"$ROOT/tests/peers/net_faults.sh\"\n{script}"),
    )
}

/// A summary's number, or a failure with the run's output.
#[track_caller]
fn number(run: &Run, json: &str, key: &str) -> f64 {
    json_number(json, key).unwrap_or_else(|| panic!("no {key} in {json}\n{}", run.all()))
}

#[test]
fn lockstep_under_loss_delay_reordering_duplicates_and_an_outage_ends_on_the_clean_runs_sample() {
    // separate processes; the default `--lockstep-on-silence wait`, the scene's 0.1 s command
    // timeout (which used to give a silent sample a zero-force step)
    let run = with_faults(
        300,
        r#"
        once() {
            start_controller --mode forward 2> "$TMP/$1.ctl.log"
            $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 1 --wait-subscribers 1 \
                --summary-json "$TMP/$1.json" 2> "$TMP/$1.plant.log" & P=$!
            if [ "$1" = OUTAGE ]; then
                # 0.5 s with nothing getting through, as soon as the loop runs (1,000 steps
                # can take as little as 0.3 s)
                wait_log "$TMP/$1.plant.log" "subscribers matched: starting" || exit 1
                partition; sleep 0.5; heal
            fi
            wait $P || { echo "$1 plant failed"; cat "$TMP/$1.plant.log" >&2; exit 1; }
            stop $C
            grep -h "applying zero force\|not used" "$TMP/$1.plant.log" "$TMP/$1.ctl.log" >&2
            echo "$1 $(cat $TMP/$1.json)"
        }
        once CLEAN
        lossy 0.10; dupes 0.01; delayed 1 1 0.05
        once LOSSY
        unfault; echo "NFQUEUE $(cat $TMP/nfq.json)"
        once OUTAGE"#,
    );
    run.assert_ok();
    let clean = last_sample(&run, "CLEAN");
    assert_moved_to_seq_1000(&clean, &run);
    for tag in ["LOSSY", "OUTAGE"] {
        assert_eq!(
            last_sample(&run, tag),
            clean,
            "{tag} differs\n{}",
            run.all()
        );
    }
    // the faults were there: the lossy run re-sent samples, the queue delayed packets and
    // reordered some, the outage held one sample for most of its 0.5 s
    let lossy = run.line("LOSSY");
    assert!(number(&run, lossy, "resent") >= 10.0, "{lossy}");
    let queue = run.after("NFQUEUE ");
    assert!(number(&run, queue, "packets") > 1000.0, "{queue}");
    assert!(number(&run, queue, "reordered") > 10.0, "{queue}");
    let outage = run.line("OUTAGE");
    assert!(number(&run, outage, "resent") >= 15.0, "{outage}");
    assert!(!run.stderr.contains("applying zero force"), "{}", run.all());
}

/// Panics unless `last` is seq 1000 of a capsule that moved (1 s at the scene's 1 kHz).
#[track_caller]
fn assert_moved_to_seq_1000(last: &str, run: &Run) {
    assert_eq!(json_raw(last, "seq"), Some("1000"), "{last}\n{}", run.all());
    assert_ne!(json_raw(last, "capsule_position"), Some("0.0"), "{last}");
}

#[test]
fn a_lockstep_plant_whose_controller_is_gone_ends_with_an_error_and_a_complete_recording() {
    // a controller that exits leaves the graph: seen at once when its goodbye (a dispose of its
    // writer) arrives, else after --lockstep-give-up-s; one killed stays in discovery until its
    // lease ends, and the plant gives up after --lockstep-give-up-s
    let run = with_faults(
        180,
        r#"
        once() { # TAG SIGNAL GIVE_UP_S
            start_controller --mode forward
            $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 100 --wait-subscribers 1 \
                --lockstep-give-up-s $3 --record-output "$TMP/$1.mcap" 2> "$TMP/$1.log" & P=$!
            wait_log "$TMP/$1.log" "subscribers matched: starting" || exit 1
            sleep 1; t0=$(date +%s.%N)
            kill -$2 $C; wait $C
            wait $P; rc=$?
            echo "$1 plant rc=$rc after $(awk "BEGIN { print $(date +%s.%N) - $t0 }") s"
            grep "lock-step:" "$TMP/$1.log" | sed "s/^/$1 /"
            $B/capsule record info "$TMP/$1.mcap" > "$TMP/$1.info" || echo "$1 info failed"
            grep "capsule/state " "$TMP/$1.info" | sed "s/^/$1 info /"
            python3 "$ROOT/tests/peers/mcap_decode.py" "$TMP/$1.mcap" --reader mcap > "$TMP/$1.rec.json" || exit 1
            python3 - "$TMP/$1.rec.json" $1 <<'PY'
import json, sys
t = json.load(open(sys.argv[1]))["mcap"]["topics"]
seqs = [r[0] for r in t["/capsule/state"]["rows"]]
forces = sorted(set(r[0] for r in t["/capsule/actuator_force"]["rows"]))
print(sys.argv[2], "RECORDED", json.dumps({"states": len(seqs), "last": seqs[-1],
      "once_each": seqs == list(range(seqs[0], seqs[-1] + 1)),
      "answered_but_last": forces == seqs[:-1]}))
PY
        }
        once LEFT TERM 8
        once KILLED KILL 2"#,
    );
    run.assert_ok();
    for (tag, why, within_s) in [
        // usually "the controller is gone (no publisher of the force topic left ...)" within a
        // second; seen once without the goodbye (RustDDS): the give-up then
        ("LEFT", "lock-step: ", 12.0),
        ("KILLED", "lockstep_give_up_s = 2 s", 6.0),
    ] {
        let rc = run.line(&format!("{tag} plant rc="));
        assert!(!rc.contains("rc=0 "), "{rc}\n{}", run.all());
        let secs: f64 = rc
            .rsplit("after ")
            .next()
            .and_then(|s| s.trim_end_matches(" s").parse().ok())
            .unwrap_or(f64::NAN);
        assert!(secs < within_s, "{tag}: {secs} s\n{}", run.all());
        assert!(
            run.stdout
                .lines()
                .any(|l| l.starts_with(tag) && l.contains(why)),
            "{tag}: no {why:?}\n{}",
            run.all()
        );
        let rec = run.after(&format!("{tag} RECORDED "));
        assert_eq!(json_raw(rec, "once_each"), Some("true"), "{rec}");
        assert_eq!(json_raw(rec, "answered_but_last"), Some("true"), "{rec}");
        assert!(number(&run, rec, "states") > 100.0, "{rec}");
        // record info counts the samples, each once
        let info = run.line(&format!("{tag} info "));
        let states = number(&run, rec, "states") as u64;
        assert!(info.contains(&format!("count {states} ")), "{info}\n{rec}");
    }
}

#[test]
fn a_lockstep_controller_stopped_thrice_for_150_ms_ends_on_the_clean_runs_sample() {
    // SIGSTOP / SIGCONT: epoll_wait then fails with EINTR in RustDDS's threads, which ended
    // them (docs/upstream/rustdds-poll-eintr.md): the discovery thread at every stop, the event
    // loop in about a third of them, and the controller heard the plant no more
    let run = netns(
        120,
        r#"
        once() { # TAG STOPS
            RUST_LOG=info,rustdds=error "$B/capsule_controller" --scene "$SCENE" --mode forward \
                2> "$TMP/$1.ctl.log" & C=$!
            # recorded twice: in the plant, and by the recorder, which hears every answer the
            # controller sends (a stopped controller answers each re-sent sample it queued)
            "$B/capsule_recorder" --output "$TMP/$1.rec.mcap" 2> "$TMP/$1.rec.log" & R=$!
            $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 6 --wait-subscribers 2 \
                --lockstep-give-up-s 5 --summary-json "$TMP/$1.json" \
                --record-output "$TMP/$1.mcap" 2> "$TMP/$1.plant.log" & P=$!
            for i in $(seq 300); do
                grep -q "subscribers matched: starting" "$TMP/$1.plant.log" && break; sleep 0.1
            done
            for i in $(seq $2); do sleep 0.2; kill -STOP $C; sleep 0.15; kill -CONT $C; done
            wait $P; echo "$1 plant rc=$?"
            stop $R; stop $C
            grep -h "poll\|lock-step:" "$TMP/$1.ctl.log" "$TMP/$1.plant.log" | sed "s/^/$1 LOG /"
            echo "$1 $(cat $TMP/$1.json)"
            for f in "$TMP/$1.mcap" "$TMP/$1.rec.mcap"; do
                "$B/capsule" record info "$f" | grep -o "/capsule/[a-z_]* .*| count [0-9]*" \
                    | awk -v t="$1" '{ print t, "COUNT", $1, $NF }'
            done
        }
        once CLEAN 0
        once STOPPED 3"#,
    );
    run.assert_ok();
    run.assert_stdout(&["CLEAN plant rc=0", "STOPPED plant rc=0"]);
    // no RustDDS thread gave up on its poll
    assert!(
        run.lines_starting("STOPPED LOG ").is_empty(),
        "{}",
        run.all()
    );
    let clean = last_sample(&run, "CLEAN {");
    assert_eq!(
        json_raw(&clean, "seq"),
        Some("6000"),
        "{clean}\n{}",
        run.all()
    );
    assert_eq!(last_sample(&run, "STOPPED {"), clean, "{}", run.all());
    // the stops fell in the loop: each held a sample for 150 ms, re-sent every 20 ms
    let stopped = run.line("STOPPED {");
    assert!(number(&run, stopped, "resent") >= 10.0, "{stopped}");
    // both recordings count each sample once, re-sends and the answers to them included: 6,001
    // states, each answered (the last one perhaps not yet), in the plant and in the recorder
    let counts = run.lines_starting("STOPPED COUNT ");
    for topic in ["/capsule/state", "/capsule/actuator_force"] {
        let n: Vec<&str> = counts
            .iter()
            .filter(|l| l.split_whitespace().nth(2) == Some(topic))
            .filter_map(|l| l.split_whitespace().nth(3))
            .collect();
        assert_eq!(n.len(), 2, "{topic}: {counts:?}\n{}", run.all());
        for c in n {
            let ok = if topic == "/capsule/state" {
                c == "6001"
            } else {
                c == "6000" || c == "6001"
            };
            assert!(ok, "{topic} counted {c}: {counts:?}\n{}", run.all());
        }
    }
}

#[test]
fn real_time_keeps_moving_at_5_percent_loss_and_resumes_after_a_partition() {
    let run = with_faults(
        120,
        r#"
        lossy 0.05
        start_controller --mode forward 2> "$TMP/ctl.log"
        $B/capsule_plant --scene "$SCENE" --until-s 5 --wait-subscribers 1 \
            --summary-json "$TMP/rt.json" 2> "$TMP/rt.log" & P=$!
        wait_log "$TMP/rt.log" "subscribers matched: starting" || exit 1
        # 2 s at 5 % loss, then 1 s partitioned, then 2 s at 5 % loss again
        sleep 2; partition; echo "PARTITIONED"; sleep 1; heal
        wait $P; echo "plant rc=$?"
        stop $C
        echo "RT $(cat $TMP/rt.json)"
        grep -o "applying zero force\|command received (seq [0-9]*): applying commanded force" "$TMP/rt.log" | sed "s/^/LOG /""#,
    );
    run.assert_ok();
    run.assert_stdout(&["plant rc=0", "PARTITIONED"]);
    let rt = run.line("RT ");
    let samples = number(&run, rt, "samples");
    let unanswered = number(&run, rt, "unanswered");
    // the partition's second unanswered, and the loss around it, but most samples answered
    assert!(unanswered > 800.0 && unanswered < 0.5 * samples, "{rt}");
    // the watchdog fell back during the partition, and commands applied again after it
    let log = run.lines_starting("LOG ");
    let zero = log.iter().position(|l| l.contains("applying zero force"));
    let resumed = log
        .iter()
        .rposition(|l| l.contains("applying commanded force"));
    assert!(
        zero.is_some() && resumed > zero,
        "no fall-back and resumption: {log:?}\n{}",
        run.all()
    );
    let last = last_sample(&run, "RT ");
    assert_eq!(json_raw(&last, "command_stale"), Some("false"), "{last}");
    // moving forward: 4 of the 5 s at 5 % loss (a partition-free clean run covers CLEAN_5S_M)
    let x = json_number(&last, "capsule_position").unwrap_or(f64::NAN);
    assert!(x > 0.4 * CLEAN_5S_M, "capsule at {x} m: {last}");
}

/// Where a clean real-time FORWARD run of 5 s leaves the capsule \[m\] (docs/perf/faults.md:
/// 0.0850 m; 0.0546 m with 5 % loss and a 1 s partition).
const CLEAN_5S_M: f64 = 0.085;
