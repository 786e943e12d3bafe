//! The live view without ROS (`capsule_foxglove`): a WebSocket client that is not ours
//! (PyPI `websockets`, tests/peers/foxglove_ws_client.py) speaks Foxglove's v1 WebSocket
//! protocol (subprotocol foxglove.sdk.v1) to the bridge serving a running plant and controller,
//! subscribes, and decodes the samples, from the bridge inside the composed process
//! (`capsule_container --foxglove-port`, the launcher's default) and from `capsule_foxglove` as a
//! process of its own (`--separate`); a bind address other than loopback is refused before
//! anything starts, and a port taken ends the container, naming the bridge, before the loop
//! starts; the layout in docs/foxglove plots only fields the bridge serves. The separate graph
//! runs a Move goal meanwhile, whose feedback the client reads too.

use super::harness::{json_number, json_raw, netns, root, Run};

const STATE: &str = "/capsule/state";
const STATUS: &str = "/capsule_controller/status";
const FRAME: &str = "/capsule/frame";
const FORCE: &str = "/capsule/actuator_force";
const MOVE_FEEDBACK: &str = "/capsule_controller/move/_action/feedback";

/// The part of the client's summary about `topic` (up to the next topic's key).
fn section<'a>(summary: &'a str, topic: &str) -> &'a str {
    let key = format!("\"{topic}\":");
    let Some(at) = summary.find(&key) else {
        return "";
    };
    let rest = &summary[at + key.len()..];
    let end = [STATE, STATUS, FRAME, FORCE, MOVE_FEEDBACK]
        .iter()
        .filter_map(|t| rest.find(&format!("\"{t}\":")))
        .min()
        .unwrap_or(rest.len());
    &rest[..end]
}

/// Through the launcher (`--foxglove-port 0` and `flags`), as a user starts it: a Foxglove client
/// decodes every channel; the launcher's processes (`KIDS ...`: their names) are printed. With
/// `goal`, a Move goal of 4 mm (`capsule_ros move`) runs while the client reads, and the client
/// reads its feedback too.
fn client_decodes_the_live_graph(flags: &str, goal: bool) -> Run {
    let client = root().join("tests/peers/foxglove_ws_client.py");
    let (feedback, move_goal) = if goal {
        (
            MOVE_FEEDBACK,
            // the goal once the client listens: a loaded host can start it after a short goal ended
            "for i in $(seq 600); do grep -q subscribed $TMP/client.err && break; sleep 0.1; done
            $B/capsule_ros move 0.004 > $TMP/move.out || exit 1",
        )
    } else {
        ("", "")
    };
    let run = netns(
        150,
        &format!(
            r#"
            $ROOT/launch_scripts/capsule_launch.sh --scene "$SCENE" --mode forward --no-record \
                --foxglove-port 0 {flags} > $TMP/fox.out &
            L=$!
            for i in $(seq 300); do grep -q serving $TMP/fox.out && break; sleep 0.2; done
            URL=$(sed -n 's/^capsule_foxglove: serving //p' $TMP/fox.out)
            echo "url $URL"
            python3 {client} "$URL" --topics {STATE} {STATUS} {FRAME} {FORCE} {feedback} \
                --seconds 3 --min 5 --timeout 90 > $TMP/client.out 2> $TMP/client.err & W=$!
            {move_goal}
            wait $W; S=$?
            cat $TMP/client.err >&2
            [ $S -eq 0 ] || exit 1
            cat $TMP/client.out
            KIDS=$(pgrep -P $L)
            echo "KIDS $(for k in $KIDS; do cat /proc/$k/comm; done | sort | tr '\n' ' ')"
            stop $L || exit 1
            # the launcher stopped every node, the bridge too
            for k in $KIDS; do kill -0 $k 2>/dev/null && {{ echo "left running: $k"; exit 1; }}; done
            exit 0"#,
            client = client.display()
        ),
    );
    // with a goal, the mode is the goal's (FORWARD, or OFF between and after)
    assert_decoded(
        &run,
        if goal {
            &["FORWARD", "OFF"]
        } else {
            &["FORWARD"]
        },
    );
    if goal {
        // the goal's feedback as the live view serves it: one goal, travelling forward
        let summary = run.line("{\"server\"");
        let fb = section(summary, MOVE_FEEDBACK);
        assert_eq!(
            json_raw(fb, "schema"),
            Some("\"capsule.MoveFeedback\""),
            "{fb}"
        );
        assert!(json_number(fb, "count").unwrap_or(0.0) >= 5.0, "{fb}");
        assert!(
            json_number(fb, "travelled_m").is_some_and(|t| t > 0.0),
            "{fb}"
        );
        assert!(fb.contains("\"goal_id\": \""), "{fb}");
    }
    run
}

