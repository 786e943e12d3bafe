//! `capsule record recover`: rebuilds a complete recording from a damaged one, as the `mcap
//! recover` tool does: every intact chunk is kept, wherever it lies; a damaged chunk (a
//! flipped bit fails its CRC or its decompression) is skipped and reading goes on after it;
//! when a record's length itself is damaged, reading resumes at the next intact chunk; a cut
//! file (a killed writer, an open chunk with a placeholder length) ends at its last intact
//! record. The `ros2` profile, schemas, channels (with their QoS), metadata and attachments are
//! written again with a fresh summary, chunks compressed as the input's were. Schemas written
//! with the old `MSG: pkg/msg/Type` spelling are rewritten as rosbag2 writes them (Foxglove
//! reads them).

use std::{
    collections::BTreeMap,
    path::{Path, PathBuf},
};

use mcap::{
    records::{self, Record},
    McapError, MAGIC,
};

use crate::{
    fix_schemas::respell_dependencies,
    profile::{CAPSULE_METADATA, ROSBAG2_METADATA},
    scan::{chunk_records, keep_definition, SchemaRec},
    writer::{ChunkCompression, RecordWriter, WriterOptions},
    ChannelId, RecordError,
};

/// What recovery saved.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Recovered {
    /// The complete file written.
    pub output: PathBuf,
    /// Messages saved.
    pub messages: u64,
    /// Messages per topic.
    pub per_topic: BTreeMap<String, u64>,
    /// The input ended with a footer and its end magic (it was not cut).
    pub was_complete: bool,
    /// Messages the input's own summary lists, when it has a readable one.
    pub summary_messages: Option<u64>,
    /// Intact chunks copied.
    pub chunks_kept: u64,
    /// Damaged chunks (or stretches of damaged bytes) skipped.
    pub chunks_dropped: u64,
    /// What was damaged and what was done about it, one line each.
    pub damage: Vec<String>,
    /// Bytes skipped to find the next intact record after a damaged length.
    pub bytes_skipped: u64,
    /// Messages on channels whose definition was lost with a damaged chunk.
    pub orphans: u64,
    /// Why reading ended before the footer (the cut point), if it did.
    pub cut: Option<String>,
    /// First and last log time of the saved messages (ns).
    pub bounds: Option<(u64, u64)>,
    /// Schemas whose `MSG:` blocks were renamed to their fields' spelling (files written
    /// before capsule wrote them as rosbag2 does; see [`crate::fix_schemas`]).
    pub schemas_respelled: Vec<String>,
}

/// The length a chunk record's own fields give (opcode and length prefix included): start and
/// end times, uncompressed size and CRC, compression name, records.
fn chunk_len(header: &records::ChunkHeader, data: &[u8]) -> usize {
    9 + 8 + 8 + 8 + 4 + 4 + header.compression.len() + 8 + data.len()
}

/// One top-level record found at `offset` with its total length (opcode + length + body). A
/// chunk is parsed from its own fields, whatever its length prefix says (a flipped bit there
/// would otherwise lose an intact chunk and the ones after it): the second value tells
/// whether the prefix disagreed.
fn record_at(bytes: &[u8], offset: usize) -> Result<(Record<'_>, usize, bool), McapError> {
    let head = bytes
        .get(offset..offset.saturating_add(9))
        .filter(|h| h.len() == 9)
        .ok_or(McapError::UnexpectedEof)?;
    let mut len8 = [0u8; 8];
    len8.copy_from_slice(&head[1..9]);
    let len = u64::from_le_bytes(len8);
    let body_start = offset + 9;
    if head[0] == OP_CHUNK {
        let rest = bytes.get(body_start..).unwrap_or_default();
        if let Ok(Record::Chunk { header, data }) = mcap::parse_record(OP_CHUNK, rest) {
            let own = chunk_len(&header, &data);
            let damaged = own as u64 != len.saturating_add(9);
            return Ok((Record::Chunk { header, data }, own, damaged));
        }
    }
    let end = usize::try_from(len)
        .ok()
        .and_then(|l| body_start.checked_add(l))
        .filter(|e| *e <= bytes.len())
        .ok_or(McapError::UnexpectedEof)?;
    let rec = mcap::parse_record(head[0], &bytes[body_start..end])?;
    Ok((rec, end - offset, false))
}

const OP_CHUNK: u8 = 0x06;

