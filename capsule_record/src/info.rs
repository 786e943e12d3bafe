//! `capsule record info`: what a recording holds, from the summary section (a few small reads,
//! whatever the file size); a full scan only for files written without one.

use capsule_msgs::names::type_names;
use std::{
    collections::BTreeMap,
    fs::File,
    io::{Read, Seek, SeekFrom},
    path::{Path, PathBuf},
};

use capsule_msgs::{SetModeRequest, SetModeResponse};
use mcap::{
    records::{self, Record},
    sans_io::{SummaryReadEvent, SummaryReader, SummaryReaderOptions},
    McapError, Summary,
};

use crate::{
    cdr,
    open::{check_channel, corrupt, open_checked, parse_whole, read_at, read_header},
    profile::{CAPSULE_METADATA, QOS_KEY, SCENE_ATTACHMENT},
    scan::{chunk_records, scan},
    types::SetModeEvent,
    RecordError,
};

/// One topic of a recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TopicInfo {
    /// Topic name.
    pub topic: String,
    /// ROS type (`pkg/msg/Type`).
    pub type_name: String,
    /// Messages on it.
    pub count: u64,
    /// Offered QoS (YAML), if recorded.
    pub qos: Option<String>,
}

/// One mode change: a `set_mode` service event.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeChange {
    /// Log time (ns).
    pub log_time: u64,
    /// The service event.
    pub event: SetModeEvent,
}

impl ModeChange {
    /// The request, if the event carries one.
    pub fn request(&self) -> Option<&SetModeRequest> {
        self.event.request.first()
    }
    /// The response, if the event carries one.
    pub fn response(&self) -> Option<&SetModeResponse> {
        self.event.response.first()
    }
}

/// Where [`info`] took its figures from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InfoSource {
    /// The summary section (statistics and indexes): no scan.
    Summary,
    /// A scan of the whole file (it has no summary).
    Scan,
}

/// What `capsule record info` shows.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordingInfo {
    /// The file.
    pub path: PathBuf,
    /// Its size in bytes.
    pub size: u64,
    /// Header profile (`ros2`).
    pub profile: String,
    /// Header library (the writer).
    pub library: String,
    /// First and last log time (ns); (0, 0) without messages.
    pub bounds: (u64, u64),
    /// Messages in all.
    pub messages: u64,
    /// Chunks.
    pub chunks: u64,
    /// Topics, by name.
    pub topics: Vec<TopicInfo>,
    /// Mode changes (service events of `set_mode`), in log-time order.
    pub mode_changes: Vec<ModeChange>,
    /// The scene's name, if recorded.
    pub scene_name: Option<String>,
    /// The scene file's text, if attached.
    pub scene_toml: Option<String>,
    /// Metadata records by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    /// Attachment names.
    pub attachments: Vec<String>,
    /// Summary or scan.
    pub source: InfoSource,
    /// Files (more than one: a split recording).
    pub files: u64,
}

impl RecordingInfo {
    /// Duration between the first and last message (ns).
    pub fn duration_ns(&self) -> u64 {
        self.bounds.1 - self.bounds.0
    }
}

fn decode_mode_change(log_time: u64, data: &[u8]) -> Option<ModeChange> {
    match cdr::decode::<SetModeEvent>(data) {
        Ok(event) => Some(ModeChange { log_time, event }),
        Err(e) => {
            tracing::warn!("undecodable set_mode service event at {log_time} ns: {e}");
            None
        }
    }
}

/// Reads what `capsule record info` shows. Uses the summary (statistics, chunk, metadata and
/// attachment indexes) and reads only the chunks that hold service events; scans the file
/// only when it has no summary. A cut file (no footer) is [`RecordError::Truncated`].
pub fn info(path: &Path) -> Result<RecordingInfo, RecordError> {
    let (mut f, size) = open_checked(path)?;
    let header = read_header(&mut f, path)?;
    f.seek(SeekFrom::Start(0))
        .map_err(|e| RecordError::io(path, e))?;
    let summary = match read_summary(&mut f, path, size)? {
        Some(s) if s.stats.is_some() => s,
        _ => return info_by_scan(path, size, header),
    };
    let stats = summary.stats.clone().unwrap_or_default();
    let mut topics = Vec::new();
    let mut event_channels = Vec::new();
    for (id, ch) in &summary.channels {
        let schema = ch
            .schema
            .as_ref()
            .map(|s| (s.name.as_str(), s.encoding.as_str()));
        check_channel(path, &ch.topic, schema, &ch.message_encoding)?;
        let type_name = schema.map(|s| s.0).unwrap_or_default().to_string();
        if type_name == type_names::SET_MODE_EVENT {
            event_channels.push(*id);
        }
        topics.push(TopicInfo {
            topic: ch.topic.clone(),
            type_name,
            count: stats.channel_message_counts.get(id).copied().unwrap_or(0),
            qos: ch.metadata.get(QOS_KEY).cloned(),
        });
    }
    topics.sort_by(|a, b| a.topic.cmp(&b.topic));

    let mut metadata = BTreeMap::new();
    for idx in &summary.metadata_indexes {
        let buf = read_at(&mut f, path, idx.offset, idx.length)?;
        if let Record::Metadata(m) = parse_whole(&buf).map_err(|e| corrupt(path, e))? {
            metadata.insert(m.name, m.metadata);
        }
    }
    let mut scene_toml = None;
    let mut attachments = Vec::new();
    for idx in &summary.attachment_indexes {
        attachments.push(idx.name.clone());
        if idx.name == SCENE_ATTACHMENT && idx.length < 16 << 20 {
            let buf = read_at(&mut f, path, idx.offset, idx.length)?;
            if let Record::Attachment { data, .. } =
                parse_whole(&buf).map_err(|e| corrupt(path, e))?
            {
                scene_toml = Some(String::from_utf8_lossy(&data).into_owned());
            }
        }
    }

    let mut mode_changes = summary_mode_changes(&mut f, path, &summary, &event_channels)?;
    mode_changes.sort_by_key(|m| m.log_time);
    let bounds = if stats.message_count > 0 {
        (stats.message_start_time, stats.message_end_time)
    } else {
        (0, 0)
    };
    let scene_name = metadata
        .get(CAPSULE_METADATA)
        .and_then(|m| m.get("scene_name").cloned());
    Ok(RecordingInfo {
        path: path.to_path_buf(),
        size,
        profile: header.profile,
        library: header.library,
        bounds,
        messages: stats.message_count,
        chunks: stats.chunk_count as u64,
        topics,
        mode_changes,
        scene_name,
        scene_toml,
        metadata,
        attachments,
        source: InfoSource::Summary,
        files: 1,
    })
}

