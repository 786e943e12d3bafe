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
    assert!(text.contains("accepted FORWARD (gain 0.5)"), "{text}");
    assert!(text.contains("refused CUSTOM (gain 99)"), "{text}");
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
        let args = ["record", "info", f.as_str()];
        let out = capsule(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{args:?}: {err}");
        assert!(err.contains(want) && err.contains(&f), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
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
