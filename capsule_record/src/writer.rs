//! The recording writer: one MCAP file in rosbag2's `ros2` profile, chunked and flushed often so
//! that a killed run leaves every closed chunk readable.

use std::{
    collections::BTreeMap,
    fs::{File, OpenOptions},
    io::BufWriter,
    path::{Path, PathBuf},
};

use mcap::{records::MessageHeader, WriteOptions};

use crate::{
    metadata_yaml::{metadata_yaml, BagFile, BagTopic},
    profile::{CAPSULE_METADATA, QOS_KEY, ROSBAG2_METADATA, SCENE_ATTACHMENT},
    types::{ros2msg_schema, OfferedQos},
    RecordError,
};

/// The scene a run used, stored with the recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SceneRecord {
    /// The scene's name (file stem unless the scene names itself).
    pub name: String,
    /// The scene file's text (TOML).
    pub toml: String,
}

/// How chunks are compressed: none, or rosbag2's MCAP storage choices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ChunkCompression {
    /// Uncompressed chunks (the default: cheapest to write).
    #[default]
    None,
    /// zstd at a level (0: the library's default, 3).
    Zstd {
        /// zstd level, 0-22.
        level: u32,
    },
    /// lz4 (frame format), the library's default level.
    Lz4,
}

impl ChunkCompression {
    /// The names `--compression` takes, as rosbag2 users know them.
    pub const NAMES: &'static str = "none, zstd, zstd_fast, zstd_small, lz4";

    /// rosbag2's `zstd_fast` preset: zstd at its fastest positive level (the mcap crate takes
    /// no negative levels).
    pub const ZSTD_FAST: ChunkCompression = ChunkCompression::Zstd { level: 1 };
    /// rosbag2's `zstd_small` preset: zstd at a slow, small level.
    pub const ZSTD_SMALL: ChunkCompression = ChunkCompression::Zstd { level: 19 };

    /// The compression a chunk record names (`zstd`, `lz4`, or empty), at default levels.
    pub fn like(chunk_compression: &str) -> ChunkCompression {
        match chunk_compression {
            "zstd" => ChunkCompression::Zstd { level: 0 },
            "lz4" => ChunkCompression::Lz4,
            _ => ChunkCompression::None,
        }
    }

    /// The name MCAP chunk records carry (`zstd`, `lz4`, or empty).
    pub fn chunk_name(&self) -> &'static str {
        match self {
            ChunkCompression::None => "",
            ChunkCompression::Zstd { .. } => "zstd",
            ChunkCompression::Lz4 => "lz4",
        }
    }
}

impl std::str::FromStr for ChunkCompression {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Ok(match s {
            "none" => ChunkCompression::None,
            "zstd" => ChunkCompression::Zstd { level: 0 },
            "zstd_fast" => ChunkCompression::ZSTD_FAST,
            "zstd_small" => ChunkCompression::ZSTD_SMALL,
            "lz4" => ChunkCompression::Lz4,
            other => {
                return Err(format!(
                    "unknown compression {other:?} (one of {})",
                    ChunkCompression::NAMES
                ))
            }
        })
    }
}

/// How to write a recording.
#[derive(Debug, Clone)]
pub struct WriterOptions {
    /// Chunk compression.
    pub compression: ChunkCompression,
    /// Close the open chunk once it holds this much log time (ns); bounds what a kill loses.
    pub flush_interval_ns: u64,
    /// Close the open chunk once it holds this many bytes.
    pub chunk_bytes: u64,
    /// The scene of the run, written as an attachment and metadata at the start.
    pub scene: Option<SceneRecord>,
    /// Wall-clock start of the recording (ns since the epoch), for the metadata.
    pub created_ns: u64,
    /// `ROS_DISTRO` written into the rosbag2 metadata record.
    pub ros_distro: String,
    /// Extra key/values for the `capsule` metadata record.
    pub extra_metadata: BTreeMap<String, String>,
    /// Replace an existing file instead of refusing it.
    pub overwrite: bool,
}

impl Default for WriterOptions {
    fn default() -> Self {
        WriterOptions {
            compression: ChunkCompression::None,
            flush_interval_ns: 500_000_000,
            chunk_bytes: 4 << 20,
            scene: None,
            created_ns: now_ns(),
            ros_distro: "jazzy".into(),
            extra_metadata: BTreeMap::new(),
            overwrite: false,
        }
    }
}

/// A topic's channel: the `ros2msg` schema of its type (one this crate knows) and the channel
/// metadata holding the publisher's QoS.
pub(crate) fn topic_channel(
    topic: &str,
    type_name: &str,
    qos: &OfferedQos,
) -> Result<(String, BTreeMap<String, String>), RecordError> {
    let schema = ros2msg_schema(type_name).ok_or_else(|| {
        RecordError::Usage(format!("{topic}: no ros2msg schema for type {type_name}"))
    })?;
    let mut metadata = BTreeMap::new();
    metadata.insert(QOS_KEY.to_string(), qos.to_yaml());
    Ok((schema, metadata))
}

