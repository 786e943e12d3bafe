//! `capsule record recover`: rebuilds a complete recording from a file whose writer died
//! (no footer, an open chunk with a placeholder length). Every closed chunk is kept; the cut
//! chunk is dropped; the `ros2` profile, schemas, channels (with their QoS), metadata and the
//! scene attachment are written again, with a fresh summary.

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
};

use crate::{
    read::scan,
    writer::{RecordWriter, WriterOptions, CAPSULE_METADATA, ROSBAG2_METADATA},
    RecordError,
};

/// What recovery saved.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovered {
    /// The complete file written.
    pub output: PathBuf,
    /// Messages saved.
    pub messages: u64,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
    /// The input already had a footer (nothing was cut).
    pub was_complete: bool,
    /// Why the scan stopped (the cut point), if it did.
    pub cut: Option<String>,
    /// First and last log time of the saved messages (ns).
    pub bounds: Option<(u64, u64)>,
}

/// Reads `input` as far as it is intact and writes a complete `ros2`-profile file to `output`
/// (which may not exist yet; `input == output` is refused: write elsewhere, then rename).
pub fn recover(input: &Path, output: &Path) -> Result<Recovered, RecordError> {
    if input == output {
        return Err(RecordError::Usage(format!(
            "{}: recovery writes a new file; give another output path",
            input.display()
        )));
    }
    let bytes = std::fs::read(input).map_err(|e| RecordError::io(input, e))?;
    if !bytes.starts_with(mcap::MAGIC) {
        return Err(RecordError::NotMcap(input.to_path_buf()));
    }
    let found = scan(&bytes, true).map_err(|e| RecordError::Corrupt {
        path: input.to_path_buf(),
        cause: e,
    })?;
    let created_ns = found
        .metadata
        .iter()
        .find(|m| m.name == CAPSULE_METADATA)
        .and_then(|m| m.metadata.get("created_ns"))
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(crate::writer::now_ns);
    let mut w = RecordWriter::create(
        output,
        WriterOptions {
            created_ns,
            flush_interval_ns: u64::MAX,
            ..WriterOptions::default()
        },
    )?;
    for m in &found.metadata {
        // the writer wrote its own `capsule` record; keep the original's keys over it
        if m.name != ROSBAG2_METADATA {
            w.write_metadata(&m.name, m.metadata.clone())?;
        }
    }
    for (h, data) in &found.attachments {
        w.attach(&h.name, &h.media_type, h.log_time, data)?;
    }
    let mut ids = BTreeMap::new();
    for (id, ch) in &found.channels {
        let Some(schema) = found.schemas.get(&ch.schema_id) else {
            return Err(RecordError::UnknownSchema {
                path: input.to_path_buf(),
                topic: ch.topic.clone(),
                reason: format!(
                    "refers to schema id {}, which the file does not define",
                    ch.schema_id
                ),
            });
        };
        let new = w.add_channel(&ch.topic, &schema.name, &schema.data, ch.metadata.clone())?;
        ids.insert(*id, (new, ch.topic.clone()));
    }
    let mut per_topic = BTreeMap::new();
    for m in &found.messages {
        let Some((id, topic)) = ids.get(&m.header.channel_id) else {
            continue;
        };
        w.write(
            *id,
            m.header.sequence,
            m.header.log_time,
            m.header.publish_time,
            &m.data,
        )?;
        *per_topic.entry(topic.clone()).or_insert(0u64) += 1;
    }
    let summary = w.finish()?;
    Ok(Recovered {
        output: output.to_path_buf(),
        messages: summary.messages,
        per_topic,
        was_complete: found.complete,
        cut: found.stopped.map(|e| e.to_string()),
        bounds: summary.bounds,
    })
}
