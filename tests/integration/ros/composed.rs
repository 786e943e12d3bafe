//! Plant and controller composed in one process (`capsule_container`, in-process state and
//! force): the same run as separate processes, bit for bit; every sample recorded; the DDS
//! copies and the services there for a real peer.

use serde_json::Value;

use super::harness::{
    assert_contains, assert_moved_to_seq_1500, json_raw, last_sample, netns, netns_with_peer,
};

/// The rows of `topic` (as tests/peers/mcap_decode.py gives them), the first of each key
/// (`key_col`): a lock-step plant re-sends an unanswered sample, and a re-sent one is the same.
fn first_rows(v: &Value, topic: &str, key_col: usize) -> Vec<Value> {
    let rows = v["mcap"]["topics"][topic]["rows"]
        .as_array()
        .unwrap_or_else(|| panic!("no {topic} in the recording"));
    let mut seen = std::collections::BTreeSet::new();
    rows.iter()
        .filter(|r| seen.insert(r[key_col].as_u64()))
        .cloned()
        .collect()
}

/// The states of a recording, one per seq, checked to be every seq from 0 on.
#[track_caller]
fn every_state(v: &Value) -> Vec<Value> {
    let states = first_rows(v, "/capsule/state", 0);
    for (k, s) in states.iter().enumerate() {
        assert_eq!(
            s[0].as_u64(),
            Some(k as u64),
            "seq {k} missing or out of order"
        );
    }
    states
}

#[test]
fn lockstep_composed_and_separate_give_the_same_run_bit_for_bit() {
    let script = r#"
        # separate processes: the controller, the plant recording in-process
        start_controller --mode forward
        # a step waits up to 10 s for its answer (a loaded host's stall must not step at zero force)
        $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 1.5 --wait-subscribers 1 \
            --command-timeout-s 10 --summary-json "$TMP/sep.json" --record-output "$TMP/sep.mcap" || exit 1
        stop $C || exit 1
        # composed: one process, the same nodes, state and force in-process
        $B/capsule_container --scene "$SCENE" --pacing lockstep --until-s 1.5 --mode forward \
            --summary-json "$TMP/com.json" --record-output "$TMP/com.mcap" \
            --plant-arg --command-timeout-s --plant-arg 10 || exit 1
        echo "SEP $(cat $TMP/sep.json)"
        echo "COM $(cat $TMP/com.json)"
        echo "TMP=$TMP"
        python3 "$ROOT/tests/peers/mcap_decode.py" "$TMP/sep.mcap" --reader mcap > "$TMP/sep.dec" || exit 1
        python3 "$ROOT/tests/peers/mcap_decode.py" "$TMP/com.mcap" --reader mcap > "$TMP/com.dec" || exit 1
        echo "SEPDEC $(cat $TMP/sep.dec)"
        echo "COMDEC $(cat $TMP/com.dec)""#;
    let run = netns(240, script);
    run.assert_ok();
    let (sep, com) = (last_sample(&run, "SEP "), last_sample(&run, "COM "));
    assert_moved_to_seq_1500(&sep);
    assert_eq!(sep, com, "composed and separate lock-step runs differ");
    // the whole run: every state and every command, as the two recordings hold them
    let decoded = |tag: &str| -> Value {
        serde_json::from_str(run.after(tag)).unwrap_or_else(|e| panic!("{tag}: {e}"))
    };
    let (sep, com) = (decoded("SEPDEC "), decoded("COMDEC "));
    let (sep_states, com_states) = (every_state(&sep), every_state(&com));
    assert_eq!(sep_states.len(), 1501, "separate: seq 0..=1500");
    assert!(sep_states == com_states, "the recorded states differ");
    let (sep_forces, com_forces) = (
        first_rows(&sep, "/capsule/actuator_force", 0),
        first_rows(&com, "/capsule/actuator_force", 0),
    );
    // every sample but the last is answered (the run ends at the last one)
    assert_eq!(com_forces.len(), 1500, "composed: an answer per step");
    assert!(sep_forces == com_forces, "the recorded commands differ");
}

