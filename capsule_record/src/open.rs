//! Opening a recording: checks that it is an MCAP file with both magics, reads records at
//! offsets the summary gives, and checks that a channel is ROS 2 (`ros2msg` / `cdr`).

use std::{
    fs::File,
    io::{Read, Seek, SeekFrom},
    path::Path,
};

use mcap::{
    records::{self, Record},
    McapError, MAGIC,
};

use crate::RecordError;

pub(crate) fn corrupt(path: &Path, e: McapError) -> RecordError {
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
pub(crate) fn open_checked(path: &Path) -> Result<(File, u64), RecordError> {
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

pub(crate) fn read_at(
    f: &mut File,
    path: &Path,
    offset: u64,
    len: u64,
) -> Result<Vec<u8>, RecordError> {
    // an index pointing past the end of the file is damage, not an allocation to attempt
    let size = f.metadata().map_err(|e| RecordError::io(path, e))?.len();
    if offset.checked_add(len).is_none_or(|end| end > size) {
        return Err(corrupt(path, McapError::BadIndex));
    }
    let mut buf = vec![0u8; len as usize];
    f.seek(SeekFrom::Start(offset))
        .and_then(|_| f.read_exact(&mut buf))
        .map_err(|e| RecordError::io(path, e))?;
    Ok(buf)
}

/// Parses one whole record (opcode, length, body) from `buf`.
pub(crate) fn parse_whole(buf: &[u8]) -> Result<Record<'_>, McapError> {
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

pub(crate) fn read_header(f: &mut File, path: &Path) -> Result<records::Header, RecordError> {
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

pub(crate) fn check_channel(
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
