//! Reading recordings: `info` from the summary (a few small reads, whatever the file size),
//! a full scan only for files written without one, and every message in order for replay.

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
    McapError, MAGIC,
};

use crate::{
    cdr,
    types::{names, SetModeEvent},
    writer::{CAPSULE_METADATA, QOS_KEY, SCENE_ATTACHMENT},
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
}

impl RecordingInfo {
    /// Duration between the first and last message (ns).
    pub fn duration_ns(&self) -> u64 {
        self.bounds.1 - self.bounds.0
    }
}

fn corrupt(path: &Path, e: McapError) -> RecordError {
    match e {
        McapError::UnknownSchema(topic, id) => RecordError::UnknownSchema {
            path: path.to_path_buf(),
            topic,
            reason: format!("refers to schema id {id}, which the file does not define"),
        },
        source => RecordError::Corrupt {
            path: path.to_path_buf(),
            cause: source,
        },
    }
}

/// Opens a recording and checks both magics: missing file, non-MCAP and cut files are errors.
fn open_checked(path: &Path) -> Result<(File, u64), RecordError> {
    let mut f = File::open(path).map_err(|e| RecordError::io(path, e))?;
    let size = f.metadata().map_err(|e| RecordError::io(path, e))?.len();
    if f.metadata().map(|m| m.is_dir()).unwrap_or(false) {
        return Err(RecordError::Io {
            path: path.to_path_buf(),
            cause: std::io::Error::other("is a directory"),
        });
    }
    let mut head = [0u8; 8];
    if size < 8 || f.read_exact(&mut head).is_err() || head != MAGIC {
        return Err(RecordError::NotMcap(path.to_path_buf()));
    }
    let mut tail = [0u8; 8];
    let tail_ok = size >= 16
        && f.seek(SeekFrom::End(-8)).is_ok()
        && f.read_exact(&mut tail).is_ok()
        && tail == MAGIC;
    if !tail_ok {
        return Err(RecordError::Truncated(path.to_path_buf()));
    }
    Ok((f, size))
}

fn read_at(f: &mut File, path: &Path, offset: u64, len: u64) -> Result<Vec<u8>, RecordError> {
    let mut buf = vec![0u8; len as usize];
    f.seek(SeekFrom::Start(offset))
        .and_then(|_| f.read_exact(&mut buf))
        .map_err(|e| RecordError::io(path, e))?;
    Ok(buf)
}

/// Parses one whole record (opcode, length, body) from `buf`.
fn parse_whole(buf: &[u8]) -> Result<Record<'_>, McapError> {
    if buf.len() < 9 {
        return Err(McapError::UnexpectedEof);
    }
    let len = u64::from_le_bytes(buf[1..9].try_into().map_err(|_| McapError::UnexpectedEof)?);
    let end = 9usize.saturating_add(len as usize);
    if buf.len() < end {
        return Err(McapError::UnexpectedEof);
    }
    mcap::parse_record(buf[0], &buf[9..end])
}

fn read_header(f: &mut File, path: &Path) -> Result<records::Header, RecordError> {
    let prefix = read_at(f, path, 8, 9)?;
    let len = u64::from_le_bytes(prefix[1..9].try_into().unwrap_or([0; 8]));
    if prefix[0] != 0x01 || len > 1 << 20 {
        return Err(RecordError::Corrupt {
            path: path.to_path_buf(),
            cause: McapError::BadIndex,
        });
    }
    let body = read_at(f, path, 17, len)?;
    match mcap::parse_record(0x01, &body) {
        Ok(Record::Header(h)) => Ok(h),
        Ok(_) => Err(corrupt(path, McapError::BadIndex)),
        Err(e) => Err(corrupt(path, e)),
    }
}