/// Wall-clock time in nanoseconds since the epoch (0 if the clock is before it).
pub fn now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}

/// A channel of an open recording.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ChannelId(pub u16);

#[derive(Debug, Clone)]
struct TopicEntry {
    topic: String,
    type_name: String,
    qos_yaml: String,
    count: u64,
}

/// What a finished recording holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WriteSummary {
    /// The file.
    pub path: PathBuf,
    /// Messages written.
    pub messages: u64,
    /// First and last log time (ns), if any message.
    pub bounds: Option<(u64, u64)>,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
}

/// Writes one recording. Call [`RecordWriter::finish`] to end it properly; a writer dropped
/// without it (or a killed process) leaves a file that [`crate::recover()`] completes.
pub struct RecordWriter {
    path: PathBuf,
    mcap: mcap::Writer<BufWriter<File>>,
    options: WriterOptions,
    topics: BTreeMap<u16, TopicEntry>,
    chunk_start_ns: Option<u64>,
    bounds: Option<(u64, u64)>,
    messages: u64,
    bytes: u64,
}

impl std::fmt::Debug for RecordWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RecordWriter")
            .field("path", &self.path)
            .field("messages", &self.messages)
            .finish_non_exhaustive()
    }
}

impl RecordWriter {
    /// Creates the file (refusing an existing one unless `overwrite`), writes the `ros2` header,
    /// the scene attachment and the `capsule` metadata, and flushes them to disk.
    pub fn create(path: &Path, options: WriterOptions) -> Result<Self, RecordError> {
        let mut open = OpenOptions::new();
        open.write(true);
        if options.overwrite {
            open.create(true).truncate(true);
        } else {
            open.create_new(true);
        }
        let file = open.open(path).map_err(|e| RecordError::Io {
            path: path.to_path_buf(),
            cause: e,
        })?;
        let werr = |source| RecordError::Write {
            path: path.to_path_buf(),
            cause: source,
        };
        let (compression, level) = match options.compression {
            ChunkCompression::None => (None, 0),
            ChunkCompression::Zstd { level } => (Some(mcap::Compression::Zstd), level),
            ChunkCompression::Lz4 => (Some(mcap::Compression::Lz4), 0),
        };
        let mcap = WriteOptions::new()
            .profile("ros2")
            .library(format!(
                "capsule_record/{} (mcap-rust/{})",
                env!("CARGO_PKG_VERSION"),
                mcap::VERSION
            ))
            .compression(compression)
            .compression_level(level)
            // no worker threads: a chunk is compressed when it closes, in the writer's thread
            .compression_threads(0)
            .chunk_size(Some(options.chunk_bytes))
            .create(BufWriter::with_capacity(1 << 16, file))
            .map_err(werr)?;
        let mut w = RecordWriter {
            path: path.to_path_buf(),
            mcap,
            options,
            topics: BTreeMap::new(),
            chunk_start_ns: None,
            bounds: None,
            messages: 0,
            bytes: 0,
        };
        let mut meta = w.options.extra_metadata.clone();
        meta.insert("created_ns".into(), w.options.created_ns.to_string());
        if let Some(scene) = w.options.scene.clone() {
            meta.insert("scene_name".into(), scene.name.clone());
            let attachment = mcap::Attachment {
                log_time: w.options.created_ns,
                create_time: w.options.created_ns,
                name: SCENE_ATTACHMENT.into(),
                media_type: "application/toml".into(),
                data: std::borrow::Cow::Owned(scene.toml.into_bytes()),
            };
            w.mcap.attach(&attachment).map_err(werr)?;
        }
        w.write_metadata(CAPSULE_METADATA, meta)?;
        w.flush()?;
        Ok(w)
    }

    /// The file being written.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Messages written so far.
    pub fn messages(&self) -> u64 {
        self.messages
    }

