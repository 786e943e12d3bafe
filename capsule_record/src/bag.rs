//! Recordings as rosbag2 users configure them: chunk compression, and splitting by size or
//! by recorded time into numbered files `NAME_0.mcap`, `NAME_1.mcap`, ... in a directory
//! `NAME/` with one rosbag2 `metadata.yaml` (format version 8, as `ros2 bag info` and
//! `rosbags` read it). Without a split limit a recording is one file, as before.

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
};

use crate::{
    info::{info, InfoSource, RecordingInfo},
    metadata_yaml::{metadata_yaml, relative_file_paths, BagFile, BagTopic, METADATA_YAML},
    profile::QOS_KEY,
    types::OfferedQos,
    writer::{topic_channel, ChunkCompression, RecordWriter, WriteSummary, WriterOptions},
    ChannelId, RecordError,
};

/// How a recording is stored: one options struct for every recorder (node, plant, simulate).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BagOptions {
    /// Chunk compression.
    pub compression: ChunkCompression,
    /// Start the next file once the current one holds about this many bytes.
    pub max_bytes: Option<u64>,
    /// Start the next file once the current one spans this much log time (ns).
    pub max_duration_ns: Option<u64>,
}

impl BagOptions {
    /// The recording is split into numbered files in a directory.
    pub fn splits(&self) -> bool {
        self.max_bytes.is_some() || self.max_duration_ns.is_some()
    }
}

struct ChannelSpec {
    topic: String,
    type_name: String,
    schema: Vec<u8>,
    metadata: BTreeMap<String, String>,
    count: u64,
}

/// Writes a recording: one file, or numbered files in a directory when [`BagOptions`] asks for
/// splitting. Channel ids stay the same across files.
pub struct BagWriter {
    /// The bag directory when splitting.
    dir: Option<PathBuf>,
    stem: String,
    options: WriterOptions,
    bag: BagOptions,
    channels: Vec<ChannelSpec>,
    current: RecordWriter,
    /// The current file's channel ids, by [`ChannelId`] index.
    ids: Vec<ChannelId>,
    file_start_ns: Option<u64>,
    files: Vec<BagFile>,
}

impl std::fmt::Debug for BagWriter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("path", &self.path())
            .field("files", &self.files.len())
            .finish_non_exhaustive()
    }
}

impl BagWriter {
    /// Creates the recording at `path` (a file; when splitting, the directory `path` without
    /// its `.mcap` extension, refused if it exists, holding `<stem>_0.mcap`, ...).
    pub fn create(
        path: &Path,
        options: WriterOptions,
        bag: BagOptions,
    ) -> Result<Self, RecordError> {
        let options = WriterOptions {
            compression: bag.compression,
            ..options
        };
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "recording".into());
        let (dir, first) = if bag.splits() {
            let dir = path.with_extension("");
            std::fs::create_dir(&dir).map_err(|e| RecordError::io(&dir, e))?;
            let first = dir.join(format!("{stem}_0.mcap"));
            (Some(dir), first)
        } else {
            (None, path.to_path_buf())
        };
        let current = RecordWriter::create(&first, options.clone())?;
        Ok(BagWriter {
            dir,
            stem,
            options,
            bag,
            channels: Vec::new(),
            current,
            ids: Vec::new(),
            file_start_ns: None,
            files: Vec::new(),
        })
    }

    /// The recording: the file, or the bag directory when splitting.
    pub fn path(&self) -> &Path {
        self.dir.as_deref().unwrap_or(self.current.path())
    }

    /// Adds a channel of a type `capsule_record` knows, with the publisher's QoS.
    pub fn add_topic(
        &mut self,
        topic: &str,
        type_name: &str,
        qos: &OfferedQos,
    ) -> Result<ChannelId, RecordError> {
        let (schema, metadata) = topic_channel(topic, type_name, qos)?;
        let id = self
            .current
            .add_channel(topic, type_name, schema.as_bytes(), metadata.clone())?;
        self.ids.push(id);
        self.channels.push(ChannelSpec {
            topic: topic.to_string(),
            type_name: type_name.to_string(),
            schema: schema.into_bytes(),
            metadata,
            count: 0,
        });
        Ok(ChannelId((self.channels.len() - 1) as u16))
    }

    /// Writes one message (see [`RecordWriter::write`]), starting the next file first when
    /// the current one reached a split limit.
    pub fn write(
        &mut self,
        channel: ChannelId,
        sequence: u32,
        log_time: u64,
        publish_time: u64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        let start = *self.file_start_ns.get_or_insert(log_time);
        let full = self
            .bag
            .max_bytes
            .is_some_and(|m| self.current.bytes() >= m)
            || self
                .bag
                .max_duration_ns
                .is_some_and(|d| log_time.saturating_sub(start) >= d);
        if full && self.dir.is_some() && self.current.messages() > 0 {
            self.next_file()?;
            self.file_start_ns = Some(log_time);
        }
        let k = channel.0 as usize;
        let id = *self
            .ids
            .get(k)
            .ok_or_else(|| RecordError::Usage(format!("unknown channel {k}")))?;
        self.current
            .write(id, sequence, log_time, publish_time, data)?;
        if let Some(c) = self.channels.get_mut(k) {
            c.count += 1;
        }
        Ok(())
    }

    /// Closes the open chunk and hands it to the operating system.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.current.flush()
    }

    fn next_file(&mut self) -> Result<(), RecordError> {
        let Some(dir) = self.dir.clone() else {
            return Ok(());
        };
        let next = dir.join(format!("{}_{}.mcap", self.stem, self.files.len() + 1));
        let mut w = RecordWriter::create(&next, self.options.clone())?;
        let mut ids = Vec::new();
        for c in &self.channels {
            ids.push(w.add_channel(&c.topic, &c.type_name, &c.schema, c.metadata.clone())?);
        }
        let done = std::mem::replace(&mut self.current, w);
        self.ids = ids;
        let summary = done.finish()?;
        self.files.push(bag_file(&summary));
        self.write_metadata(&dir)
    }

    fn write_metadata(&self, dir: &Path) -> Result<(), RecordError> {
        write_metadata(&self.channels, &self.files, &self.options.ros_distro, dir)
    }

    /// Finishes the last file and, when splitting, writes `metadata.yaml`. The summary covers
    /// the whole recording (its path is the directory when splitting).
    pub fn finish(mut self) -> Result<WriteSummary, RecordError> {
        let last = self.current.finish()?;
        let Some(dir) = self.dir.take() else {
            return Ok(last);
        };
        self.files.push(bag_file(&last));
        write_metadata(&self.channels, &self.files, &self.options.ros_distro, &dir)?;
        let mut per_topic = BTreeMap::new();
        for c in &self.channels {
            *per_topic.entry(c.topic.clone()).or_insert(0) += c.count;
        }
        Ok(WriteSummary {
            path: dir,
            messages: self.files.iter().map(|f| f.messages).sum(),
            bounds: self
                .files
                .iter()
                .filter_map(|f| f.bounds)
                .reduce(|a, b| (a.0.min(b.0), a.1.max(b.1))),
            per_topic,
        })
    }
}