fn check_channel(
    path: &Path,
    topic: &str,
    schema: Option<(&str, &str)>,
    message_encoding: &str,
) -> Result<(), RecordError> {
    let unknown = |reason: String| RecordError::UnknownSchema {
        path: path.to_path_buf(),
        topic: topic.to_string(),
        reason,
    };
    match schema {
        None => Err(unknown("has no schema".into())),
        Some((_, enc)) if enc != "ros2msg" => Err(unknown(format!(
            "schema encoding {enc:?} is not ros2msg: not a ROS 2 recording"
        ))),
        Some(_) if message_encoding != "cdr" => Err(unknown(format!(
            "message encoding {message_encoding:?} is not cdr: not a ROS 2 recording"
        ))),
        Some(_) => Ok(()),
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
    let summary = match reader.finish() {
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
        if type_name == names::SET_MODE_EVENT {
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

    let mut mode_changes = Vec::new();
    for chunk in &summary.chunk_indexes {
        if !event_channels
            .iter()
            .any(|c| chunk.message_index_offsets.contains_key(c))
        {
            continue;
        }
        let buf = read_at(&mut f, path, chunk.chunk_start_offset, chunk.chunk_length)?;
        let Record::Chunk { header, data } = parse_whole(&buf).map_err(|e| corrupt(path, e))?
        else {
            return Err(corrupt(path, McapError::BadIndex));
        };
        let reader = mcap::read::ChunkReader::new(header, &data).map_err(|e| corrupt(path, e))?;
        for rec in reader {
            if let Record::Message { header, data } = rec.map_err(|e| corrupt(path, e))? {
                if event_channels.contains(&header.channel_id) {
                    mode_changes.extend(decode_mode_change(header.log_time, &data));
                }
            }
        }
    }
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
    })
}

fn info_by_scan(
    path: &Path,
    size: u64,
    header: records::Header,
) -> Result<RecordingInfo, RecordError> {
    let bytes = std::fs::read(path).map_err(|e| RecordError::io(path, e))?;
    let scan = scan(&bytes, false).map_err(|e| corrupt(path, e))?;
    if let Some(e) = scan.stopped {
        return Err(corrupt(path, e));
    }
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
                .is_some_and(|s| s.name == names::SET_MODE_EVENT)
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
    })
}

/// A schema record.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaRec {
    /// `pkg/msg/Type`.
    pub name: String,
    /// `ros2msg`.
    pub encoding: String,
    /// The schema text.
    pub data: Vec<u8>,
}

/// A message as stored.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RawMessage {
    /// Channel, sequence and times.
    pub header: records::MessageHeader,
    /// CDR bytes with the encapsulation header.
    pub data: Vec<u8>,
}

/// Everything a linear scan found, in file order.
#[derive(Debug, Default)]
pub struct Scan {
    /// The header record, if read.
    pub header: Option<records::Header>,
    /// Schemas by id.
    pub schemas: BTreeMap<u16, SchemaRec>,
    /// Channels by id.
    pub channels: BTreeMap<u16, records::Channel>,
    /// Messages in file order.
    pub messages: Vec<RawMessage>,
    /// Messages per channel.
    pub counts: BTreeMap<u16, u64>,
    /// Metadata records.
    pub metadata: Vec<records::Metadata>,
    /// Attachments (header, data).
    pub attachments: Vec<(records::AttachmentHeader, Vec<u8>)>,
    /// Chunks read whole.
    pub chunks: u64,
    /// The error the scan stopped at (lenient scans only): the cut point of a killed file.
    pub stopped: Option<McapError>,
    /// The footer was reached.
    pub complete: bool,
}

impl Scan {
    /// First and last log time of the messages.
    pub fn bounds(&self) -> Option<(u64, u64)> {
        let mut it = self.messages.iter().map(|m| m.header.log_time);
        let first = it.next()?;
        Some(it.fold((first, first), |(a, b), t| (a.min(t), b.max(t))))
    }
}