/// The next offset after `from` where an intact chunk starts (its records decode and its CRC
/// holds), or `None`. Only chunks count: inside an uncompressed chunk every message looks like
/// a top-level record too.
fn resync(bytes: &[u8], from: usize) -> Option<usize> {
    (from..bytes.len().saturating_sub(9)).find(|&at| {
        bytes[at] == OP_CHUNK
            && match record_at(bytes, at) {
                Ok((Record::Chunk { header, data }, ..)) => chunk_records(header, &data).is_ok(),
                _ => false,
            }
    })
}

/// Everything needed to write the output, gathered as the input is read.
struct Rebuild<'a> {
    output: &'a Path,
    writer: Option<RecordWriter>,
    /// Metadata and attachments seen before the writer exists (it is made at the first
    /// chunk, once the original `capsule` record and the chunks' compression are known).
    pending_metadata: Vec<records::Metadata>,
    pending_attachments: Vec<(records::AttachmentHeader, Vec<u8>)>,
    schemas: BTreeMap<u16, SchemaRec>,
    channels: BTreeMap<u16, records::Channel>,
    written: BTreeMap<u16, (ChannelId, String)>,
    out: Recovered,
}

impl Rebuild<'_> {
    fn writer(&mut self, compression: &str) -> Result<&mut RecordWriter, RecordError> {
        if self.writer.is_none() {
            let created_ns = self
                .pending_metadata
                .iter()
                .find(|m| m.name == CAPSULE_METADATA)
                .and_then(|m| m.metadata.get("created_ns"))
                .and_then(|s| s.parse().ok())
                .unwrap_or_else(crate::writer::now_ns);
            let mut w = RecordWriter::create(
                self.output,
                WriterOptions {
                    created_ns,
                    flush_interval_ns: u64::MAX,
                    compression: ChunkCompression::like(compression),
                    ..WriterOptions::default()
                },
            )?;
            for m in self.pending_metadata.drain(..) {
                // the writer wrote its own `capsule` record; the original's keys follow it
                if m.name != ROSBAG2_METADATA {
                    w.write_metadata(&m.name, m.metadata)?;
                }
            }
            for (h, data) in self.pending_attachments.drain(..) {
                w.attach(&h.name, &h.media_type, h.log_time, &data)?;
            }
            self.writer = Some(w);
        }
        self.writer
            .as_mut()
            .ok_or_else(|| RecordError::Usage("no writer".into()))
    }

    fn take(&mut self, rec: Record<'_>, compression: &str) -> Result<(), RecordError> {
        match rec {
            Record::Schema { .. } | Record::Channel(_) => {
                keep_definition(&mut self.schemas, &mut self.channels, rec)
            }
            Record::Message { header, data } => {
                let Some(id) = self.channel(header.channel_id, compression)? else {
                    self.out.orphans += 1;
                    return Ok(());
                };
                let w = self.writer(compression)?;
                w.write(
                    id,
                    header.sequence,
                    header.log_time,
                    header.publish_time,
                    &data,
                )?;
            }
            Record::Metadata(m) => match self.writer.as_mut() {
                Some(w) if m.name != ROSBAG2_METADATA => w.write_metadata(&m.name, m.metadata)?,
                Some(_) => {}
                None => self.pending_metadata.push(m),
            },
            Record::Attachment { header, data, .. } => match self.writer.as_mut() {
                Some(w) => w.attach(&header.name, &header.media_type, header.log_time, &data)?,
                None => self.pending_attachments.push((header, data.into_owned())),
            },
            _ => {}
        }
        Ok(())
    }

    /// The output channel of input channel `id`, added on its first message; `None` when the
    /// input's definition of the channel or its schema was lost.
    fn channel(&mut self, id: u16, compression: &str) -> Result<Option<ChannelId>, RecordError> {
        if let Some((new, _)) = self.written.get(&id) {
            return Ok(Some(*new));
        }
        let Some(ch) = self.channels.get(&id).cloned() else {
            return Ok(None);
        };
        let Some(schema) = self.schemas.get(&ch.schema_id).cloned() else {
            return Ok(None);
        };
        let respelled = std::str::from_utf8(&schema.data)
            .ok()
            .and_then(|text| respell_dependencies(&schema.name, text));
        let data = match &respelled {
            Some(text) => {
                if !self.out.schemas_respelled.contains(&schema.name) {
                    self.out.schemas_respelled.push(schema.name.clone());
                }
                text.as_bytes()
            }
            None => &schema.data[..],
        };
        let w = self.writer(compression)?;
        let new = w.add_channel(&ch.topic, &schema.name, data, ch.metadata.clone())?;
        self.written.insert(id, (new, ch.topic.clone()));
        Ok(Some(new))
    }

    /// Takes the schemas and channels of the summary, when the footer is intact: it defines
    /// every one, also those whose first definition was in a damaged chunk.
    fn take_summary(&mut self, bytes: &[u8]) {
        let summary = mcap::read::Summary::read(bytes).ok().flatten();
        if let Some(s) = &summary {
            self.out.summary_messages = s.stats.as_ref().map(|st| st.message_count);
            for (id, ch) in &s.channels {
                if let Some(schema) = &ch.schema {
                    self.schemas.entry(schema.id).or_insert(SchemaRec {
                        name: schema.name.clone(),
                        encoding: schema.encoding.clone(),
                        data: schema.data.to_vec(),
                    });
                }
                self.channels.entry(*id).or_insert(records::Channel {
                    id: *id,
                    schema_id: ch.schema.as_ref().map(|s| s.id).unwrap_or(0),
                    topic: ch.topic.clone(),
                    message_encoding: ch.message_encoding.clone(),
                    metadata: ch.metadata.clone(),
                });
            }
        }
    }

    /// Takes every intact record of the data section, skipping damaged chunks to the next
    /// intact one; the compression of the first chunk kept.
    fn take_data(&mut self, bytes: &[u8]) -> Result<String, RecordError> {
        let mut compression = String::new();
        let mut at = MAGIC.len();
        loop {
            let (rec, len) = match record_at(bytes, at) {
                Ok((rec, len, prefix_damaged)) => {
                    if prefix_damaged {
                        self.out.damage.push(format!(
                            "chunk at offset {at}: damaged length prefix, read by its own fields"
                        ));
                    }
                    (rec, len)
                }
                Err(e) => {
                    // a damaged or cut record: go on at the next intact chunk, if any
                    match resync(bytes, at + 1) {
                        Some(next) => {
                            self.out.bytes_skipped += (next - at) as u64;
                            self.out.chunks_dropped += 1;
                            self.out.damage.push(format!(
                                "skipped {} bytes at offset {at} to the next intact chunk: {e}",
                                next - at
                            ));
                            at = next;
                            continue;
                        }
                        None => {
                            self.out.cut = Some(format!("at offset {at} of {}: {e}", bytes.len()));
                            break;
                        }
                    }
                }
            };
            match rec {
                Record::Chunk { header, data } => {
                    let kind = header.compression.clone();
                    match chunk_records(header, &data) {
                        Ok(inner) => {
                            if self.out.chunks_kept == 0 {
                                compression = kind;
                            }
                            self.out.chunks_kept += 1;
                            for x in inner {
                                self.take(x, &compression)?;
                            }
                        }
                        Err(e) => {
                            self.out.chunks_dropped += 1;
                            self.out
                                .damage
                                .push(format!("skipped the chunk at offset {at}: {e}"));
                        }
                    }
                }
                Record::DataEnd(_) => {
                    // the summary section follows: its records repeat what the data held
                    self.out.was_complete =
                        bytes.ends_with(MAGIC) && bytes.len() >= 2 * MAGIC.len();
                    break;
                }
                Record::Footer(_) => {
                    self.out.was_complete = true;
                    break;
                }
                other => self.take(other, &compression)?,
            }
            at += len;
        }
        Ok(compression)
    }
}

