//! Recordings (issue 4): files from `capsule_record` read by the reference ROS 2 MCAP readers
//! (`mcap` + `mcap-ros2-support`, `rosbags`, and Foxglove's own TypeScript readers
//! `@mcap/core`, `@foxglove/rosmsg`, `@foxglove/rosmsg2-serialization`: run
//! .ci/record-setup.sh), and `capsule record info|recover` on good and bad files (needs
//! `cargo build -p capsule_cli` first).

use capsule_msgs::names::{default_topics, type_names};
use capsule_msgs::std_types::Clock;
use std::path::{Path, PathBuf};
use std::process::Command;

use capsule_msgs::{ActuatorForce, CapsuleState, Header, SetModeRequest, SetModeResponse, Time};
use capsule_record::{
    cdr,
    types::{ros2msg_schema, OfferedQos, ServiceEventInfo, SetModeEvent},
    ChunkCompression, RecordWriter, SceneRecord, WriterOptions,
};
use serde_json::Value;

use crate::common::{assert_holds, assert_ok, capsule, capsule_ok, line, succeeded, TempDir};
use crate::root;

/// Decodes with the reference readers (their own ROS 2 decoders) and returns their JSON.
pub fn python_decode(path: &Path, reader: &str) -> Value {
    let script = root().join("tests/peers/mcap_decode.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(path)
        .args(["--reader", reader])
        .output()
        .unwrap_or_else(|e| panic!("python3: {e} (run .ci/record-setup.sh)"));
    succeeded(&out, "mcap_decode.py (run .ci/record-setup.sh)");
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON: {e}"))
}

/// Decodes every message with Foxglove's readers (tests/peers/foxglove/decode.mjs: linearly
/// and through the summary, failing on any message that does not decode or leaves bytes
/// over); `Err(stderr)` when it fails.
pub fn foxglove_try(path: &Path) -> Result<Value, String> {
    let dir = root().join("tests/peers/foxglove");
    assert!(
        dir.join("node_modules/@mcap/core").is_dir(),
        "Foxglove readers missing: run .ci/record-setup.sh"
    );
    let out = Command::new("node")
        .arg(dir.join("decode.mjs"))
        .arg(path)
        .output()
        .unwrap_or_else(|e| panic!("node: {e} (run .ci/record-setup.sh)"));
    if !out.status.success() {
        return Err(String::from_utf8_lossy(&out.stderr).into_owned());
    }
    Ok(serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON: {e}")))
}

/// [`foxglove_try`] that must succeed.
pub fn foxglove_decode(path: &Path) -> Value {
    foxglove_try(path).unwrap_or_else(|e| panic!("Foxglove's readers refused the file: {e}"))
}

/// Foxglove's per-topic counts agree with `rosbags`' and sum to `total`.
fn foxglove_agrees(fox: &Value, rosbags: &Value, total: u64) {
    assert_eq!(fox["messages"], total, "{fox}");
    assert_eq!(fox["indexed_messages"], total, "{fox}");
    let t = rosbags["rosbags"]["topics"]
        .as_object()
        .cloned()
        .unwrap_or_default();
    assert!(!t.is_empty());
    for (topic, r) in t {
        assert_eq!(fox["topics"][&topic]["count"], r["count"], "{topic}: {fox}");
    }
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
            ..SetModeRequest::default()
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

/// A writer of a recording at `path` that holds the scene `name` (text `toml`).
pub(crate) fn scene_writer(
    path: &Path,
    name: &str,
    toml: String,
    options: &WriterOptions,
) -> Result<RecordWriter, capsule_record::RecordError> {
    RecordWriter::create(
        path,
        WriterOptions {
            scene: Some(SceneRecord {
                name: name.into(),
                toml,
            }),
            ..options.clone()
        },
    )
}

/// A run of `n` states at 1 kHz with forces, clock, and two mode changes (one refused).
fn write_run(path: &Path, n: u64, finish: bool) {
    write_run_with(path, n, finish, &WriterOptions::default(), false);
}

/// The schema text capsule wrote before 2026-11-23: `MSG: pkg/msg/Type` blocks.
fn old_spelling(text: &str) -> String {
    let mut s = text.to_string();
    for (now, old) in [
        ("MSG: std_msgs/Header", "MSG: std_msgs/msg/Header"),
        (
            "MSG: builtin_interfaces/Time",
            "MSG: builtin_interfaces/msg/Time",
        ),
        ("MSG: service_msgs/", "MSG: service_msgs/msg/"),
        ("MSG: capsule_msgs/", "MSG: capsule_msgs/msg/"),
    ] {
        s = s.replace(now, old);
    }
    s
}

/// [`write_run`] with writer options (scene added), and with `old_schemas` the schema texts
/// as capsule wrote them before they were spelled as rosbag2 spells them.
fn write_run_with(path: &Path, n: u64, finish: bool, options: &WriterOptions, old_schemas: bool) {
    let go = || -> Result<(), capsule_record::RecordError> {
        let mut w = scene_writer(path, "it_scene", "# test\n".into(), options)?;
        let q = OfferedQos::reliable(10);
        let mut add = |topic: &str, ty: &str| {
            if old_schemas {
                let text = old_spelling(&ros2msg_schema(ty).unwrap_or_default());
                let mut meta = std::collections::BTreeMap::new();
                meta.insert("offered_qos_profiles".to_string(), q.to_yaml());
                w.add_channel(topic, ty, text.as_bytes(), meta)
            } else {
                w.add_topic(topic, ty, &q)
            }
        };
        let s = add(default_topics::STATE, type_names::STATE)?;
        let f = add(default_topics::FORCE, type_names::FORCE)?;
        let c = add(default_topics::CLOCK, type_names::CLOCK)?;
        let e = add(default_topics::SET_MODE_EVENT, type_names::SET_MODE_EVENT)?;
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

/// The rows a reader decoded of `topic` (`topics`: the reader's `topics` object).
fn rows(topics: &Value, topic: &str) -> Vec<Value> {
    topics[topic]["rows"]
        .as_array()
        .cloned()
        .unwrap_or_default()
}

/// The first column of each row of `topic`, as integers (the sequence numbers).
fn first_column(topics: &Value, topic: &str) -> Vec<u64> {
    rows(topics, topic)
        .iter()
        .filter_map(|r| r[0].as_u64())
        .collect()
}

fn check_reader(v: &Value, reader: &str, n: u64) {
    let topics_v = &v[reader]["topics"];
    let st = &topics_v[default_topics::STATE];
    assert_eq!(st["type"], type_names::STATE, "{reader}");
    assert_eq!(st["count"], n, "{reader}");
    let states = rows(topics_v, default_topics::STATE);
    assert_eq!(states.len() as u64, n);
    for (k, r) in states.iter().enumerate() {
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
    let fr = rows(topics_v, default_topics::FORCE);
    assert_eq!(fr.len() as u64, n, "{reader}");
    for (k, r) in fr.iter().enumerate() {
        assert_eq!(r[0], k as u64 + 1);
        assert_eq!(
            r[1].as_i64(),
            Some(((k as f64 + 1.0) * -0.01).to_bits() as i64),
            "{reader} force {k}"
        );
    }
    let cl = rows(topics_v, default_topics::CLOCK);
    assert_eq!(cl.len() as u64, n);
    assert_eq!(cl[0][0], 1_000_000);
    let ev: Vec<String> = rows(topics_v, default_topics::SET_MODE_EVENT)
        .iter()
        .map(|r| r.to_string())
        .collect();
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
    let tmp = TempDir::new("record_readers");
    let p = tmp.file("readers.mcap");
    let n = 3000;
    write_run(&p, n, true);
    let v = python_decode(&p, "both");
    check_reader(&v, "mcap", n);
    check_reader(&v, "rosbags", n);
    let fox = foxglove_decode(&p);
    foxglove_agrees(&fox, &v, 3 * n + 4);
    let st = &fox["topics"][default_topics::STATE];
    assert_eq!(st["schema"], type_names::STATE);
    assert_eq!(st["first"]["seq"], "1");
    assert_eq!(st["last"]["seq"], n.to_string());
    assert_eq!(
        st["last"]["mass_position"].as_f64().map(f64::to_bits),
        Some(state(n).mass_position.to_bits())
    );
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
    let tmp = TempDir::new("record_info");
    let p = tmp.file("info.mcap");
    write_run(&p, 2000, true);
    let text = capsule_ok(&["record", "info", &p.display().to_string()]);
    assert_holds(
        &text,
        &[
            "Read from:         summary",
            "Scene:             it_scene",
            "Duration:          1.999000010 s",
            "Start:             2023-11-14 22:13:20.001000000 UTC",
        ],
    );
    assert!(
        text.contains("/capsule/state") && text.contains("count 2000 | rate 1000.5 Hz"),
        "{text}"
    );
    assert_holds(
        &text,
        &[
            "set_mode FORWARD (gain 0.5): accepted -> FORWARD k_p 0.5: why",
            "set_mode CUSTOM (gain 99): refused -> CUSTOM k_p 99: why",
        ],
    );
}

#[test]
fn bad_files_are_clear_errors_and_never_crash() {
    let tmp = TempDir::new("record_bad_files");
    let good = tmp.file("good.mcap");
    write_run(&good, 1500, true);
    let bytes = std::fs::read(&good).unwrap_or_default();
    let truncated = tmp.file("truncated.mcap");
    std::fs::write(&truncated, &bytes[..bytes.len() * 2 / 3]).unwrap_or_else(|e| panic!("{e}"));
    let text = tmp.file("text.mcap");
    std::fs::write(&text, "not an mcap file at all\n").unwrap_or_else(|e| panic!("{e}"));
    let foreign = tmp.file("foreign.mcap");
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
    let missing = tmp.file("missing.mcap");
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

/// `DIR/x.mcap` -> `DIR/x.recovered.mcap`, where `capsule record recover` writes by default.
fn recovered(p: &Path) -> PathBuf {
    let stem = p.file_stem().unwrap_or_default().to_string_lossy();
    p.with_file_name(format!("{stem}.recovered.mcap"))
}

#[test]
fn recover_completes_a_cut_file_that_rosbags_then_opens() {
    let tmp = TempDir::new("record_recover_cut");
    let p = tmp.file("cut.mcap");
    write_run(&p, 2400, false);
    let f = p.display().to_string();
    let before = std::fs::read(&p).unwrap_or_default();
    let text = capsule_ok(&["record", "recover", &f]);
    // everything was flushed before the "kill": nothing lost; a new file, the input untouched
    assert_holds(&text, &[&format!("recovered {} messages", 3 * 2400 + 4)]);
    assert_eq!(std::fs::read(&p).unwrap_or_default(), before);
    let fixed = recovered(&p);
    let v = python_decode(&fixed, "rosbags");
    assert_eq!(v["rosbags"]["topics"][default_topics::STATE]["count"], 2400);
    foxglove_agrees(&foxglove_decode(&fixed), &v, 3 * 2400 + 4);
    let info = capsule(&["record", "info", &fixed.display().to_string()]);
    let info = String::from_utf8_lossy(&info.stdout);
    assert!(
        info.contains("profile ros2") && info.contains("Scene:             it_scene"),
        "{info}"
    );
    // a second run does not overwrite the first one's output
    let again = capsule(&["record", "recover", &f]);
    let err = String::from_utf8_lossy(&again.stderr);
    assert_eq!(again.status.code(), Some(1), "{err}");
    assert_holds(&err, &["exists: not overwriting"]);
    // --in-place replaces the input, explicitly
    let inplace = capsule(&["record", "recover", "--in-place", &f]);
    assert!(inplace.status.success());
    assert_eq!(
        capsule_record::info(&p).map(|i| i.messages).ok(),
        Some(3 * 2400 + 4)
    );
}

#[test]
fn recover_and_info_on_compressed_and_damaged_files() {
    let tmp = TempDir::new("record_recover_damaged");
    for kind in ["zstd_fast", "lz4"] {
        let p = tmp.file(&format!("cli_{kind}.mcap"));
        let options = WriterOptions {
            compression: kind.parse().unwrap_or_default(),
            ..WriterOptions::default()
        };
        write_run_with(&p, 3000, true, &options, false);
        let f = p.display().to_string();
        let total = 3 * 3000 + 4;
        // a compressed file is not damage
        let text = capsule_ok(&["record", "info", &f]);
        assert_holds(&text, &[&format!("Messages:          {total}")]);
        let v = python_decode(&p, "rosbags");
        check_reader(&v, "rosbags", 3000);
        foxglove_agrees(&foxglove_decode(&p), &v, total);
        // recovering a valid compressed file keeps every message, compressed as it was
        let text = capsule_ok(&["record", "recover", &f]);
        assert_holds(
            &text,
            &[
                &format!("recovered {total} messages"),
                "the input was complete and intact",
            ],
        );
        let size = |p: &Path| std::fs::metadata(p).map(|m| m.len()).unwrap_or(0);
        let ratio = size(&recovered(&p)) as f64 / size(&p) as f64;
        assert!((0.7..1.4).contains(&ratio), "{kind}: size ratio {ratio}");
        // one flipped byte in a middle chunk: that chunk alone is lost
        let bytes = std::fs::read(&p).unwrap_or_default();
        let summary = mcap::read::Summary::read(&bytes)
            .ok()
            .flatten()
            .unwrap_or_else(|| panic!("no summary"));
        let chunks = &summary.chunk_indexes;
        assert!(chunks.len() >= 5, "{} chunks", chunks.len());
        let c = &chunks[chunks.len() / 2];
        let lost: u64 = c.message_index_offsets.len() as u64; // channels in it (> 0)
        assert!(lost > 0);
        let mut bad = bytes.clone();
        bad[(c.chunk_start_offset + c.chunk_length * 3 / 4) as usize] ^= 0x01;
        let b = tmp.file(&format!("cli_{kind}_flipped.mcap"));
        std::fs::write(&b, &bad).unwrap_or_else(|e| panic!("{e}"));
        let text = capsule_ok(&["record", "recover", &b.display().to_string()]);
        assert_holds(&text, &["damaged: skipped the chunk at offset"]);
        let kept = capsule_record::info(&recovered(&b))
            .map(|i| i.messages)
            .unwrap_or(0);
        // chunks hold 0.5 s: about 1500 messages; every other chunk is kept
        assert!(
            kept < total && kept + 2000 > total,
            "{kind}: kept {kept} of {total}\n{text}"
        );
        assert_eq!(
            python_decode(&recovered(&b), "rosbags")["rosbags"]["topics"][default_topics::STATE]
                ["count"]
                .as_u64()
                .map(|n| n < 3000),
            Some(true)
        );
    }
}

#[test]
fn recover_rewrites_old_schema_spelling_so_foxglove_reads_the_file() {
    let tmp = TempDir::new("record_old_spelling");
    let old = tmp.file("old_spelling.mcap");
    let n = 600;
    write_run_with(&old, n, true, &WriterOptions::default(), true);
    // the old files: Foxglove's readers refuse them (the Python readers do not notice)
    let err = foxglove_try(&old).err().unwrap_or_default();
    assert_holds(
        &err,
        &["Expected 1 top level type definition for 'std_msgs/Header' but found 0"],
    );
    let fixed = tmp.file("old_spelling_fixed.mcap");
    let text = capsule_ok(&[
        "record",
        "recover",
        &old.display().to_string(),
        "-o",
        &fixed.display().to_string(),
    ]);
    for t in [
        type_names::STATE,
        type_names::FORCE,
        type_names::CLOCK,
        type_names::SET_MODE_EVENT,
    ] {
        assert!(
            text.contains(&format!("schema {t}: dependency blocks renamed")),
            "{t}: {text}"
        );
    }
    let v = python_decode(&fixed, "both");
    check_reader(&v, "rosbags", n);
    foxglove_agrees(&foxglove_decode(&fixed), &v, 3 * n + 4);
    // the schema texts are now exactly what the writer writes
    let scan = capsule_record::scan::scan(&std::fs::read(&fixed).unwrap_or_default())
        .unwrap_or_else(|e| panic!("{e}"));
    for s in scan.schemas.values() {
        assert_eq!(
            String::from_utf8_lossy(&s.data),
            ros2msg_schema(&s.name).unwrap_or_default()
        );
    }
}

/// `capsule simulate --record` of 4 periods (2 of transient) of the Fig 15 scene, with
/// `samples` samples a period and `extra` arguments; must succeed.
fn simulate_record(path: &Path, samples: u32, extra: &[&str]) {
    let args = line(
        "simulate --scene scenes/fig15_forward.toml --periods 4 --transient 2",
        &[],
    );
    let samples = samples.to_string();
    let record = path.display().to_string();
    assert_ok(&capsule(
        &[
            &args[..],
            &["--samples-per-period", &samples, "--record", &record],
            extra,
        ]
        .concat(),
    ));
}

#[test]
fn simulate_record_is_read_by_foxglove() {
    let tmp = TempDir::new("record_simulate");
    let p = tmp.file("simulate.mcap");
    simulate_record(&p, 50, &[]);
    let v = python_decode(&p, "rosbags");
    let fox = foxglove_decode(&p);
    foxglove_agrees(&fox, &v, 2 * (1 + 4 * 50));
    assert_eq!(fox["topics"][default_topics::STATE]["count"], 1 + 4 * 50);
    assert_eq!(fox["topics"][default_topics::STATE]["first"]["seq"], "0");
}

#[test]
fn simulate_record_split_and_compressed_is_a_rosbag2_bag() {
    let tmp = TempDir::new("record_simulate_split");
    let p = tmp.file("split_sim.mcap");
    let dir = p.with_extension("");
    simulate_record(
        &p,
        100,
        &line("--compression zstd_fast --max-bag-size 40000", &[]),
    );
    let total = 2 * (1 + 4 * 100);
    // rosbags opens the directory through its metadata.yaml (rosbag2's reader path)
    let v = python_decode(&dir, "rosbags");
    assert_eq!(v_total(&v), total, "{v}");
    assert_eq!(
        v["rosbags"]["topics"][default_topics::STATE]["count"],
        1 + 4 * 100
    );
    let files = capsule_record::bag::bag_files(&dir).unwrap_or_else(|e| panic!("{e}"));
    assert!(files.len() >= 3, "{files:?}");
    let mut sum = 0;
    for f in &files {
        let fox = foxglove_decode(f);
        sum += fox["messages"].as_u64().unwrap_or(0);
    }
    assert_eq!(sum, total);
    for arg in [dir.clone(), dir.join("metadata.yaml")] {
        let text = capsule_ok(&["record", "info", &arg.display().to_string()]);
        assert_holds(
            &text,
            &[
                &format!("Messages:          {total}"),
                &format!("Files:             {}", files.len()),
            ],
        );
    }
    // recovery works per file
    let one = &files[1];
    let out = capsule(&["record", "recover", &one.display().to_string()]);
    assert!(out.status.success());
    assert_eq!(
        capsule_record::info(&recovered(one))
            .map(|i| i.messages)
            .ok(),
        capsule_record::info(one).map(|i| i.messages).ok()
    );
    // bad storage flags are refused before any work
    for bad in [
        ["--compression", "brotli"],
        ["--max-bag-duration", "nan"],
        ["--max-bag-size", "0"],
    ] {
        let out = capsule(
            &[
                &["simulate", "--periods", "4", "--transient", "2", "--record"][..],
                &[tmp.file("never.mcap").display().to_string().as_str()],
                &bad,
            ]
            .concat(),
        );
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !out.status.success() && !err.contains("panicked"),
            "{bad:?}: {err}"
        );
        assert!(!tmp.file("never.mcap").exists());
    }
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

/// What `reader` decodes of a recorded launcher run (its topics `t`): every state the plant
/// published, the controller's commands and statuses, /clock, /diagnostics, the mode requests'
/// service events.
fn the_readers_see_the_whole_run(
    t: &serde_json::Value,
    reader: &str,
    published: u64,
    in_plant: bool,
) {
    // every state the plant published, in order, none twice
    let seqs = first_column(t, default_topics::STATE);
    expect_all(&seqs, published, &format!("{reader} states"));
    // every command the controller sent: one per state it answered, in order, none twice;
    // at least as many as its last status counted
    let forces = first_column(t, default_topics::FORCE);
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
    assert_eq!(t[default_topics::CLOCK]["count"], published, "{reader}");
    assert!(t["/capsule_controller/status"]["count"].as_u64() > Some(10));
    // the plant's /diagnostics (1 Hz; and the controller's through the recorder)
    let diag = rows(t, "/diagnostics");
    assert!(
        !diag.is_empty() && diag.iter().all(|r| r[0].as_u64().is_some_and(|l| l <= 3)),
        "{reader}: /diagnostics {diag:?}"
    );
    let ev: Vec<String> = rows(t, default_topics::SET_MODE_EVENT)
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

/// A lock-step launcher run with two mode requests, recorded by the recorder node or (with
/// `in_plant`) by the plant itself, composed with the controller: the same file either way. The switch is scheduled (at 4.5 s
/// of sim time): `--check-controller` replays a scheduled switch exactly, an immediate one only
/// to within a sample of where the recording saw the request. So the requests are made while
/// the managed plant waits unconfigured, and it is activated after them: a lock-step run is
/// fast enough to pass 4.5 s of sim time before a request made during it arrives.
fn launcher_run_is_recorded(name: &str, in_plant: bool) {
    let dir = TempDir::new(&format!("record_{name}"));
    let (code, all) = netns(
        240,
        &dir,
        &format!(
            r#"
        ( sleep 1; $B/capsule_ros set-mode backward --at-s 4.5; $B/capsule_ros set-mode custom --gain 99
          $B/capsule_ros lifecycle-set /capsule_plant configure && $B/capsule_ros lifecycle-set /capsule_plant activate ) &
        $ROOT/launch_scripts/capsule_launch.sh --scene "$SCENE" --pacing lockstep --until-s 6 {} \
            --mode forward --record-dir "$D/runs" --plant-arg --summary-json --plant-arg "$D/plant.json" \
            --managed
        rc=$?; wait; exit $rc"#,
            // in the plant: composed (the launcher's default), which records in-process
            if in_plant { "" } else { "--separate" }
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
    // Foxglove's own readers decode every message of the live graph's file, /diagnostics too
    let total: u64 = v["rosbags"]["topics"]
        .as_object()
        .map(|t| t.values().filter_map(|x| x["count"].as_u64()).sum())
        .unwrap_or(0);
    let fox = foxglove_decode(&file);
    foxglove_agrees(&fox, &v, total);
    assert!(
        fox["topics"]["/diagnostics"]["count"].as_u64() > Some(0),
        "{fox}"
    );
    for reader in ["mcap", "rosbags"] {
        the_readers_see_the_whole_run(&v[reader]["topics"], reader, published, in_plant);
    }
    // Foxglove's own readers decode every message of the run, none with bytes left over
    foxglove_agrees(&foxglove_decode(&file), &v, v_total(&v));
    let info = capsule(&["record", "info", &file.display().to_string()]);
    let info = String::from_utf8_lossy(&info.stdout);
    assert_holds(
        &info,
        &[
            "Scene:             control_point",
            "set_mode BACKWARD (default gain): accepted -> BACKWARD k_p -0.2",
        ],
    );
    // refused, the mode unchanged: FORWARD (the run had not started, BACKWARD is only scheduled)
    assert!(
        info.contains("set_mode CUSTOM (gain 99): refused -> FORWARD k_p 0.2"),
        "{info}"
    );
    the_recording_re_drives_the_controller(&file, published, in_plant);
}

/// The lock-step recording `file` re-drives the controller library to identical commands, and
/// a changed controller (another default direction gain) is caught.
fn the_recording_re_drives_the_controller(file: &Path, published: u64, in_plant: bool) {
    // the lock-step recording re-drives the controller library to identical commands
    let f = file.display().to_string();
    let text = capsule_ok(&["replay", "--check-controller", &f]);
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
    let dir = TempDir::new("record_sigkill_run");
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
    assert_holds(&all, &["recorder rc=137"]);
    let kill_ns: u64 = all
        .lines()
        .find_map(|l| l.strip_prefix("kill_ns="))
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or_else(|| panic!("{all}"));
    let file = dir.join("killed.mcap");
    let f = file.display().to_string();
    let before = capsule(&["record", "info", &f]);
    assert_eq!(before.status.code(), Some(1), "a killed file has no footer");
    let text = capsule_ok(&["record", "recover", &f]);
    let file = recovered(&file);
    let v = python_decode(&file, "rosbags");
    foxglove_agrees(&foxglove_decode(&file), &v, v_total(&v));
    let st = &v["rosbags"]["topics"][default_topics::STATE];
    let seqs = first_column(&v["rosbags"]["topics"], default_topics::STATE);
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
    assert_holds(&text, &[&format!("recovered {} messages", v_total(&v))]);
}

#[test]
fn a_replayed_recording_rerecords_to_the_same_messages_in_the_same_order() {
    let dir = TempDir::new("record_replay_run");
    let original = dir.join("original.mcap");
    write_run(&original, 1500, true);
    let (code, all) = netns(
        120,
        &dir,
        r#"
        $B/capsule_recorder --output "$D/again.mcap" --wait-publishers-s 20 &
        R=$!
        $B/capsule replay "$D/original.mcap" --wait-subscribers 1 --rate 2 || exit 1
        sleep 1
        kill -INT $R; wait $R; echo "recorder rc=$?""#,
    );
    assert_eq!(code, Some(0), "{all}");
    assert_holds(&all, &["recorder rc=0"]);
    let a = capsule_record::messages(&original).unwrap_or_else(|e| panic!("{e}"));
    let b = capsule_record::messages(&dir.join("again.mcap")).unwrap_or_else(|e| panic!("{e}"));
    let by_topic = |v: &[capsule_record::messages::Message]| {
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
    let in_a = same_order_across_topics(&a, &b);
    at_the_asked_pace(&a, &b, &in_a);
}

/// Across topics, `b` (re-recorded) holds `a`'s messages in the same order, except messages the
/// original logged within 20 ms of each other (different DDS writers and readers: DDS orders
/// samples per writer only), and those few. Returns, for each message of `b`, its index in `a`.
fn same_order_across_topics(
    a: &[capsule_record::messages::Message],
    b: &[capsule_record::messages::Message],
) -> Vec<usize> {
    let mut index: std::collections::BTreeMap<(String, usize), usize> = Default::default();
    let mut seen: std::collections::BTreeMap<String, usize> = Default::default();
    for (k, m) in a.iter().enumerate() {
        let n = seen.entry(m.topic.clone()).or_default();
        index.insert((m.topic.clone(), *n), k);
        *n += 1;
    }
    seen.clear();
    let mut in_a = Vec::new();
    for m in b {
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
    in_a
}

/// The replay published at the asked pace (rate 2).
fn at_the_asked_pace(
    a: &[capsule_record::messages::Message],
    b: &[capsule_record::messages::Message],
    in_a: &[usize],
) {
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

// ---- property tests of the MCAP reading paths (issue 15 point 4): damaged real recordings ----

mod fuzz {
    use super::*;
    use proptest::prelude::*;
    use std::sync::OnceLock;

    /// How a recording is damaged.
    #[derive(Debug, Clone)]
    enum Damage {
        /// XOR these bytes at these fractions of the file.
        Flips(Vec<(f64, u8)>),
        /// Keep this fraction of the file.
        Truncate(f64),
        /// Insert this garbage at this fraction.
        Insert(f64, Vec<u8>),
        /// Overwrite 8 bytes at this fraction with a huge little-endian length.
        HugeLength(f64, u64),
    }

    fn damage() -> impl Strategy<Value = Damage> {
        prop_oneof![
            prop::collection::vec((0.0..1.0f64, 1..=255u8), 1..6).prop_map(Damage::Flips),
            (0.0..1.0f64).prop_map(Damage::Truncate),
            (0.0..1.0f64, prop::collection::vec(any::<u8>(), 1..64))
                .prop_map(|(a, g)| Damage::Insert(a, g)),
            (
                0.0..1.0f64,
                prop_oneof![Just(u64::MAX), Just(1u64 << 40), 1u64 << 20..1u64 << 34]
            )
                .prop_map(|(a, n)| Damage::HugeLength(a, n)),
        ]
    }

    fn apply(bytes: &[u8], d: &Damage) -> Vec<u8> {
        let at = |f: f64, len: usize| ((len as f64 * f) as usize).min(len.saturating_sub(1));
        let mut b = bytes.to_vec();
        match d {
            Damage::Flips(f) => {
                for (x, bits) in f {
                    let i = at(*x, b.len());
                    b[i] ^= bits;
                }
            }
            Damage::Truncate(f) => b.truncate(at(*f, bytes.len())),
            Damage::Insert(f, g) => {
                let i = at(*f, b.len());
                b.splice(i..i, g.iter().copied());
            }
            Damage::HugeLength(f, n) => {
                let i = at(*f, b.len().saturating_sub(8));
                b[i..i + 8].copy_from_slice(&n.to_le_bytes());
            }
        }
        b
    }

    /// Two small real recordings (uncompressed and zstd), written once.
    fn originals() -> &'static [Vec<u8>; 2] {
        static FILES: OnceLock<[Vec<u8>; 2]> = OnceLock::new();
        FILES.get_or_init(|| {
            let tmp = TempDir::new("record_fuzz_originals");
            [ChunkCompression::None, ChunkCompression::ZSTD_FAST].map(|c| {
                let p = tmp.file(&format!("fuzz_orig_{}.mcap", c.chunk_name()));
                let options = WriterOptions {
                    compression: c,
                    flush_interval_ns: 100_000_000,
                    ..WriterOptions::default()
                };
                write_run_with(&p, 600, true, &options, false);
                std::fs::read(&p).unwrap_or_default()
            })
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

        /// `record info`, `recover` and replay's reader on a damaged file return a result or
        /// an error: no panic, no abort (an absurd allocation would end the test binary), and
        /// a recovery never holds more messages than the original.
        #[test]
        fn damaged_recordings_give_errors_or_results_never_panics(
            which in 0..2usize,
            d in damage(),
        ) {
            let bad = apply(&originals()[which], &d);
            let tmp = TempDir::new(&format!("record_fuzz_{which}"));
            let p = tmp.file(&format!("fuzz_{which}.mcap"));
            std::fs::write(&p, &bad).unwrap_or_else(|e| panic!("{e}"));
            let t0 = std::time::Instant::now();
            let _ = capsule_record::info(&p);
            let _ = capsule_record::messages(&p);
            let out = tmp.file(&format!("fuzz_{which}.recovered.mcap"));
            if let Ok(r) = capsule_record::recover(&p, &out) {
                prop_assert!(r.messages <= 3 * 600 + 4, "{r:?}");
                // what recovery wrote is a complete file every path reads
                let i = capsule_record::info(&out);
                prop_assert!(i.is_ok(), "{d:?}: {i:?}");
                prop_assert_eq!(i.map(|i| i.messages).ok(), Some(r.messages));
            }
            prop_assert!(t0.elapsed().as_secs_f64() < 5.0, "{d:?}: {:?}", t0.elapsed());
        }
    }
}

#[test]
fn diagnostics_in_a_recording_decode_in_every_reference_reader() {
    use capsule_msgs::std_types::{DiagnosticArray, DiagnosticStatus, KeyValue};
    let tmp = TempDir::new("record_diagnostics");
    let p = tmp.file("diagnostics.mcap");
    let topic = capsule_msgs::names::topics::views::DIAGNOSTICS;
    let levels = [
        (DiagnosticStatus::OK, "1000 samples/s"),
        (DiagnosticStatus::ERROR, "device: no line"),
        (DiagnosticStatus::WARN, "3 samples late"),
    ];
    let go = || -> Result<(), capsule_record::RecordError> {
        let mut w = scene_writer(&p, "it_scene", "# test\n".into(), &WriterOptions::default())?;
        let d = w.add_topic(
            topic,
            type_names::DIAGNOSTIC_ARRAY,
            &OfferedQos::reliable(16),
        )?;
        for (i, (level, message)) in levels.iter().enumerate() {
            let t = 1_700_000_000_000_000_000 + i as u64 * 1_000_000_000;
            let array = DiagnosticArray {
                header: Header {
                    stamp: Time::from_nanos(t as i64),
                    frame_id: String::new(),
                },
                status: vec![DiagnosticStatus {
                    level: *level,
                    name: "capsule_plant: loop".into(),
                    message: message.to_string(),
                    hardware_id: "capsule (serial /dev/ttyUSB0 at 921600 baud)".into(),
                    values: vec![KeyValue {
                        key: "device_line".into(),
                        value: i.to_string(),
                    }],
                }],
            };
            w.write(d, i as u32 + 1, t, t, &cdr::encode(&array)?)?;
        }
        w.finish().map(|_| ())
    };
    go().unwrap_or_else(|e| panic!("{e}"));
    let v = python_decode(&p, "both");
    for reader in ["mcap", "rosbags"] {
        let got: Vec<String> = rows(&v[reader]["topics"], topic)
            .iter()
            .map(|r| r.to_string())
            .collect();
        let want: Vec<String> = levels
            .iter()
            .enumerate()
            .map(|(i, (l, m))| format!("[{l},\"{m}\",[\"device_line={i}\"]]"))
            .collect();
        assert_eq!(got, want, "{reader}");
    }
    let fox = foxglove_decode(&p);
    let t = &fox["topics"][topic];
    assert_eq!(t["schema"], type_names::DIAGNOSTIC_ARRAY, "{fox}");
    assert_eq!(t["count"], 3, "{fox}");
    assert_eq!(t["first"]["message"], "1000 samples/s", "{fox}");
    assert_eq!(t["last"]["level"], DiagnosticStatus::WARN, "{fox}");
    assert_eq!(t["last"]["values"][0], "device_line=2", "{fox}");
}
