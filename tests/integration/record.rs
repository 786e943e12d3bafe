//! Recordings (issue 4): files from `capsule_record` read by the reference ROS 2 MCAP readers
//! (`mcap` + `mcap-ros2-support`, `rosbags`: run .ci/record-setup.sh), and `capsule record
//! info|recover` on good and bad files (needs `cargo build -p capsule_cli` first).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use capsule_msgs::{ActuatorForce, CapsuleState, Header, SetModeRequest, SetModeResponse, Time};
use capsule_record::{
    cdr,
    types::{names, topics, Clock, OfferedQos, ServiceEventInfo, SetModeEvent},
    RecordWriter, SceneRecord, WriterOptions,
};
use serde_json::Value;

use crate::root;

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("capsule_rec_it_{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn capsule(args: &[&str]) -> Output {
    let bin = std::env::var_os("CAPSULE_BIN")
        .map(|d| PathBuf::from(d).join("capsule"))
        .unwrap_or_else(|| root().join("target/debug/capsule"));
    assert!(
        bin.exists(),
        "{} missing: run `cargo build -p capsule_cli` first",
        bin.display()
    );
    Command::new(bin)
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run capsule: {e}"))
}

/// Decodes with the reference readers (their own ROS 2 decoders) and returns their JSON.
pub fn python_decode(path: &Path, reader: &str) -> Value {
    let script = root().join("tests/peers/mcap_decode.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(path)
        .args(["--reader", reader])
        .output()
        .unwrap_or_else(|e| panic!("python3: {e} (run .ci/record-setup.sh)"));
    assert!(
        out.status.success(),
        "mcap_decode.py failed (run .ci/record-setup.sh): {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON: {e}"))
}

fn state(i: u64) -> CapsuleState {
    CapsuleState {
        header: Header {
            stamp: Time::from_nanos(i as i64 * 1_000_000 + 7),
            frame_id: "odom".into(),
        },
        seq: i,
        mass_position: (i as f64 * 0.37).sin() * 1e-3,
        capsule_velocity: -(i as f64) * 1.25e-4,
        stuck: i.is_multiple_of(3),
        ..CapsuleState::default()
    }
}

fn event(kind: u8, seq: i64, mode: u8, gain: f64, accepted: Option<bool>) -> SetModeEvent {
    SetModeEvent {
        info: ServiceEventInfo {
            event_type: kind,
            stamp: Time::from_nanos(5),
            client_gid: [9; 16],
            sequence_number: seq,
        },
        request: vec![SetModeRequest {
            mode,
            gain,
            effective_from: Time::ZERO,
        }],
        response: accepted
            .map(|a| SetModeResponse {
                accepted: a,
                mode,
                gain,
                reason: "why".into(),
            })
            .into_iter()
            .collect(),
    }
}

