//! Writer -> reader -> recovery round trips on temporary files.

use std::path::PathBuf;

use capsule_msgs::{ActuatorForce, CapsuleState, Header, SetModeRequest, SetModeResponse, Time};

use crate::{
    cdr,
    read::{info, messages, InfoSource},
    recover,
    types::{names, topics, OfferedQos, ServiceEventInfo, SetModeEvent},
    RecordError, RecordWriter, SceneRecord, WriterOptions,
};

fn tmp(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("capsule_record_{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let p = dir.join(name);
    let _ = std::fs::remove_file(&p);
    p
}

fn state(seq: u64) -> CapsuleState {
    CapsuleState {
        header: Header {
            stamp: Time::from_nanos(seq as i64 * 1_000_000),
            frame_id: "odom".into(),
        },
        seq,
        mass_position: seq as f64 * 0.25,
        capsule_velocity: -(seq as f64),
        stuck: seq.is_multiple_of(2),
        ..CapsuleState::default()
    }
}

/// Writes `n` states at 1 kHz log time plus one force per state and a mode change at n/2.
fn write_run(path: &std::path::Path, n: u64, finish: bool) -> Result<(), RecordError> {
    let mut w = RecordWriter::create(
        path,
        WriterOptions {
            scene: Some(SceneRecord {
                name: "unit".into(),
                toml: "name = \"unit\"\n".into(),
            }),
            ..WriterOptions::default()
        },
    )?;
    let s = w.add_topic(topics::STATE, names::STATE, &OfferedQos::reliable(10))?;
    let f = w.add_topic(topics::FORCE, names::FORCE, &OfferedQos::reliable(10))?;
    let e = w.add_topic(
        topics::SET_MODE_EVENT,
        names::SET_MODE_EVENT,
        &OfferedQos::reliable(1000),
    )?;
    for i in 1..=n {
        let t = 1_000_000_000 + i * 1_000_000;
        w.write(s, i as u32, t, t, &cdr::encode(&state(i))?)?;
        let force = ActuatorForce {
            state_seq: i,
            force: i as f64 * 0.5,
            ..ActuatorForce::default()
        };
        w.write(f, i as u32, t + 1, t + 1, &cdr::encode(&force)?)?;
        if i == n / 2 {
            let ev = SetModeEvent {
                info: ServiceEventInfo {
                    event_type: ServiceEventInfo::RESPONSE_SENT,
                    stamp: Time::from_nanos(t as i64),
                    client_gid: [0; 16],
                    sequence_number: 1,
                },
                request: vec![SetModeRequest {
                    mode: SetModeRequest::FORWARD,
                    gain: 0.7,
                    effective_from: Time::ZERO,
                }],
                response: vec![SetModeResponse {
                    accepted: true,
                    mode: SetModeRequest::FORWARD,
                    gain: 0.7,
                    reason: "ok".into(),
                }],
            };
            w.write(e, 1, t + 2, t + 2, &cdr::encode(&ev)?)?;
        }
    }
    if finish {
        w.finish()?;
    } else {
        w.flush()?;
        // a writer that dies: no summary, no footer
        std::mem::forget(w);
    }
    Ok(())
}

#[test]
fn info_reads_the_summary_with_counts_modes_and_scene() {
    let p = tmp("info.mcap");
    write_run(&p, 2000, true).unwrap_or_else(|e| panic!("{e}"));
    let i = info(&p).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(i.source, InfoSource::Summary);
    assert_eq!(i.profile, "ros2");
    assert_eq!(i.messages, 4001);
    assert_eq!(i.bounds, (1_001_000_000, 3_000_000_001));
    let counts: Vec<_> = i
        .topics
        .iter()
        .map(|t| (t.topic.as_str(), t.count))
        .collect();
    assert_eq!(
        counts,
        [
            (topics::FORCE, 2000),
            (topics::STATE, 2000),
            (topics::SET_MODE_EVENT, 1)
        ]
    );
    assert!(i.topics.iter().all(|t| t.qos.is_some()));
    assert_eq!(i.mode_changes.len(), 1);
    assert_eq!(i.mode_changes[0].log_time, 2_000_000_002);
    assert_eq!(i.mode_changes[0].request().map(|r| r.gain), Some(0.7));
    assert_eq!(i.scene_name.as_deref(), Some("unit"));
    assert_eq!(i.scene_toml.as_deref(), Some("name = \"unit\"\n"));
    assert!(i.metadata.contains_key("rosbag2"));
    // 2 s of log time, a chunk closed every 0.5 s
    assert!(i.chunks >= 4, "{} chunks", i.chunks);
}

#[test]
fn messages_come_back_in_order_with_their_values() {
    let p = tmp("messages.mcap");
    write_run(&p, 300, true).unwrap_or_else(|e| panic!("{e}"));
    let all = messages(&p).unwrap_or_else(|e| panic!("{e}"));
    let states: Vec<CapsuleState> = all
        .iter()
        .filter(|m| m.topic == topics::STATE)
        .map(|m| cdr::decode(&m.data).unwrap_or_default())
        .collect();
    assert_eq!(states.len(), 300);
    for (k, s) in states.iter().enumerate() {
        assert_eq!(*s, state(k as u64 + 1));
    }
    assert!(all.windows(2).all(|w| w[0].log_time <= w[1].log_time));
}

#[test]
fn a_cut_file_is_reported_and_recovered_with_the_profile() {
    let p = tmp("cut.mcap");
    write_run(&p, 1500, false).unwrap_or_else(|e| panic!("{e}"));
    match info(&p) {
        Err(RecordError::Truncated(_)) => {}
        other => panic!("expected Truncated, got {other:?}"),
    }
    let out = tmp("cut.recovered.mcap");
    let r = recover(&p, &out).unwrap_or_else(|e| panic!("{e}"));
    assert!(!r.was_complete);
    assert_eq!(r.messages, 3001, "flushed before the cut: nothing lost");
    let i = info(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(i.profile, "ros2");
    assert_eq!(i.messages, 3001);
    assert_eq!(i.scene_name.as_deref(), Some("unit"));
    assert_eq!(i.mode_changes.len(), 1);
}

#[test]
fn a_half_written_chunk_is_dropped_and_the_rest_kept() {
    let p = tmp("half.mcap");
    write_run(&p, 1200, true).unwrap_or_else(|e| panic!("{e}"));
    let bytes = std::fs::read(&p).unwrap_or_default();
    // cut in the middle of the file: inside some chunk
    let cut = tmp("half_cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap_or_else(|e| panic!("{e}"));
    let out = tmp("half.recovered.mcap");
    let r = recover(&cut, &out).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.cut.is_some());
    assert!(r.messages > 0 && r.messages < 2401, "{}", r.messages);
    let i = info(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(i.messages, r.messages);
}

#[test]
fn bad_inputs_are_clear_errors() {
    let missing = tmp("does_not_exist.mcap");
    assert!(matches!(info(&missing), Err(RecordError::Missing(_))));
    let text = tmp("text.mcap");
    std::fs::write(&text, "hello, not mcap").unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(info(&text), Err(RecordError::NotMcap(_))));
    assert!(matches!(messages(&text), Err(RecordError::NotMcap(_))));
    assert!(matches!(
        recover(&text, &tmp("x.mcap")),
        Err(RecordError::NotMcap(_))
    ));
    let empty = tmp("empty.mcap");
    std::fs::write(&empty, "").unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(info(&empty), Err(RecordError::NotMcap(_))));
    // a schema in another encoding: not a ROS 2 recording
    let foreign = tmp("foreign.mcap");
    {
        let file = std::fs::File::create(&foreign).unwrap_or_else(|e| panic!("{e}"));
        let mut w =
            mcap::Writer::new(std::io::BufWriter::new(file)).unwrap_or_else(|e| panic!("{e}"));
        let sid = w
            .add_schema("foo.Bar", "jsonschema", b"{}")
            .unwrap_or_else(|e| panic!("{e}"));
        let cid = w
            .add_channel(sid, "/x", "json", &Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        let h = mcap::records::MessageHeader {
            channel_id: cid,
            sequence: 1,
            log_time: 1,
            publish_time: 1,
        };
        w.write_to_known_channel(&h, b"{}")
            .unwrap_or_else(|e| panic!("{e}"));
        w.finish().unwrap_or_else(|e| panic!("{e}"));
    }
    match info(&foreign) {
        Err(e @ RecordError::UnknownSchema { .. }) => {
            assert!(e.to_string().contains("jsonschema"), "{e}")
        }
        other => panic!("expected UnknownSchema, got {other:?}"),
    }
    assert!(matches!(
        messages(&foreign),
        Err(RecordError::UnknownSchema { .. })
    ));
    // an existing file is not overwritten
    assert!(matches!(
        RecordWriter::create(&foreign, WriterOptions::default()),
        Err(RecordError::Io { .. })
    ));
    // an unwritable place is an error at start
    assert!(RecordWriter::create(
        std::path::Path::new("/nonexistent_dir/x.mcap"),
        WriterOptions::default()
    )
    .is_err());
}

#[test]
fn full_disk_is_an_error_not_a_silent_truncation() {
    // /dev/full: every write fails with ENOSPC
    let dev_full = std::path::Path::new("/dev/full");
    if !dev_full.exists() {
        return;
    }
    let r = RecordWriter::create(
        dev_full,
        WriterOptions {
            overwrite: true,
            ..WriterOptions::default()
        },
    );
    match r {
        Err(e) => assert!(e.to_string().contains("/dev/full"), "{e}"),
        Ok(_) => panic!("writing to /dev/full must fail"),
    }
}
