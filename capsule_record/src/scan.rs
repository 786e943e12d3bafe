//! A linear scan of every record of an MCAP file in memory: files without a summary, replay,
//! and the tools' own checks.

use std::collections::BTreeMap;

use mcap::{
    records::{self, Record},
    McapError, MAGIC,
};

/// A schema record as stored.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaRec {
    /// `pkg/msg/Type`.
    pub name: String,
    /// `ros2msg`.
    pub encoding: String,
    /// The schema text.
    pub data: Vec<u8>,
}

/// Keeps a schema or channel record (the first one of each id; a recovered or split file may
/// repeat them); any other record is left alone.
pub(crate) fn keep_definition(
    schemas: &mut BTreeMap<u16, SchemaRec>,
    channels: &mut BTreeMap<u16, records::Channel>,
    rec: Record<'_>,
) {
    match rec {
        Record::Schema { header, data } => {
            schemas.entry(header.id).or_insert(SchemaRec {
                name: header.name,
                encoding: header.encoding,
                data: data.into_owned(),
            });
        }
        Record::Channel(c) => {
            channels.entry(c.id).or_insert(c);
        }
        _ => {}
    }
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

/// Largest uncompressed chunk this crate inflates (the writer closes chunks at 4 MiB).
pub const MAX_CHUNK_BYTES: u64 = 256 << 20;

fn bad_chunk(declared: u64, available: u64) -> McapError {
    McapError::BadChunkLength {
        header: declared,
        available,
    }
}

/// The uncompressed bytes of a chunk, at most its declared size (refused if implausible for
/// its compressed size), checked against its CRC when it has one.
fn inflate(header: &records::ChunkHeader, data: &[u8]) -> Result<Vec<u8>, McapError> {
    use std::io::Read;
    let declared = header.uncompressed_size;
    let available = data.len() as u64;
    let out = match header.compression.as_str() {
        "" if declared == available => data.to_vec(),
        "" => return Err(bad_chunk(declared, available)),
        kind => {
            // a damaged size must not become an allocation: bounded by a plausible ratio
            if declared > MAX_CHUNK_BYTES || declared > available.saturating_mul(1024) + (1 << 20) {
                return Err(bad_chunk(declared, available));
            }
            let mut out = Vec::with_capacity(declared as usize);
            let read = match kind {
                "zstd" => zstd::stream::read::Decoder::new(data)
                    .and_then(|d| d.take(declared + 1).read_to_end(&mut out)),
                "lz4" => {
                    lz4::Decoder::new(data).and_then(|d| d.take(declared + 1).read_to_end(&mut out))
                }
                other => return Err(McapError::UnsupportedCompression(other.to_string())),
            };
            read.map_err(|_| McapError::DecompressionError(kind.to_string()))?;
            if out.len() as u64 != declared {
                return Err(bad_chunk(declared, out.len() as u64));
            }
            out
        }
    };
    if header.uncompressed_crc != 0 {
        let calculated = crc32fast::hash(&out);
        if calculated != header.uncompressed_crc {
            return Err(McapError::BadChunkCrc {
                saved: header.uncompressed_crc,
                calculated,
            });
        }
    }
    Ok(out)
}

/// The records of one chunk, all or none: decompressed (bounded), checked against its CRC,
/// each record's length checked against what is left before it is parsed.
pub fn chunk_records(
    header: records::ChunkHeader,
    data: &[u8],
) -> Result<Vec<Record<'static>>, McapError> {
    let bytes = inflate(&header, data)?;
    let mut out = Vec::new();
    let mut at = 0usize;
    while at < bytes.len() {
        let head = bytes.get(at..at + 9).ok_or(McapError::UnexpectedEoc)?;
        let mut len8 = [0u8; 8];
        len8.copy_from_slice(&head[1..9]);
        let body = usize::try_from(u64::from_le_bytes(len8))
            .ok()
            .and_then(|l| (at + 9).checked_add(l))
            .filter(|end| *end <= bytes.len())
            .ok_or(McapError::UnexpectedEoc)?;
        out.push(mcap::parse_record(head[0], &bytes[at + 9..body])?.into_owned());
        at = body;
    }
    Ok(out)
}

/// Reads every record of a complete MCAP file in memory (chunks unpacked); any damage is an
/// error.
pub fn scan(bytes: &[u8]) -> Result<Scan, McapError> {
    if !bytes.starts_with(MAGIC) {
        return Err(McapError::BadMagic);
    }
    let mut out = Scan::default();
    for rec in mcap::read::LinearReader::new(bytes)? {
        match rec? {
            Record::Chunk { header, data } => {
                for x in chunk_records(header, &data)? {
                    take(&mut out, x);
                }
                out.chunks += 1;
            }
            rec @ Record::Footer(_) => {
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
        Record::Schema { .. } | Record::Channel(_) => {
            keep_definition(&mut out.schemas, &mut out.channels, rec)
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