/// A run of `n` states at 1 kHz with forces, clock, and two mode changes (one refused).
fn write_run(path: &Path, n: u64, finish: bool) {
    let go = || -> Result<(), capsule_record::RecordError> {
        let mut w = RecordWriter::create(
            path,
            WriterOptions {
                scene: Some(SceneRecord {
                    name: "it_scene".into(),
                    toml: "# test\n".into(),
                }),
                ..WriterOptions::default()
            },
        )?;
        let q = OfferedQos::reliable(10);
        let s = w.add_topic(topics::STATE, names::STATE, &q)?;
        let f = w.add_topic(topics::FORCE, names::FORCE, &q)?;
        let c = w.add_topic(topics::CLOCK, names::CLOCK, &q)?;
        let e = w.add_topic(topics::SET_MODE_EVENT, names::SET_MODE_EVENT, &q)?;
        let mut ev = 0;
        for i in 1..=n {
            let t = 1_700_000_000_000_000_000 + i * 1_000_000;
            let clock = Clock {
                clock: Time::from_nanos(i as i64 * 1_000_000),
            };
            w.write(c, i as u32, t, t, &cdr::encode(&clock)?)?;
            w.write(s, i as u32, t, t, &cdr::encode(&state(i))?)?;
            let force = ActuatorForce {
                header: state(i).header,
                state_seq: i,
                force: i as f64 * -0.01,
            };
            w.write(f, i as u32, t + 10, t + 10, &cdr::encode(&force)?)?;
            if i == n / 3 || i == 2 * n / 3 {
                let (mode, gain, ok) = if i == n / 3 {
                    (SetModeRequest::FORWARD, 0.5, true)
                } else {
                    (SetModeRequest::CUSTOM, 99.0, false)
                };
                for (kind, acc) in [
                    (ServiceEventInfo::REQUEST_RECEIVED, None),
                    (ServiceEventInfo::RESPONSE_SENT, Some(ok)),
                ] {
                    ev += 1;
                    let data = cdr::encode(&event(kind, i as i64, mode, gain, acc))?;
                    w.write(e, ev, t + 20, t + 20, &data)?;
                }
            }
        }
        if finish {
            w.finish()?;
        } else {
            w.flush()?;
            std::mem::forget(w); // a killed writer: no summary, no footer
        }
        Ok(())
    };
    go().unwrap_or_else(|e| panic!("{e}"));
}

fn bits(x: f64) -> i64 {
    x.to_bits() as i64
}