#[test]
fn composed_recording_holds_every_sample_in_real_time() {
    let run = netns(
        120,
        r#"
        $B/capsule_container --scene "$SCENE" --pacing realtime --until-s 2 --mode forward \
            --summary-json "$TMP/com.json" --record-output "$TMP/com.mcap" || exit 1
        echo "COM $(cat $TMP/com.json)"
        python3 "$ROOT/tests/peers/mcap_decode.py" "$TMP/com.mcap" --reader mcap > "$TMP/com.dec" || exit 1
        echo "COMDEC $(cat $TMP/com.dec)""#,
    );
    run.assert_ok();
    let summary = run.after("COM ");
    let samples: u64 = json_raw(summary, "samples")
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("{summary}"));
    assert_eq!(samples, 2001, "{summary}");
    assert_eq!(json_raw(summary, "unanswered"), Some("0"), "{summary}");
    let v: Value = serde_json::from_str(run.after("COMDEC ")).unwrap_or_else(|e| panic!("{e}"));
    let states = every_state(&v);
    assert_eq!(states.len() as u64, samples, "0 missing");
    // in-process, every sample is answered before the next one: one command per step
    let forces = first_rows(&v, "/capsule/actuator_force", 0);
    assert!(
        forces.len() as u64 >= samples - 1,
        "{} commands",
        forces.len()
    );
    // the state's DDS copies: none dropped (and none sent: nobody read them)
    assert_contains(summary, &["\"dds_copies\"", "\"dropped\":0"]);
    // the controller's status too: its readers are on a participant of their own, since RustDDS
    // delivers nothing to a reader on the writer's own participant (0 before; that participant's
    // discovery takes part of this 2 s run, so only some of the 10 Hz statuses are in)
    let statuses = first_rows(&v, "/capsule_controller/status", 0);
    assert!(!statuses.is_empty(), "no status recorded");
}

#[test]
fn a_real_peer_reads_the_composed_plant_and_calls_the_composed_controller() {
    let run = netns_with_peer(
        150,
        r#"
        RMW_IMPLEMENTATION=rmw_cyclonedds_cpp $B/capsule_container --scene "$SCENE" --until-s 20 \
            --mode forward --summary-json "$TMP/com.json" &
        K=$!
        peer state --samples 200 || exit 1
        peer set-mode 2 0.1 || exit 1
        peer status --periods 3 || exit 1
        stop $K || exit 1
        echo "COM $(cat $TMP/com.json)""#,
    );
    run.assert_ok();
    super::harness::assert_state_at_1khz(&run);
    let answer = run.json_with("accepted");
    assert_contains(answer, &["\"accepted\": true", "\"mode\": 2"]);
    // the status (on DDS, from the composed controller) says BACKWARD now, and commanding
    let st = run.json_with("mode_name");
    assert_contains(st, &["\"mode_name\": \"BACKWARD\"", "\"commanding\": true"]);
    // the peer read the DDS copies: some were published, none dropped
    let summary = run.after("COM ");
    assert_contains(summary, &["\"dropped\":0"]);
    let published: u64 = summary
        .split("\"published\":")
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    assert!(published >= 200, "{summary}");
}

#[test]
fn the_container_refuses_bad_input_before_any_work() {
    let run = netns(
        60,
        r#"
        $B/capsule_container --scene "$SCENE" --pacing sideways; echo "pacing rc=$?"
        $B/capsule_container --scene "$SCENE" --controller-arg --gain --controller-arg nan; echo "gain rc=$?"
        $B/capsule_container --scene "$SCENE" --plant-arg --cpu-affinity --plant-arg 0; echo "cpu rc=$?"
        $B/capsule_container --scene "$SCENE" --controller-arg --domain-id --controller-arg 7; echo "domain rc=$?"
        $B/capsule_container --scene "$SCENE" --controller-arg --node-name --controller-arg capsule_plant; echo "name rc=$?"
        $B/capsule_container --scene "$TMP/none.toml"; echo "scene rc=$?"
        $B/capsule_container --scene "$SCENE" --record-output "$TMP/no/such/dir/run.mcap"; echo "record rc=$?"
        $B/capsule_container --scene "$SCENE" --pacing lockstep --check; echo "check rc=$?""#,
    );
    run.assert_stdout(&[
        "pacing rc=2",
        "gain rc=2",
        "cpu rc=2",
        "domain rc=2",
        "name rc=2",
        "scene rc=2",
        "record rc=2",
        "check rc=0",
        "capsule_container: ok: plant node /capsule_plant",
        "controller node /capsule_controller",
    ]);
    run.assert_stderr(&[
        "capsule_plant's arguments",
        "sideways",
        "--gain",
        "give the container's --cpu-affinity",
        "domain",
        "share one DDS participant",
        "need names of their own",
        "none.toml",
        "capsule_plant: cannot record to",
    ]);
}
