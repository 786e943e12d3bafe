//! Writer -> reader -> recovery round trips on temporary files.

use capsule_msgs::names::{default_topics, type_names};
use std::path::PathBuf;

use capsule_msgs::{ActuatorForce, CapsuleState, Header, SetModeRequest, SetModeResponse, Time};

use crate::{
    cdr,
    info::{info, InfoSource},
    messages::messages,
    recover,
    scan::chunk_records,
    types::{OfferedQos, ServiceEventInfo, SetModeEvent},
    writer::ChunkCompression,
    RecordError, RecordWriter, Recovered, SceneRecord, WriterOptions,
};

/// A directory of one test's own under the system temp dir, removed when the test ends, also
/// when it panics (the recordings here are tens of MB).
struct Tmp(PathBuf);

impl Tmp {
    fn new(test: &str) -> Tmp {
        let pid = std::process::id();
        let dir = std::env::temp_dir().join(format!("capsule_record_{pid}_{test}"));
        let _ = std::fs::remove_dir_all(&dir);
        let _ = std::fs::create_dir_all(&dir);
        Tmp(dir)
    }

    /// A file in the directory (not created).
    fn file(&self, name: &str) -> PathBuf {
        self.0.join(name)
    }
}

impl Drop for Tmp {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
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
    write_with(path, n, finish, WriterOptions::default())
}