/// The composed bridge (the launcher's default): the container serves, no process of its own.
#[test]
fn a_foxglove_websocket_client_decodes_the_composed_live_graph() {
    let run = client_decodes_the_live_graph("", false);
    let kids = run.line("KIDS ");
    // /proc/PID/comm keeps 15 characters
    assert!(kids.contains("capsule_contain"), "{kids}");
    assert!(
        !kids.contains("capsule_foxglov"),
        "a bridge process: {kids}"
    );
    // state and force from the in-process link, not from DDS copies published for it
    run.assert_stderr(&["(from the in-process link)"]);
}

/// `--separate`: `capsule_foxglove` as a process of its own, the same channels.
#[test]
fn a_foxglove_websocket_client_decodes_the_separate_live_graph() {
    let run = client_decodes_the_live_graph("--separate", true);
    let kids = run.line("KIDS ");
    assert!(
        kids.contains("capsule_foxglov"),
        "no bridge process: {kids}"
    );
    assert!(!kids.contains("capsule_contain"), "{kids}");
    run.assert_stderr(&["(from DDS)"]);
}

/// What every live-graph run shows: each channel decoded, with its schema and the sample's
/// fields, from a plant that moved.
#[track_caller]
fn assert_decoded(run: &Run, modes: &[&str]) {
    run.assert_ok();
    // bound on loopback, port printed
    run.assert_stdout(&["url ws://127.0.0.1:"]);
    let summary = run.line("{\"server\"");
    assert!(summary.contains("\"capsule_foxglove\""), "{summary}");
    let state = section(summary, STATE);
    let status = section(summary, STATUS);
    let frame = section(summary, FRAME);
    let force = section(summary, FORCE);
    // thinned to at most 200 per second of sim time, but at least the client's minimum
    for (name, s) in [
        ("state", state),
        ("status", status),
        ("frame", frame),
        ("force", force),
    ] {
        assert!(json_number(s, "count").unwrap_or(0.0) >= 5.0, "{name}: {s}");
    }
    assert_eq!(json_raw(state, "schema"), Some("\"capsule.State\""));
    assert_eq!(
        json_raw(status, "schema"),
        Some("\"capsule.ControllerStatus\"")
    );
    assert_eq!(
        json_raw(frame, "schema"),
        Some("\"foxglove.FrameTransform\"")
    );
    // the plant was driven: sim time advanced and a force was applied; the phase-plane fields
    // are those of the sample
    let (t0, t1) = (
        json_number(state, "first_t").unwrap_or(f64::NAN),
        json_number(state, "last_t").unwrap_or(f64::NAN),
    );
    assert!(t1 > t0 && t1 - t0 >= 0.02, "{state}");
    let x1 = json_number(state, "x1").unwrap_or(f64::NAN);
    let x2 = json_number(state, "x2").unwrap_or(f64::NAN);
    let rel = json_number(state, "x1_minus_x2").unwrap_or(f64::NAN);
    assert!(
        (x1 - x2 - rel).abs() <= 1e-12 * (1.0 + rel.abs()),
        "{state}"
    );
    assert!(json_number(state, "force").is_some(), "{state}");
    let mode = json_raw(status, "mode_name").unwrap_or_default();
    assert!(modes.iter().any(|m| mode == format!("\"{m}\"")), "{status}");
    assert!(frame.contains("\"child_frame_id\": \"capsule\""), "{frame}");
    assert_eq!(json_raw(force, "schema"), Some("\"capsule.ActuatorForce\""));
    assert!(
        json_number(force, "force").is_some_and(f64::is_finite),
        "{force}"
    );
    assert!(frame.contains("\"parent_frame_id\": \"odom\""), "{frame}");
}

#[test]
fn the_foxglove_bridge_refuses_a_non_loopback_bind() {
    // in the namespace all the same: were the check gone, nothing would reach a network
    for host in ["0.0.0.0", "192.0.2.1"] {
        let run = netns(
            30,
            &format!("$B/capsule_foxglove --host {host} --port 0; echo \"rc=$?\""),
        );
        run.assert_ok();
        run.assert_stdout(&["rc=2"]);
        run.assert_stderr(&[&format!("--host \"{host}\""), "127.0.0.1 only"]);
        assert!(!run.stdout.contains("serving"), "nothing served for {host}");
    }
}