    /// About how many bytes the file holds so far (messages as stored uncompressed, with their
    /// record and index overhead): what splitting by size compares.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    fn werr(&self, source: mcap::McapError) -> RecordError {
        RecordError::Write {
            path: self.path.clone(),
            cause: source,
        }
    }

    /// Adds a channel of a type this crate knows, with the publisher's QoS.
    pub fn add_topic(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: &OfferedQos,
    ) -> Result<ChannelId, RecordError> {
        let (schema, metadata) = topic_channel(topic, type_name, qos)?;
        self.add_channel(topic, type_name, schema.as_bytes(), metadata)
    }

    /// Adds a channel with a given `ros2msg` schema text and channel metadata (used by recovery).
    pub fn add_channel(
        &mut self,
        topic: &str,
        type_name: &str,
        schema: &[u8],
        metadata: BTreeMap<String, String>,
    ) -> Result<ChannelId, RecordError> {
        let schema_id = self
            .mcap
            .add_schema(type_name, "ros2msg", schema)
            .map_err(|e| self.werr(e))?;
        let id = self
            .mcap
            .add_channel(schema_id, topic, "cdr", &metadata)
            .map_err(|e| self.werr(e))?;
        self.topics.entry(id).or_insert_with(|| TopicEntry {
            topic: topic.to_string(),
            type_name: type_name.to_string(),
            qos_yaml: metadata.get(QOS_KEY).cloned().unwrap_or_default(),
            count: 0,
        });
        Ok(ChannelId(id))
    }

    /// Writes one message (CDR with its encapsulation header). Times in ns; `sequence` is the
    /// per-channel counter. Closes the chunk when it spans the flush interval of log time.
    pub fn write(
        &mut self,
        channel: ChannelId,
        sequence: u32,
        log_time: u64,
        publish_time: u64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        let entry = self
            .topics
            .get_mut(&channel.0)
            .ok_or_else(|| RecordError::Usage(format!("unknown channel {}", channel.0)))?;
        entry.count += 1;
        let header = MessageHeader {
            channel_id: channel.0,
            sequence,
            log_time,
            publish_time,
        };
        self.mcap
            .write_to_known_channel(&header, data)
            .map_err(|e| self.werr(e))?;
        self.messages += 1;
        // message record (opcode, length, channel, sequence, times) and its index entry
        self.bytes += data.len() as u64 + 31 + 16;
        self.bounds = Some(match self.bounds {
            None => (log_time, log_time),
            Some((a, b)) => (a.min(log_time), b.max(log_time)),
        });
        let start = *self.chunk_start_ns.get_or_insert(log_time);
        if log_time.saturating_sub(start) >= self.options.flush_interval_ns {
            self.flush()?;
        }
        Ok(())
    }

    /// Closes the open chunk and hands everything to the operating system (a killed process
    /// then loses nothing written before). Call it on a wall-clock timer too.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.chunk_start_ns = None;
        self.mcap.flush().map_err(|e| self.werr(e))
    }

    /// Writes a metadata record.
    pub fn write_metadata(
        &mut self,
        name: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), RecordError> {
        let m = mcap::records::Metadata {
            name: name.to_string(),
            metadata,
        };
        self.mcap.write_metadata(&m).map_err(|e| self.werr(e))
    }

    /// Writes an attachment.
    pub fn attach(
        &mut self,
        name: &str,
        media_type: &str,
        log_time: u64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        let a = mcap::Attachment {
            log_time,
            create_time: log_time,
            name: name.into(),
            media_type: media_type.into(),
            data: std::borrow::Cow::Borrowed(data),
        };
        self.mcap.attach(&a).map_err(|e| self.werr(e))
    }

    /// Writes the `rosbag2` metadata record, the summary (statistics, indexes) and the footer,
    /// and syncs the file to disk.
    pub fn finish(mut self) -> Result<WriteSummary, RecordError> {
        let rosbag2 = self.rosbag2_metadata();
        self.write_metadata(ROSBAG2_METADATA, rosbag2)?;
        self.mcap.finish().map_err(|e| self.werr(e))?;
        let path = self.path.clone();
        let buf = self.mcap.into_inner();
        let file = buf.into_inner().map_err(|e| RecordError::Io {
            path: path.clone(),
            cause: e.into_error(),
        })?;
        file.sync_all().map_err(|e| RecordError::Io {
            path: path.clone(),
            cause: e,
        })?;
        let mut per_topic = BTreeMap::new();
        for t in self.topics.values() {
            *per_topic.entry(t.topic.clone()).or_insert(0) += t.count;
        }
        Ok(WriteSummary {
            path,
            messages: self.messages,
            bounds: self.bounds,
            per_topic,
        })
    }

    /// The `rosbag2` metadata record: this file's `metadata.yaml` text, as rosbag2's MCAP
    /// storage writes it into each file.
    fn rosbag2_metadata(&self) -> BTreeMap<String, String> {
        let file = self
            .path
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        let topics: Vec<BagTopic> = self
            .topics
            .values()
            .map(|t| BagTopic {
                topic: t.topic.clone(),
                type_name: t.type_name.clone(),
                qos_yaml: t.qos_yaml.clone(),
                count: t.count,
            })
            .collect();
        let files = [BagFile {
            name: file,
            bounds: self.bounds,
            messages: self.messages,
        }];
        let mut m = BTreeMap::new();
        m.insert(
            "serialized_metadata".to_string(),
            metadata_yaml(&topics, &files, &self.options.ros_distro),
        );
        m.insert("ROS_DISTRO".to_string(), self.options.ros_distro.clone());
        m
    }
}