/// [`write_run`] with writer options (the scene is added).
fn write_with(
    path: &std::path::Path,
    n: u64,
    finish: bool,
    options: WriterOptions,
) -> Result<(), RecordError> {
    let mut w = RecordWriter::create(
        path,
        WriterOptions {
            scene: Some(SceneRecord {
                name: "unit".into(),
                toml: "name = \"unit\"\n".into(),
            }),
            ..options
        },
    )?;
    let mut add = |topic, ty, depth| w.add_topic(topic, ty, &OfferedQos::reliable(depth));
    let s = add(default_topics::STATE, type_names::STATE, 10)?;
    let f = add(default_topics::FORCE, type_names::FORCE, 10)?;
    let e = add(
        default_topics::SET_MODE_EVENT,
        type_names::SET_MODE_EVENT,
        1000,
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
                    ..SetModeRequest::default()
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

/// [`write_run`] into `<test>.mcap` in a directory of the test's own.
fn written(test: &str, n: u64, finish: bool) -> (Tmp, PathBuf) {
    let tmp = Tmp::new(test);
    let p = tmp.file(&format!("{test}.mcap"));
    write_run(&p, n, finish).unwrap_or_else(|e| panic!("{e}"));
    (tmp, p)
}

#[test]
fn info_reads_the_summary_with_counts_modes_and_scene() {
    let (_tmp, p) = written("info", 2000, true);
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
            (default_topics::FORCE, 2000),
            (default_topics::STATE, 2000),
            (default_topics::SET_MODE_EVENT, 1)
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
    let (_tmp, p) = written("messages", 300, true);
    let all = messages(&p).unwrap_or_else(|e| panic!("{e}"));
    let states: Vec<CapsuleState> = all
        .iter()
        .filter(|m| m.topic == default_topics::STATE)
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
    let (tmp, p) = written("cut", 1500, false);
    match info(&p) {
        Err(RecordError::Truncated(_)) => {}
        other => panic!("expected Truncated, got {other:?}"),
    }
    let out = tmp.file("cut.recovered.mcap");
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
    let (tmp, p) = written("half", 1200, true);
    let bytes = std::fs::read(&p).unwrap_or_default();
    // cut in the middle of the file: inside some chunk
    let cut = tmp.file("half_cut.mcap");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap_or_else(|e| panic!("{e}"));
    let out = tmp.file("half.recovered.mcap");
    let r = recover(&cut, &out).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.cut.is_some());
    assert!(r.messages > 0 && r.messages < 2401, "{}", r.messages);
    let i = info(&out).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(i.messages, r.messages);
}

#[test]
fn bad_inputs_are_clear_errors() {
    let tmp = Tmp::new("bad_inputs");
    let missing = tmp.file("does_not_exist.mcap");
    assert!(matches!(info(&missing), Err(RecordError::Missing(_))));
    let text = tmp.file("text.mcap");
    std::fs::write(&text, "hello, not mcap").unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(info(&text), Err(RecordError::NotMcap(_))));
    assert!(matches!(messages(&text), Err(RecordError::NotMcap(_))));
    assert!(matches!(
        recover(&text, &tmp.file("x.mcap")),
        Err(RecordError::NotMcap(_))
    ));
    let empty = tmp.file("empty.mcap");
    std::fs::write(&empty, "").unwrap_or_else(|e| panic!("{e}"));
    assert!(matches!(info(&empty), Err(RecordError::NotMcap(_))));
    // a schema in another encoding (not a ROS 2 recording) is refused by `info` and replay
    // reading: tests/integration/record.rs writes one and checks both through the CLI
    // an existing file is not overwritten
    assert!(matches!(
        RecordWriter::create(&empty, WriterOptions::default()),
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

/// A chunk of a file: offset, length, messages in it.
type Chunk = (usize, usize, u64);

/// Each chunk of a complete file (from its summary).
fn chunk_table(bytes: &[u8]) -> Vec<Chunk> {
    let summary = mcap::read::Summary::read(bytes)
        .ok()
        .flatten()
        .unwrap_or_else(|| panic!("no summary"));
    summary
        .chunk_indexes
        .iter()
        .map(|c| {
            let (start, len) = (c.chunk_start_offset as usize, c.chunk_length as usize);
            let msgs = match mcap::parse_record(bytes[start], &bytes[start + 9..start + len]) {
                Ok(mcap::records::Record::Chunk { header, data }) => chunk_records(header, &data)
                    .unwrap_or_default()
                    .iter()
                    .filter(|r| matches!(r, mcap::records::Record::Message { .. }))
                    .count()
                    as u64,
                other => panic!("not a chunk at {start}: {other:?}"),
            };
            (start, len, msgs)
        })
        .collect()
}

const KINDS: [ChunkCompression; 3] = [
    ChunkCompression::None,
    ChunkCompression::ZSTD_FAST,
    ChunkCompression::Lz4,
];

/// 6000 states + forces + 1 event in about 12 chunks (0.5 s of log time each).
fn chunked_run(tmp: &Tmp, name: &str, compression: ChunkCompression) -> (PathBuf, Vec<u8>) {
    let p = tmp.file(&format!("{name}_{}.mcap", compression.chunk_name()));
    let options = WriterOptions {
        compression,
        ..WriterOptions::default()
    };
    write_with(&p, 6000, true, options).unwrap_or_else(|e| panic!("{e}"));
    let bytes = std::fs::read(&p).unwrap_or_default();
    (p, bytes)
}

#[test]
fn compressed_files_read_whole_and_recover_whole() {
    let tmp = Tmp::new("whole");
    let mut sizes = Vec::new();
    for kind in KINDS {
        let (p, bytes) = chunked_run(&tmp, "whole", kind);
        let i = info(&p).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_eq!(i.messages, 12_001, "{kind:?}");
        assert_eq!(i.mode_changes.len(), 1, "{kind:?}");
        assert!(i.chunks >= 10, "{kind:?}: {} chunks", i.chunks);
        assert_eq!(messages(&p).map(|m| m.len()).ok(), Some(12_001));
        let out = tmp.file(&format!("whole_{}.recovered.mcap", kind.chunk_name()));
        let r = recover(&p, &out).unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert!(
            r.was_complete && r.damage.is_empty() && r.cut.is_none(),
            "{r:?}"
        );
        assert_eq!((r.messages, r.summary_messages), (12_001, Some(12_001)));
        let again = std::fs::read(&out).unwrap_or_default();
        // the same compression again: the recovered file is not a different size class
        let ratio = again.len() as f64 / bytes.len() as f64;
        assert!((0.7..1.4).contains(&ratio), "{kind:?}: size ratio {ratio}");
        assert_eq!(info(&out).map(|i| i.messages).ok(), Some(12_001));
        sizes.push(bytes.len());
    }
    // none, zstd, lz4: compression does compress
    assert!(sizes[1] * 2 < sizes[0] && sizes[2] < sizes[0], "{sizes:?}");
}

/// For each compression, in a directory of the test's own (`test`): the bytes of a
/// [`chunked_run`] and its chunk table.
fn each_chunked_run(test: &str, mut check: impl FnMut(&Tmp, ChunkCompression, &[u8], &[Chunk])) {
    let tmp = Tmp::new(test);
    for kind in KINDS {
        let (_, bytes) = chunked_run(&tmp, test, kind);
        check(&tmp, kind, &bytes, &chunk_table(&bytes));
    }
}

/// Writes `bytes` to `<name>.mcap` in `tmp` and recovers it into `<name>.recovered.mcap`
/// (replaced if there): the damaged file, the recovered one, what recovery says.
fn recover_bytes(
    tmp: &Tmp,
    name: &str,
    bytes: &[u8],
) -> (PathBuf, PathBuf, Result<Recovered, RecordError>) {
    let p = tmp.file(&format!("{name}.mcap"));
    std::fs::write(&p, bytes).unwrap_or_else(|e| panic!("{e}"));
    let out = tmp.file(&format!("{name}.recovered.mcap"));
    let _ = std::fs::remove_file(&out);
    let r = recover(&p, &out);
    (p, out, r)
}

#[test]
fn a_flipped_bit_in_a_middle_chunk_loses_that_chunk_only() {
    each_chunked_run("flip", |tmp, kind, bytes, chunks| {
        let total: u64 = chunks.iter().map(|c| c.2).sum();
        assert_eq!(total, 12_001);
        for k in [1, chunks.len() / 2, chunks.len() - 2] {
            let (start, len, lost) = chunks[k];
            let mut bad = bytes.to_vec();
            bad[start + len * 2 / 3] ^= 0x10;
            let name = format!("flip_{}_{k}", kind.chunk_name());
            let (_, out, r) = recover_bytes(tmp, &name, &bad);
            let r = r.unwrap_or_else(|e| panic!("{kind:?} {k}: {e}"));
            assert_eq!(r.messages, total - lost, "{kind:?} chunk {k}: {r:?}");
            assert_eq!(r.chunks_dropped, 1, "{kind:?} chunk {k}: {r:?}");
            assert_eq!(r.chunks_kept as usize, chunks.len() - 1);
            assert_eq!(info(&out).map(|i| i.messages).ok(), Some(total - lost));
        }
    });
}

#[test]
fn a_damaged_chunk_length_prefix_loses_nothing() {
    each_chunked_run("len", |tmp, kind, bytes, chunks| {
        let k = chunks.len() / 2;
        for junk in [u64::MAX, 3, (chunks[k].1 as u64) * 3] {
            let mut bad = bytes.to_vec();
            bad[chunks[k].0 + 1..chunks[k].0 + 9].copy_from_slice(&junk.to_le_bytes());
            let name = format!("len_{}", kind.chunk_name());
            let r = recover_bytes(tmp, &name, &bad).2;
            let r = r.unwrap_or_else(|e| panic!("{kind:?}: {e}"));
            // the chunk is read by its own fields (its CRC holds): nothing lost, the damage said
            assert_eq!(r.messages, 12_001, "{kind:?} {junk}: {r:?}");
            assert_eq!(r.damage.len(), 1, "{kind:?} {junk}: {r:?}");
            assert_eq!(r.chunks_dropped, 0);
        }
    });
}

#[test]
fn a_truncated_file_keeps_every_chunk_before_the_cut() {
    each_chunked_run("trunc", |tmp, kind, bytes, chunks| {
        for frac in [0.0, 0.1, 0.33, 0.5, 0.77, 0.95, 0.999] {
            let cut = ((bytes.len() as f64 * frac) as usize).max(8);
            let whole: u64 = chunks
                .iter()
                .filter(|c| c.0 + c.1 <= cut)
                .map(|c| c.2)
                .sum();
            let name = format!("trunc_{}_{frac}", kind.chunk_name());
            let (p, out, r) = recover_bytes(tmp, &name, &bytes[..cut]);
            assert!(info(&p).is_err(), "{kind:?} {frac}: a cut file is an error");
            let r = r.unwrap_or_else(|e| panic!("{kind:?} {frac}: {e}"));
            assert_eq!(r.messages, whole, "{kind:?} cut at {frac}: {r:?}");
            assert!(!r.was_complete);
            assert_eq!(info(&out).map(|i| i.messages).ok(), Some(whole));
        }
    });
}

#[test]
fn a_damaged_chunk_header_skips_to_the_next_intact_chunk() {
    each_chunked_run("hdr", |tmp, kind, bytes, chunks| {
        let k = chunks.len() / 2;
        let mut bad = bytes.to_vec();
        // the records length (after times, size, CRC and the compression name): past the end
        let name = kind.chunk_name().len();
        let at = chunks[k].0 + 9 + 8 + 8 + 8 + 4 + 4 + name;
        bad[at..at + 8].copy_from_slice(&u64::MAX.to_le_bytes());
        bad[chunks[k].0 + 1..chunks[k].0 + 9].copy_from_slice(&u64::MAX.to_le_bytes());
        let name = format!("hdr_{}", kind.chunk_name());
        let r = recover_bytes(tmp, &name, &bad).2;
        let r = r.unwrap_or_else(|e| panic!("{kind:?}: {e}"));
        assert_eq!(r.messages, 12_001 - chunks[k].2, "{kind:?}: {r:?}");
        assert_eq!(r.chunks_dropped, 1, "{kind:?}: {r:?}");
        assert_eq!(r.chunks_kept as usize, chunks.len() - 1);
    });
}

#[test]
fn split_by_duration_and_size_gives_numbered_files_and_one_metadata_yaml() {
    let tmp = Tmp::new("split");
    use crate::bag::{bag_files, bag_info, BagOptions, BagWriter};
    use crate::metadata_yaml::METADATA_YAML;
    for (name, bag) in [
        (
            "split_dur",
            BagOptions {
                compression: ChunkCompression::ZSTD_FAST,
                max_bytes: None,
                max_duration_ns: Some(1_000_000_000),
            },
        ),
        (
            "split_size",
            BagOptions {
                compression: ChunkCompression::Lz4,
                max_bytes: Some(200_000),
                max_duration_ns: None,
            },
        ),
    ] {
        let path = tmp.file(&format!("{name}.mcap"));
        let dir = path.with_extension("");
        let mut w = BagWriter::create(&path, WriterOptions::default(), bag)
            .unwrap_or_else(|e| panic!("{e}"));
        let s = w
            .add_topic(
                default_topics::STATE,
                type_names::STATE,
                &OfferedQos::reliable(10),
            )
            .unwrap_or_else(|e| panic!("{e}"));
        for i in 1..=4500u64 {
            let t = 1_000_000_000 + i * 1_000_000;
            let data = cdr::encode(&state(i)).unwrap_or_default();
            w.write(s, i as u32, t, t, &data)
                .unwrap_or_else(|e| panic!("{e}"));
        }
        let summary = w.finish().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            (summary.path.as_path(), summary.messages),
            (dir.as_path(), 4500)
        );
        let files = bag_files(&dir).unwrap_or_else(|e| panic!("{e}"));
        // 4.5 s in 1 s files: 5; 4500 states of about 170 bytes as counted (with record and
        // index overhead) in files of 200 kB: 4
        let want = if name == "split_dur" { 5 } else { 4 };
        assert_eq!(files.len(), want, "{name}: {files:?}");
        for (k, f) in files.iter().enumerate() {
            assert_eq!(f, &dir.join(format!("{name}_{k}.mcap")));
        }
        let yaml = std::fs::read_to_string(dir.join(METADATA_YAML)).unwrap_or_default();
        assert!(yaml.contains("  version: 8\n  storage_identifier: mcap\n"));
        assert!(yaml.contains("  message_count: 4500\n"), "{yaml}");
        let i = bag_info(&dir).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((i.messages, i.files), (4500, want as u64));
        assert_eq!(i.bounds, (1_001_000_000, 5_500_000_000));
        let per_file: u64 = files
            .iter()
            .map(|f| info(f).map(|i| i.messages).unwrap_or(0))
            .sum();
        assert_eq!(per_file, 4500);
    }
}