/// The summary section, read from the footer back (`None` when the file has none).
fn read_summary(f: &mut File, path: &Path, size: u64) -> Result<Option<Summary>, RecordError> {
    let mut reader =
        SummaryReader::new_with_options(SummaryReaderOptions::default().with_file_size(size));
    while let Some(event) = reader.next_event() {
        match event.map_err(|e| corrupt(path, e))? {
            SummaryReadEvent::ReadRequest(n) => {
                let got = f
                    .read(reader.insert(n))
                    .map_err(|e| RecordError::io(path, e))?;
                reader.notify_read(got);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let pos = f.seek(to).map_err(|e| RecordError::io(path, e))?;
                reader.notify_seeked(pos);
            }
        }
    }
    Ok(reader.finish())
}

/// The mode changes: the service events in the chunks that hold any (by the chunk indexes).
fn summary_mode_changes(
    f: &mut File,
    path: &Path,
    summary: &Summary,
    event_channels: &[u16],
) -> Result<Vec<ModeChange>, RecordError> {
    let mut mode_changes = Vec::new();
    for chunk in &summary.chunk_indexes {
        if !event_channels
            .iter()
            .any(|c| chunk.message_index_offsets.contains_key(c))
        {
            continue;
        }
        let buf = read_at(f, path, chunk.chunk_start_offset, chunk.chunk_length)?;
        let Record::Chunk { header, data } = parse_whole(&buf).map_err(|e| corrupt(path, e))?
        else {
            return Err(corrupt(path, McapError::BadIndex));
        };
        for rec in chunk_records(header, &data).map_err(|e| corrupt(path, e))? {
            if let Record::Message { header, data } = rec {
                if event_channels.contains(&header.channel_id) {
                    mode_changes.extend(decode_mode_change(header.log_time, &data));
                }
            }
        }
    }
    Ok(mode_changes)
}

fn info_by_scan(
    path: &Path,
    size: u64,
    header: records::Header,
) -> Result<RecordingInfo, RecordError> {
    let bytes = std::fs::read(path).map_err(|e| RecordError::io(path, e))?;
    let scan = scan(&bytes).map_err(|e| corrupt(path, e))?;
    let mut topics = Vec::new();
    for (id, ch) in &scan.channels {
        let schema = scan
            .schemas
            .get(&ch.schema_id)
            .map(|s| (s.name.as_str(), s.encoding.as_str()));
        check_channel(path, &ch.topic, schema, &ch.message_encoding)?;
        topics.push(TopicInfo {
            topic: ch.topic.clone(),
            type_name: schema.map(|s| s.0).unwrap_or_default().to_string(),
            count: scan.counts.get(id).copied().unwrap_or(0),
            qos: ch.metadata.get(QOS_KEY).cloned(),
        });
    }
    topics.sort_by(|a, b| a.topic.cmp(&b.topic));
    let event_channels: Vec<u16> = scan
        .channels
        .iter()
        .filter(|(_, c)| {
            scan.schemas
                .get(&c.schema_id)
                .is_some_and(|s| s.name == type_names::SET_MODE_EVENT)
        })
        .map(|(id, _)| *id)
        .collect();
    let mut mode_changes = Vec::new();
    for m in &scan.messages {
        if event_channels.contains(&m.header.channel_id) {
            mode_changes.extend(decode_mode_change(m.header.log_time, &m.data));
        }
    }
    let metadata: BTreeMap<_, _> = scan
        .metadata
        .iter()
        .map(|m| (m.name.clone(), m.metadata.clone()))
        .collect();
    let scene_name = metadata
        .get(CAPSULE_METADATA)
        .and_then(|m| m.get("scene_name").cloned());
    let scene_toml = scan
        .attachments
        .iter()
        .find(|a| a.0.name == SCENE_ATTACHMENT)
        .map(|a| String::from_utf8_lossy(&a.1).into_owned());
    Ok(RecordingInfo {
        path: path.to_path_buf(),
        size,
        profile: header.profile,
        library: header.library,
        bounds: scan.bounds().unwrap_or((0, 0)),
        messages: scan.messages.len() as u64,
        chunks: scan.chunks,
        topics,
        mode_changes,
        scene_name,
        scene_toml,
        metadata,
        attachments: scan.attachments.iter().map(|a| a.0.name.clone()).collect(),
        source: InfoSource::Scan,
        files: 1,
    })
}