/// Writes `metadata.yaml` (through a temporary file and a rename: never half written).
fn write_metadata(
    channels: &[ChannelSpec],
    files: &[BagFile],
    ros_distro: &str,
    dir: &Path,
) -> Result<(), RecordError> {
    let topics: Vec<BagTopic> = channels
        .iter()
        .map(|c| BagTopic {
            topic: c.topic.clone(),
            type_name: c.type_name.clone(),
            qos_yaml: c.metadata.get(QOS_KEY).cloned().unwrap_or_default(),
            count: c.count,
        })
        .collect();
    let text = metadata_yaml(&topics, files, ros_distro);
    let path = dir.join(METADATA_YAML);
    let tmp = dir.join(".metadata.yaml.tmp");
    std::fs::write(&tmp, text)
        .and_then(|_| std::fs::rename(&tmp, &path))
        .map_err(|e| RecordError::io(&path, e))
}

fn bag_file(s: &WriteSummary) -> BagFile {
    BagFile {
        name: s
            .path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        bounds: s.bounds,
        messages: s.messages,
    }
}

/// The files of a split recording, in order, from its `metadata.yaml` (`relative_file_paths`).
/// `path` is the bag directory or its `metadata.yaml`.
pub fn bag_files(path: &Path) -> Result<Vec<PathBuf>, RecordError> {
    let (dir, yaml) = if path.is_dir() {
        (path.to_path_buf(), path.join(METADATA_YAML))
    } else {
        let dir = match path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        (dir, path.to_path_buf())
    };
    let text = std::fs::read_to_string(&yaml).map_err(|e| RecordError::io(&yaml, e))?;
    let names = relative_file_paths(&text).map_err(|e| RecordError::UnknownSchema {
        path: yaml.clone(),
        topic: "-".into(),
        reason: format!("not a rosbag2 metadata.yaml: {e}"),
    })?;
    let files: Vec<PathBuf> = names.iter().map(|n| dir.join(n)).collect();
    if files.is_empty() {
        return Err(RecordError::UnknownSchema {
            path: yaml,
            topic: "-".into(),
            reason: "no relative_file_paths: not a rosbag2 metadata.yaml".into(),
        });
    }
    Ok(files)
}

/// `capsule record info` of a split recording: each file's [`info`] summed (messages, chunks,
/// per-topic counts, size), the time span over all, mode changes in order, the scene and
/// metadata of the first file.
pub fn bag_info(path: &Path) -> Result<RecordingInfo, RecordError> {
    let files = bag_files(path)?;
    let mut all: Option<RecordingInfo> = None;
    for f in &files {
        let i = info(f)?;
        all = Some(match all {
            None => i,
            Some(mut a) => {
                a.size += i.size;
                a.messages += i.messages;
                a.chunks += i.chunks;
                if i.messages > 0 {
                    a.bounds = if a.messages == i.messages {
                        i.bounds
                    } else {
                        (a.bounds.0.min(i.bounds.0), a.bounds.1.max(i.bounds.1))
                    };
                }
                for t in i.topics {
                    match a.topics.iter_mut().find(|x| x.topic == t.topic) {
                        Some(x) => x.count += t.count,
                        None => a.topics.push(t),
                    }
                }
                a.mode_changes.extend(i.mode_changes);
                if i.source == InfoSource::Scan {
                    a.source = InfoSource::Scan;
                }
                a
            }
        });
    }
    let mut a = all.ok_or_else(|| RecordError::Missing(path.to_path_buf()))?;
    a.path = path.to_path_buf();
    a.files = files.len() as u64;
    a.mode_changes.sort_by_key(|m| m.log_time);
    Ok(a)
}