/// Reads every record of an MCAP file in memory. `lenient`: a missing end magic or a damaged
/// record ends the scan (recorded in [`Scan::stopped`]) instead of failing it.
pub fn scan(bytes: &[u8], lenient: bool) -> Result<Scan, McapError> {
    if !bytes.starts_with(MAGIC) {
        return Err(McapError::BadMagic);
    }
    let mut out = Scan::default();
    let opts = if lenient {
        enumset::enum_set!(mcap::read::Options::IgnoreEndMagic)
    } else {
        enumset::EnumSet::empty()
    };
    let reader = mcap::read::LinearReader::new_with_options(bytes, opts)?;
    for rec in reader {
        let rec = match rec {
            Ok(r) => r,
            Err(e) if lenient => {
                out.stopped = Some(e);
                break;
            }
            Err(e) => return Err(e),
        };
        match rec {
            Record::Chunk { header, data } => {
                // a chunk is only kept whole: a damaged one is the cut point
                let mut inner = Vec::new();
                let mut bad = None;
                match mcap::read::ChunkReader::new(header, &data) {
                    Ok(r) => {
                        for x in r {
                            match x {
                                Ok(x) => inner.push(x.into_owned()),
                                Err(e) => {
                                    bad = Some(e);
                                    break;
                                }
                            }
                        }
                    }
                    Err(e) => bad = Some(e),
                }
                if let Some(e) = bad {
                    if lenient {
                        out.stopped = Some(e);
                        break;
                    }
                    return Err(e);
                }
                out.chunks += 1;
                for x in inner {
                    take(&mut out, x);
                }
            }
            Record::Footer(_) => {
                out.complete = true;
                take(&mut out, rec);
            }
            other => take(&mut out, other),
        }
    }
    Ok(out)
}

fn take(out: &mut Scan, rec: Record<'_>) {
    match rec {
        Record::Header(h) => out.header = Some(h),
        Record::Schema { header, data } => {
            out.schemas.entry(header.id).or_insert(SchemaRec {
                name: header.name,
                encoding: header.encoding,
                data: data.into_owned(),
            });
        }
        Record::Channel(c) => {
            out.channels.entry(c.id).or_insert(c);
        }
        Record::Message { header, data } => {
            *out.counts.entry(header.channel_id).or_insert(0) += 1;
            out.messages.push(RawMessage {
                header,
                data: data.into_owned(),
            });
        }
        Record::Metadata(m) => out.metadata.push(m),
        Record::Attachment { header, data, .. } => {
            out.attachments.push((header, data.into_owned()))
        }
        _ => {}
    }
}

/// A decoded-type view of one recorded message, for replay and checks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// Topic.
    pub topic: String,
    /// ROS type.
    pub type_name: String,
    /// Per-channel sequence number.
    pub sequence: u32,
    /// Log time (ns).
    pub log_time: u64,
    /// Publish time (ns).
    pub publish_time: u64,
    /// CDR bytes with the encapsulation header.
    pub data: Vec<u8>,
}

/// Every message of a complete recording in log-time order (stable: file order on ties), with the checks of
/// [`info`]: missing, non-MCAP, cut and foreign-schema files are errors.
pub fn messages(path: &Path) -> Result<Vec<Message>, RecordError> {
    let (_, _) = open_checked(path)?;
    let bytes = std::fs::read(path).map_err(|e| RecordError::io(path, e))?;
    let scan = scan(&bytes, false).map_err(|e| corrupt(path, e))?;
    let mut topics = BTreeMap::new();
    for (id, ch) in &scan.channels {
        let schema = scan.schemas.get(&ch.schema_id);
        check_channel(
            path,
            &ch.topic,
            schema.map(|s| (s.name.as_str(), s.encoding.as_str())),
            &ch.message_encoding,
        )?;
        let type_name = schema.map(|s| s.name.clone()).unwrap_or_default();
        topics.insert(*id, (ch.topic.clone(), type_name));
    }
    let mut messages = scan.messages;
    // log-time order (a recorder serving several readers may write a little out of order)
    messages.sort_by_key(|m| m.header.log_time);
    let mut out = Vec::with_capacity(messages.len());
    for m in messages {
        let Some((topic, type_name)) = topics.get(&m.header.channel_id) else {
            return Err(corrupt(
                path,
                McapError::UnknownChannel(m.header.sequence, m.header.channel_id),
            ));
        };
        out.push(Message {
            topic: topic.clone(),
            type_name: type_name.clone(),
            sequence: m.header.sequence,
            log_time: m.header.log_time,
            publish_time: m.header.publish_time,
            data: m.data,
        });
    }
    Ok(out)
}
