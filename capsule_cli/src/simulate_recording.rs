//! `capsule simulate --record`: an offline run written as the ROS 2 graph would record it, so
//! the same tools (Foxglove, `ros2 bag`, `capsule record info`) read simulations and live runs.

use anyhow::{Context, Result};
use capsule_hardware::Sample;
use capsule_msgs::names::{default_topics, type_names};
use capsule_msgs::std_types::Clock;
use capsule_msgs::{Header, Time};
use capsule_plant::scene::Scene;
use capsule_plant::Snapshot;
use capsule_record::sample::state_message;
use capsule_record::types::OfferedQos;
use capsule_record::writer::now_ns;
use capsule_record::{cdr, BagOptions, BagWriter, SceneRecord, WriterOptions};
use std::path::Path;

/// Write the sampled snapshots of `scene` to `path` (compressed and split as `bag` says);
/// returns the number of messages.
pub fn write(
    path: &Path,
    scene: &Scene,
    scene_toml: String,
    rows: &[Snapshot],
    bag: BagOptions,
) -> Result<u64> {
    let start = now_ns();
    let options = WriterOptions {
        scene: Some(SceneRecord {
            name: scene.name.clone(),
            toml: scene_toml,
        }),
        created_ns: start,
        ..WriterOptions::default()
    };
    let mut w = BagWriter::create(path, options, bag)
        .with_context(|| format!("cannot record to {}", path.display()))?;
    let state_ch = w.add_topic(
        default_topics::STATE,
        type_names::STATE,
        &OfferedQos::reliable(16),
    )?;
    let clock_ch = w.add_topic(
        default_topics::CLOCK,
        type_names::CLOCK,
        &OfferedQos::reliable(1),
    )?;
    let p = &scene.physical;
    for (seq, s) in rows.iter().enumerate() {
        let stamp = Time::from_secs_f64(s.tau * p.time_s());
        let log_time = start + stamp.to_nanos().max(0) as u64;
        let header = Header {
            stamp,
            frame_id: "odom".into(),
        };
        let msg = state_message(&Sample::from_snapshot(s, p), header, seq as u64);
        let seq32 = seq as u32;
        w.write(state_ch, seq32, log_time, log_time, &cdr::encode(&msg)?)?;
        w.write(
            clock_ch,
            seq32,
            log_time,
            log_time,
            &cdr::encode(&Clock { clock: stamp })?,
        )?;
    }
    let summary = w
        .finish()
        .with_context(|| format!("finishing {}", path.display()))?;
    Ok(summary.messages)
}
