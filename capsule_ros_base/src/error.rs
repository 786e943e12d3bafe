//! The library's error ([`NodeError`]): an input we refuse, naming it and the reason, or a step
//! that failed, naming the step and keeping the error that stopped it as its source. The
//! binaries turn it into `anyhow` at the top; [`chain`] prints the step and its sources on one
//! line, as anyhow's `{:#}` does.

use std::fmt::Display;

/// Any error kept as the source of a [`NodeError::Failed`].
pub type BoxError = Box<dyn std::error::Error + Send + Sync + 'static>;

/// An error of the capsule nodes' library.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// An input (a flag, an environment variable, a params file, a request) that is refused:
    /// the message names the input and says why.
    #[error("{0}")]
    Invalid(String),
    /// A step that failed (a DDS endpoint, a file, the runtime): `what` names the step,
    /// `source` is the error that stopped it.
    #[error("{what}")]
    Failed {
        /// The step, and the input it worked on.
        what: String,
        /// Why it failed.
        #[source]
        source: BoxError,
    },
    /// Writing a recording failed (the file, its encoding).
    #[error(transparent)]
    Record(#[from] capsule_record::RecordError),
    /// The CPUs of `--cpu-affinity` (the allowed set could not be read, or pinning failed).
    #[error(transparent)]
    Affinity(#[from] crate::affinity::AffinityError),
}

/// An error and its sources on one line, joined by `: ` (what anyhow's `{:#}` prints).
pub fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut line = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        line.push_str(&format!(": {s}"));
        source = s.source();
    }
    line
}

/// A result whose error is a [`NodeError`].
pub type Result<T, E = NodeError> = std::result::Result<T, E>;

/// Names the step that failed: turns an error into [`NodeError::Failed`] with it as the
/// source, or a missing value into [`NodeError::Invalid`].
pub trait Context<T> {
    /// The step, known beforehand.
    fn context(self, what: impl Display) -> Result<T>;
    /// The step, formatted only on failure.
    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: Into<BoxError>> Context<T> for std::result::Result<T, E> {
    fn context(self, what: impl Display) -> Result<T> {
        self.with_context(|| what)
    }

    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| NodeError::Failed {
            what: what().to_string(),
            source: e.into(),
        })
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, what: impl Display) -> Result<T> {
        self.with_context(|| what)
    }

    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.ok_or_else(|| NodeError::Invalid(what().to_string()))
    }
}

/// Returns [`NodeError::Invalid`] with the formatted message (the input and the reason).
#[doc(hidden)]
#[macro_export]
macro_rules! __node_error_bail {
    ($($message:tt)*) => {
        return Err($crate::error::NodeError::Invalid(format!($($message)*)))
    };
}
/// Returns [`NodeError::Invalid`] with the formatted message (the input and the reason).
pub use crate::__node_error_bail as bail;

/// [`NodeError::Invalid`] with the formatted message, as a value.
#[doc(hidden)]
#[macro_export]
macro_rules! __node_error_invalid {
    ($($message:tt)*) => {
        $crate::error::NodeError::Invalid(format!($($message)*))
    };
}
/// [`NodeError::Invalid`] with the formatted message, as a value.
pub use crate::__node_error_invalid as invalid;