/// Reads `input` keeping every intact chunk and writes a complete `ros2`-profile file to
/// `output`, which must not exist (`input == output` is refused: write elsewhere, then
/// rename). A valid input loses nothing.
pub fn recover(input: &Path, output: &Path) -> Result<Recovered, RecordError> {
    if input == output {
        return Err(RecordError::Usage(format!(
            "{}: recovery writes a new file; give another output path",
            input.display()
        )));
    }
    let bytes = std::fs::read(input).map_err(|e| RecordError::io(input, e))?;
    if !bytes.starts_with(MAGIC) {
        return Err(RecordError::NotMcap(input.to_path_buf()));
    }
    let mut r = Rebuild {
        output,
        writer: None,
        pending_metadata: Vec::new(),
        pending_attachments: Vec::new(),
        schemas: BTreeMap::new(),
        channels: BTreeMap::new(),
        written: BTreeMap::new(),
        out: Recovered {
            output: output.to_path_buf(),
            ..Recovered::default()
        },
    };
    r.take_summary(&bytes);
    let compression = r.take_data(&bytes)?;
    r.writer(&compression)?;
    let Some(w) = r.writer.take() else {
        return Err(RecordError::Usage("no writer".into()));
    };
    let summary = w.finish()?;
    r.out.messages = summary.messages;
    r.out.bounds = summary.bounds;
    r.out.per_topic = summary.per_topic;
    Ok(r.out)
}
