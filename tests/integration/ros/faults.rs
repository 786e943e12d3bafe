//! Bad input and faults: refused mode requests, bad scenes and flags, a plant or controller
//! that goes away, clean shutdown on SIGTERM.

use super::harness::{assert_contains, json_number, json_raw, netns};

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