/// A port taken (by a listener of the test's own) ends the container with the bridge named and
/// exit 2 before the controller or the plant starts: no sample, no recording file, no process
/// left; the launcher, composed, stops there too.
#[test]
fn a_composed_bridge_on_a_taken_port_is_named_and_nothing_runs() {
    let run = netns(
        60,
        r#"
        python3 -c "import socket, sys, time
s = socket.socket(); s.bind(('127.0.0.1', 0)); s.listen()
print(s.getsockname()[1], flush=True); time.sleep(50)" > $TMP/port &
        H=$!
        for i in $(seq 100); do [ -s $TMP/port ] && break; sleep 0.1; done
        PORT=$(cat $TMP/port)
        echo "port $PORT"
        timeout 30 $B/capsule_container --scene "$SCENE" --mode forward --until-s 5             --record-output $TMP/run.mcap --foxglove-port $PORT; echo "container rc=$?"
        [ -e $TMP/run.mcap ] && echo "a recording was started"
        timeout 30 $ROOT/launch_scripts/capsule_launch.sh --scene "$SCENE" --mode forward --until-s 5             --record-dir $TMP/runs --foxglove-port $PORT; echo "launcher rc=$?"
        # our processes only: those of this network namespace
        NS=$(ip netns identify $$)
        for k in $(ip netns pids $NS); do
            case $(cat /proc/$k/comm 2>/dev/null) in capsule_*) echo "left running: $k";; esac
        done
        kill $H
        exit 0"#,
    );
    run.assert_ok();
    let port = run.after("port ").trim();
    assert!(port.parse::<u16>().is_ok_and(|p| p > 0), "{port}");
    run.assert_stdout(&["container rc=2", "launcher rc=1"]);
    run.assert_stderr(&[
        &format!("capsule_container: error: capsule_foxglove: cannot serve on 127.0.0.1:{port}"),
        "capsule_launch: container (plant + controller) failed (status 2)",
    ]);
    for never in ["serving", "a recording was started", "left running"] {
        assert!(!run.stdout.contains(never), "{never}:\n{}", run.all());
    }
    // the loop never started: neither node announced itself
    for node in ["node /capsule_plant", "node /capsule_controller"] {
        assert!(!run.stderr.contains(node), "{node} started:\n{}", run.all());
    }
}

#[test]
fn the_foxglove_bridge_takes_ros_names_and_refuses_parameters() {
    let run = netns(
        30,
        r#"
        $B/capsule_foxglove --check --ros-args -r __ns:=/robot1 -r __node:=viewer
        $B/capsule_foxglove --check --ros-args -p foo:=1; echo "rc=$?""#,
    );
    run.assert_ok();
    run.assert_stdout(&["capsule_foxglove: ok: node /robot1/viewer", "rc=2"]);
    run.assert_stderr(&["--ros-args -p foo:=1: capsule_foxglove has no parameter \"foo\""]);
}

/// Every `topic.field` path a panel of `value` plots.
fn plot_paths(value: &serde_json::Value, out: &mut Vec<String>) {
    match value {
        serde_json::Value::Object(m) => {
            for (k, v) in m {
                match (k.as_str(), v) {
                    ("value" | "topicPath", serde_json::Value::String(s)) => out.push(s.clone()),
                    _ => plot_paths(v, out),
                }
            }
        }
        serde_json::Value::Array(a) => a.iter().for_each(|v| plot_paths(v, out)),
        _ => {}
    }
}

#[test]
fn the_foxglove_layout_plots_fields_the_bridge_serves() {
    use capsule_tools::foxglove_bridge::{
        FORCE_SCHEMA, FRAME_SCHEMA, FRAME_TOPIC, STATE_SCHEMA, STATUS_SCHEMA,
    };
    let path = root().join("docs/foxglove/capsule_layout.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    let layout: serde_json::Value =
        serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let schema = |s: &str| -> serde_json::Value { serde_json::from_str(s).unwrap_or_default() };
    let served = [
        (STATE, schema(STATE_SCHEMA)),
        (STATUS, schema(STATUS_SCHEMA)),
        (FRAME_TOPIC, schema(FRAME_SCHEMA)),
        (FORCE, schema(FORCE_SCHEMA)),
    ];
    let mut paths = Vec::new();
    plot_paths(&layout["configById"], &mut paths);
    assert!(paths.len() >= 6, "{paths:?}");
    for p in &paths {
        let (topic, field) = p.split_once('.').unwrap_or((p.as_str(), ""));
        let Some((_, s)) = served.iter().find(|(t, _)| *t == topic) else {
            panic!("{p}: {topic} is not served");
        };
        assert!(
            field.is_empty() || s["properties"].get(field).is_some(),
            "{p}: no field {field} in {}",
            s["title"]
        );
    }
    // the paper's plots are there: x1, x2, the phase plane with its custom x axis, force,
    // progression, and a 3D panel
    let config = &layout["configById"];
    let phase = config
        .as_object()
        .and_then(|m| {
            m.values()
                .find(|c| c["xAxisPath"]["value"] == format!("{STATE}.x1_minus_x2"))
        })
        .unwrap_or_else(|| panic!("no phase-plane plot in {}", path.display()));
    assert_eq!(phase["xAxisVal"], "custom");
    assert_eq!(phase["paths"][0]["value"], format!("{STATE}.y1_minus_y2"));
    for needle in ["x1", "x2", "force"] {
        assert!(paths.contains(&format!("{STATE}.{needle}")), "{needle}");
    }
    assert!(paths.contains(&format!("{STATUS}.progression_per_period_m")));
    assert!(config
        .as_object()
        .is_some_and(|m| m.keys().any(|k| k.starts_with("3D!"))));
}