fn check_reader(v: &Value, reader: &str, n: u64) {
    let topics_v = &v[reader]["topics"];
    let st = &topics_v[topics::STATE];
    assert_eq!(st["type"], names::STATE, "{reader}");
    assert_eq!(st["count"], n, "{reader}");
    let rows = st["rows"].as_array().cloned().unwrap_or_default();
    assert_eq!(rows.len() as u64, n);
    for (k, r) in rows.iter().enumerate() {
        let want = state(k as u64 + 1);
        assert_eq!(r[0], want.seq, "{reader} state {k}");
        assert_eq!(r[1], want.header.stamp.to_nanos(), "{reader} state {k}");
        assert_eq!(
            r[2].as_i64(),
            Some(bits(want.mass_position)),
            "{reader} state {k}"
        );
        assert_eq!(
            r[3].as_i64(),
            Some(bits(want.capsule_velocity)),
            "{reader} state {k}"
        );
        assert_eq!(r[4], want.stuck, "{reader} state {k}");
    }
    let fr = topics_v[topics::FORCE]["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert_eq!(fr.len() as u64, n, "{reader}");
    for (k, r) in fr.iter().enumerate() {
        assert_eq!(r[0], k as u64 + 1);
        assert_eq!(
            r[1].as_i64(),
            Some(((k as f64 + 1.0) * -0.01).to_bits() as i64),
            "{reader} force {k}"
        );
    }
    let cl = topics_v[topics::CLOCK]["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    assert_eq!(cl.len() as u64, n);
    assert_eq!(cl[0][0], 1_000_000);
    let ev = topics_v[topics::SET_MODE_EVENT]["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default();
    let ev: Vec<String> = ev.iter().map(|r| r.to_string()).collect();
    let (a, b) = (n / 3, 2 * n / 3);
    assert_eq!(
        ev,
        [
            format!("[1,{a},1,{},null]", bits(0.5)),
            format!("[2,{a},1,{},true]", bits(0.5)),
            format!("[1,{b},4,{},null]", bits(99.0)),
            format!("[2,{b},4,{},false]", bits(99.0)),
        ],
        "{reader}"
    );
}

#[test]
fn reference_readers_decode_every_message_with_the_published_values() {
    let p = tmp("readers.mcap");
    let n = 3000;
    write_run(&p, n, true);
    let v = python_decode(&p, "both");
    check_reader(&v, "mcap", n);
    check_reader(&v, "rosbags", n);
    let m = &v["mcap"];
    assert_eq!(m["profile"], "ros2");
    assert_eq!(m["statistics_messages"], 3 * n + 4);
    assert!(m["metadata"]["rosbag2"]
        .as_array()
        .is_some_and(|k| k.iter().any(|x| x == "serialized_metadata")));
    for (topic, ch) in m["channels"].as_object().cloned().unwrap_or_default() {
        assert_eq!(ch["schema_encoding"], "ros2msg", "{topic}");
        assert_eq!(ch["message_encoding"], "cdr", "{topic}");
        assert_eq!(ch["qos"], true, "{topic}");
        assert_eq!(ch["cdr_header"].to_string(), "[0,1,0,0]", "{topic}");
        assert!(ch["schema"].as_str().is_some_and(|s| s.contains("/msg/")));
    }
}

#[test]
fn info_shows_duration_topics_rates_modes_and_scene() {
    let p = tmp("info.mcap");
    write_run(&p, 2000, true);
    let out = capsule(&["record", "info", &p.display().to_string()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(text.contains("Read from:         summary"), "{text}");
    assert!(text.contains("Scene:             it_scene"), "{text}");
    assert!(text.contains("Duration:          1.999000010 s"), "{text}");
    assert!(
        text.contains("Start:             2023-11-14 22:13:20.001000000 UTC"),
        "{text}"
    );
    assert!(
        text.contains("/capsule/state") && text.contains("count 2000 | rate 1000.5 Hz"),
        "{text}"
    );
    assert!(
        text.contains("set_mode FORWARD (gain 0.5): accepted -> FORWARD k_p 0.5: why"),
        "{text}"
    );
    assert!(
        text.contains("set_mode CUSTOM (gain 99): refused -> CUSTOM k_p 99: why"),
        "{text}"
    );
}

#[test]
fn bad_files_are_clear_errors_and_never_crash() {
    let good = tmp("good.mcap");
    write_run(&good, 1500, true);
    let bytes = std::fs::read(&good).unwrap_or_default();
    let truncated = tmp("truncated.mcap");
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap_or_else(|e| panic!("{e}"));
    let text = tmp("text.mcap");
    std::fs::write(&text, "not an mcap file at all\n").unwrap_or_else(|e| panic!("{e}"));
    let foreign = tmp("foreign.mcap");
    {
        let file = std::fs::File::create(&foreign).unwrap_or_else(|e| panic!("{e}"));
        let mut w =
            mcap::Writer::new(std::io::BufWriter::new(file)).unwrap_or_else(|e| panic!("{e}"));
        let sid = w
            .add_schema("foo.Bar", "protobuf", b"\x00")
            .unwrap_or_else(|e| panic!("{e}"));
        let cid = w
            .add_channel(sid, "/foo", "protobuf", &Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let h = mcap::records::MessageHeader {
            channel_id: cid,
            sequence: 0,
            log_time: 0,
            publish_time: 0,
        };
        w.write_to_known_channel(&h, b"")
            .unwrap_or_else(|e| panic!("{e}"));
        w.finish().unwrap_or_else(|e| panic!("{e}"));
    }
    let missing = tmp("missing.mcap");
    for (file, want) in [
        (&missing, "no such file"),
        (&text, "not an MCAP file"),
        (&truncated, "truncated MCAP file"),
        (&foreign, "is not ros2msg"),
    ] {
        let f = file.display().to_string();
        for args in [
            vec!["record", "info", f.as_str()],
            vec!["replay", "--check-controller", f.as_str()],
            vec!["replay", f.as_str()],
        ] {
            let out = capsule(&args);
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
            assert!(err.contains(want) && err.contains(&f), "{args:?}: {err}");
            assert!(!err.contains("panicked"), "{err}");
        }
    }
    for file in [&missing, &text] {
        let out = capsule(&["record", "recover", &file.display().to_string()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
}

#[test]
fn recover_completes_a_cut_file_that_rosbags_then_opens() {
    let p = tmp("cut.mcap");
    write_run(&p, 2400, false);
    let f = p.display().to_string();
    let out = capsule(&["record", "recover", &f]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // everything was flushed before the "kill": nothing lost
    assert!(
        text.contains(&format!("recovered {} messages", 3 * 2400 + 4)),
        "{text}"
    );
    let v = python_decode(&p, "rosbags");
    assert_eq!(v["rosbags"]["topics"][topics::STATE]["count"], 2400);
    let info = capsule(&["record", "info", &f]);
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.contains("profile ros2") && info.contains("Scene:             it_scene"),
        "{info}"
    );
}

// ---- recorder node runs (DDS): each inside its own loopback-only network namespace ----

/// Runs a bash script through `tests/peers/netns_run.sh` (loopback-only namespace, bounded in
/// time, processes killed and namespace deleted at the end). `$B` is the binary directory,
/// `$ROOT` the workspace, `$SCENE` the control-point scene, `$D` the test's own directory.
fn netns(timeout_s: u32, dir: &Path, script: &str) -> (Option<i32>, String) {
    let b = std::env::var_os("CAPSULE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/debug"));
    for exe in [
        "capsule_plant",
        "capsule_controller",
        "capsule_recorder",
        "capsule_ros",
    ] {
        assert!(
            b.join(exe).is_file(),
            "{} missing: run `cargo build --workspace` first",
            b.join(exe).display()
        );
    }
    let out = Command::new("bash")
        .arg(root().join("tests/peers/netns_run.sh"))
        .arg(timeout_s.to_string())
        .args(["bash", "-c", script])
        .env("B", &b)
        .env("CAPSULE_BIN", &b)
        .env("ROOT", root())
        .env("SCENE", root().join("scenes/control_point.toml"))
        .env("D", dir)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .env_remove("RMW_IMPLEMENTATION")
        .env_remove("RUST_LOG")
        .output()
        .unwrap_or_else(|e| panic!("cannot run netns_run.sh: {e}"));
    let all = format!(
        "--- stdout\n{}\n--- stderr\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.code(), all)
}

fn fresh_dir(name: &str) -> PathBuf {
    let d = tmp(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap_or_else(|e| panic!("{e}"));
    d
}

fn only_mcap(dir: &Path) -> PathBuf {
    let files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "mcap"))
        .collect();
    assert_eq!(
        files.len(),
        1,
        "one recording per run in {}: {files:?}",
        dir.display()
    );
    files[0].clone()
}

/// `got` is 0, 1, ..., n-1 in order, where a sample may repeat right after itself (the
/// lock-step plant re-sends a sample whose command is late: each copy was published, so each
/// is recorded). A short report, not two long lists, when not.
fn expect_all(got: &[u64], n: u64, what: &str) {
    let mut got = got.to_vec();
    got.dedup();
    let gap = got.iter().enumerate().find(|(k, s)| **s != *k as u64);
    assert!(
        got.len() as u64 == n && gap.is_none(),
        "{what}: {} of {n}, first {:?}, last {:?}, first mismatch {gap:?}",
        got.len(),
        got.first(),
        got.last()
    );
}

/// Messages of all topics in a decoded file.
fn v_total(v: &Value) -> u64 {
    v["rosbags"]["topics"]
        .as_object()
        .map(|t| t.values().filter_map(|x| x["count"].as_u64()).sum())
        .unwrap_or(0)
}

fn json_u64(text: &str, key: &str) -> Option<u64> {
    let pat = format!("\"{key}\":");
    let at = text.find(&pat)? + pat.len();
    let rest = &text[at..];
    let end = rest.find([',', '}']).unwrap_or(rest.len());
    rest[..end].trim().parse().ok()
}

#[test]
fn launcher_records_every_published_message_and_the_mode_changes() {
    launcher_run_is_recorded("launch_run", false);
}

#[test]
fn in_plant_recording_holds_the_same_run() {
    launcher_run_is_recorded("launch_run_in_plant", true);
}

/// A lock-step launcher run with two mode requests, recorded by the recorder node or (with
/// `in_plant`) by the plant itself: the same file either way. The switch is scheduled (at 4.5 s
/// of sim time, requested early): `--check-controller` replays a scheduled switch exactly, an
/// immediate one only to within a sample of where the recording saw the request.
fn launcher_run_is_recorded(name: &str, in_plant: bool) {
    let dir = fresh_dir(name);
    let (code, all) = netns(
        240,
        &dir,
        &format!(
            r#"
        ( sleep 1; $B/capsule_ros set-mode backward --at-s 4.5; $B/capsule_ros set-mode custom --gain 99 ) &
        $ROOT/launch_scripts/capsule_launch.sh --scene "$SCENE" --pacing lockstep --until-s 6 {} \
            --mode forward --record-dir "$D/runs" --plant-arg --summary-json --plant-arg "$D/plant.json"
        rc=$?; wait; exit $rc"#,
            if in_plant { "--record-in-plant" } else { "" }
        ),
    );
    assert_eq!(code, Some(0), "{all}");
    let file = only_mcap(&dir.join("runs"));
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    assert!(
        name.starts_with("capsule_control_point_20") && name.ends_with("Z.mcap"),
        "{name}"
    );
    let plant = std::fs::read_to_string(dir.join("plant.json")).unwrap_or_default();
    let published = json_u64(&plant, "samples").unwrap_or_else(|| panic!("{plant}\n{all}"));
    assert!(published > 5000, "{plant}");
    let v = python_decode(&file, "both");
    for reader in ["mcap", "rosbags"] {
        let t = &v[reader]["topics"];
        // every state the plant published, in order, none twice
        let seqs: Vec<u64> = t[topics::STATE]["rows"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .filter_map(|r| r[0].as_u64())
            .collect();
        expect_all(&seqs, published, &format!("{reader} states"));
        // every command the controller sent: one per state it answered, in order, none twice;
        // at least as many as its last status counted
        let forces: Vec<u64> = t[topics::FORCE]["rows"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .filter_map(|r| r[0].as_u64())
            .collect();
        assert!(
            forces.windows(2).all(|w| w[0] <= w[1]),
            "{reader}: force state_seq going back"
        );
        let sent = t["/capsule_controller/status"]["rows"]
            .as_array()
            .and_then(|r| r.last())
            .and_then(|r| r[1].as_u64())
            .unwrap_or(u64::MAX);
        // (in the plant: every command it received; lock-step steps only on an answer, so at
        // least one per state but the last)
        let enough = if in_plant {
            forces.len() as u64 + 1 >= published
        } else {
            forces.len() as u64 >= sent
        };
        assert!(
            enough && sent + 200 > published,
            "{reader}: {} forces recorded, controller's last status: {sent} sent, {published} states",
            forces.len()
        );
        assert_eq!(t[topics::CLOCK]["count"], published, "{reader}");
        assert!(t["/capsule_controller/status"]["count"].as_u64() > Some(10));
        let ev: Vec<String> = t[topics::SET_MODE_EVENT]["rows"]
            .as_array()
            .cloned()
            .unwrap_or_default()
            .iter()
            .map(|r| {
                format!(
                    "{} {} {} {}",
                    r[0],
                    r[2],
                    r[4],
                    r[1].as_i64().is_some_and(|s| s > 0)
                )
            })
            .collect();
        assert_eq!(
            ev,
            [
                "1 2 null true",
                "2 null true true",
                "1 4 null true",
                "2 null false true"
            ],
            "{reader}"
        );
    }
    let info = capsule(&["record", "info", &file.display().to_string()]);
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(info.contains("Scene:             control_point"), "{info}");
    assert!(
        info.contains("set_mode BACKWARD (gain 0): accepted -> BACKWARD k_p -0.2"),
        "{info}"
    );
    // refused, the mode unchanged: FORWARD, or BACKWARD if the run (faster without a recorder
    // process) had passed the scheduled switch at 4.5 s when the request came
    assert!(
        info.contains("set_mode CUSTOM (gain 99): refused -> FORWARD k_p 0.2")
            || info.contains("set_mode CUSTOM (gain 99): refused -> BACKWARD k_p -0.2"),
        "{info}"
    );
    // the lock-step recording re-drives the controller library to identical commands
    let f = file.display().to_string();
    let out = capsule(&["replay", "--check-controller", &f]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        // (the plant stops at its last sample and does not take that sample's answer)
        (text.contains(&format!("checked {published} recorded commands"))
            || (in_plant
                && text.contains(&format!("checked {} recorded commands", published - 1))))
            && text.contains("2 mode requests, 0 answered differently")
            && text.contains("largest |difference|: 0e0 N"),
        "{text}"
    );
    // a changed controller (another default direction gain) is caught, with the difference
    let out = capsule(&[
        "replay",
        "--check-controller",
        "--direction-gain",
        "0.25",
        &f,
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{text}{err}");
    assert!(
        err.contains("does not reproduce the recording"),
        "{text}{err}"
    );
}

#[test]
fn sigkill_mid_recording_loses_at_most_the_last_second_after_recover() {
    let dir = fresh_dir("sigkill_run");
    let (code, all) = netns(
        120,
        &dir,
        r#"
        $B/capsule_controller --scene "$SCENE" --mode forward &
        C=$!
        $B/capsule_recorder --scene "$SCENE" --output "$D/killed.mcap" &
        R=$!
        $B/capsule_plant --scene "$SCENE" --until-s 30 --wait-subscribers 2 &
        P=$!
        sleep 6
        echo "kill_ns=$(date +%s%N)"
        kill -KILL $R
        wait $R; echo "recorder rc=$?"
        kill -TERM $P $C; wait $P $C
        exit 0"#,
    );
    assert_eq!(code, Some(0), "{all}");
    assert!(all.contains("recorder rc=137"), "{all}");
    let kill_ns: u64 = all
        .lines()
        .find_map(|l| l.strip_prefix("kill_ns="))
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("{all}"));
    let file = dir.join("killed.mcap");
    let f = file.display().to_string();
    let before = capsule(&["record", "info", &f]);
    assert_eq!(before.status.code(), Some(1), "a killed file has no footer");
    let out = capsule(&["record", "recover", &f]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v = python_decode(&file, "rosbags");
    let st = &v["rosbags"]["topics"][topics::STATE];
    let seqs: Vec<u64> = st["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default()
        .iter()
        .filter_map(|r| r[0].as_u64())
        .collect();
    assert!(seqs.len() > 1000, "{} states\n{text}", seqs.len());
    // contiguous from the first sample: nothing lost before the cut
    expect_all(&seqs, seqs.len() as u64, "recovered states");
    let last_log = st["log_ns"]
        .as_array()
        .and_then(|a| a.last())
        .and_then(|x| x.as_u64())
        .unwrap_or(0);
    let lost_s = kill_ns.saturating_sub(last_log) as f64 * 1e-9;
    assert!(lost_s <= 1.0, "lost the last {lost_s:.3} s\n{text}");
    assert!(
        text.contains(&format!("recovered {} messages", v_total(&v))),
        "{text}"
    );
}

#[test]
fn a_replayed_recording_rerecords_to_the_same_messages_in_the_same_order() {
    let dir = fresh_dir("replay_run");
    let original = dir.join("original.mcap");
    write_run(&original, 1500, true);
    let (code, all) = netns(
        120,
        &dir,
        r#"
        $B/capsule_recorder --output "$D/again.mcap" --wait-publishers-s 20 &
        R=$!
        $ROOT/target/debug/capsule replay "$D/original.mcap" --wait-subscribers 1 --rate 2 || exit 1
        sleep 1
        kill -INT $R; wait $R; echo "recorder rc=$?""#,
    );
    assert_eq!(code, Some(0), "{all}");
    assert!(all.contains("recorder rc=0"), "{all}");
    let a = capsule_record::messages(&original).unwrap_or_else(|e| panic!("{e}"));
    let b = capsule_record::messages(&dir.join("again.mcap")).unwrap_or_else(|e| panic!("{e}"));
    let by_topic = |v: &[capsule_record::read::Message]| {
        let mut m: std::collections::BTreeMap<String, Vec<Vec<u8>>> = Default::default();
        for x in v {
            m.entry(x.topic.clone()).or_default().push(x.data.clone());
        }
        m
    };
    let (ta, tb) = (by_topic(&a), by_topic(&b));
    for (topic, msgs) in &ta {
        let got = tb.get(topic).map(|v| v.len()).unwrap_or(0);
        assert_eq!(
            got,
            msgs.len(),
            "{topic}: {got} of {} re-recorded",
            msgs.len()
        );
        assert!(
            tb.get(topic) == Some(msgs),
            "{topic}: bytes or order differ"
        );
    }
    // across topics: the same order, except messages the original logged within 20 ms of each
    // other (different DDS writers and readers: DDS orders samples per writer only), and those
    // few; and at the asked pace (rate 2)
    let mut index: std::collections::BTreeMap<(String, usize), usize> = Default::default();
    let mut seen: std::collections::BTreeMap<String, usize> = Default::default();
    for (k, m) in a.iter().enumerate() {
        let n = seen.entry(m.topic.clone()).or_default();
        index.insert((m.topic.clone(), *n), k);
        *n += 1;
    }
    seen.clear();
    let mut in_a = Vec::new();
    for m in &b {
        let n = seen.entry(m.topic.clone()).or_default();
        in_a.push(index[&(m.topic.clone(), *n)]);
        *n += 1;
    }
    let mut swaps = 0;
    for w in in_a.windows(2) {
        if w[0] > w[1] {
            let dt = a[w[0]].log_time - a[w[1]].log_time;
            // published close together by different writers: no order DDS keeps
            swaps += usize::from(dt >= 20_000_000);
        }
    }
    assert!(
        swaps * 100 <= in_a.len(),
        "{swaps} of {} out of order by 20 ms or more",
        in_a.len()
    );
    // pace: when the replay published each message (its DDS source timestamp, recorded as
    // publish time) against the original log time / 2
    let b0 = b.iter().map(|m| m.publish_time).min().unwrap_or(0);
    let a0 = a[0].log_time;
    let late: Vec<f64> = in_a
        .iter()
        .map(|&k| &a[k])
        .zip(b.iter())
        .map(|(orig, again)| {
            let want = (orig.log_time - a0) as f64 * 1e-9 / 2.0;
            let got = (again.publish_time - b0) as f64 * 1e-9;
            (got - want).abs()
        })
        .collect();
    // robust to a loaded machine: the median message on time, the whole run at twice the pace
    let mut sorted = late.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    assert!(
        median < 0.05,
        "pace: median {median:.3} s off the recorded pace / 2"
    );
    let span = |v: &mut dyn Iterator<Item = u64>| {
        let (lo, hi) = v.fold((u64::MAX, 0), |(l, h), t| (l.min(t), h.max(t)));
        (hi - lo) as f64 * 1e-9
    };
    let (orig, again) = (
        span(&mut a.iter().map(|m| m.log_time)),
        span(&mut b.iter().map(|m| m.publish_time)),
    );
    assert!(
        (again / (orig / 2.0) - 1.0).abs() < 0.2,
        "pace: replay took {again:.3} s for {orig:.3} s recorded at rate 2"
    );
}
