//! Errors of reading and writing recordings: each names the file and says what to do.

use std::path::PathBuf;

/// What went wrong with a recording.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file does not exist.
    #[error("{}: no such file", .0.display())]
    Missing(PathBuf),
    /// An I/O error on the file (permission, full disk, ...).
    #[error("{}: {cause}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, not a separate source: printed once).
        cause: std::io::Error,
    },
    /// The file does not start with the MCAP magic bytes.
    #[error("{}: not an MCAP file (it does not start with the MCAP magic bytes)", .0.display())]
    NotMcap(PathBuf),
    /// The file has no footer: the recording was cut short.
    #[error("{}: truncated MCAP file (no footer: the recording was cut short); `capsule record recover {}` rebuilds a complete file from what it holds", .0.display(), .0.display())]
    Truncated(PathBuf),
    /// The MCAP structure is damaged.
    #[error("{}: damaged MCAP file: {cause}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What the MCAP reader found.
        cause: mcap::McapError,
    },
    /// A channel refers to a schema the file does not hold or this tool cannot read.
    #[error("{}: topic {topic}: {reason}", path.display())]
    UnknownSchema {
        /// The file.
        path: PathBuf,
        /// The channel's topic.
        topic: String,
        /// What is wrong with its schema.
        reason: String,
    },
    /// Writing failed (full disk, unwritable path, ...): the recording stops here.
    #[error("writing {}: {cause}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        cause: mcap::McapError,
    },
    /// A message's bytes are not valid CDR for its type.
    #[error("CDR: {0}")]
    Cdr(String),
    /// Misuse of the writer (unknown type or channel).
    #[error("{0}")]
    Usage(String),
}

impl RecordError {
    /// Maps an I/O error on `path`, turning "not found" into [`RecordError::Missing`].
    pub fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        if source.kind() == std::io::ErrorKind::NotFound {
            RecordError::Missing(path.to_path_buf())
        } else {
            RecordError::Io {
                path: path.to_path_buf(),
                cause: source,
            }
        }
    }
}
