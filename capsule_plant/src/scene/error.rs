//! Why a scene is refused: [`SceneError`] (file, key, reason), [`Invalid`] (key, reason) and
//! [`Fault`] (the reason).

use crate::model::Friction;
use crate::number_text::short;
use crate::solver::Method;
use thiserror::Error;

/// A scene refused: which file, which key, why.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}: {key}: {reason}")]
pub struct SceneError {
    /// The file (or other source name) the scene came from.
    pub file: String,
    /// The key, as a dotted path (`capsule.gamma`), or `(syntax)` when the text is not TOML.
    pub key: String,
    /// Why.
    pub reason: Fault,
}

/// A value of a scene refused by [`Scene::validate`](super::Scene::validate): which key, why.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{key}: {reason}")]
pub struct Invalid {
    /// The key, as a dotted path (`capsule.gamma`).
    pub key: String,
    /// Why.
    pub reason: Fault,
}

impl Invalid {
    pub(crate) fn new(key: impl Into<String>, reason: Fault) -> Self {
        Invalid {
            key: key.into(),
            reason,
        }
    }

    /// The same refusal, naming the file it came from.
    pub fn in_file(self, file: &str) -> SceneError {
        SceneError {
            file: file.to_string(),
            key: self.key,
            reason: self.reason,
        }
    }
}

/// Why a scene (or one of its values) is refused.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Fault {
    /// The file could not be read (the reader's message).
    #[error("cannot read: {0}")]
    Unreadable(String),
    /// The bytes are not UTF-8 text.
    #[error("not a text file (a scene is UTF-8 TOML)")]
    NotText,
    /// The text is not TOML (also: a key given twice).
    #[error("not valid TOML: {message}{}", at_line(*.line))]
    Syntax {
        /// The TOML parser's message.
        message: String,
        /// Where, when known.
        line: Option<usize>,
    },
    /// Valid TOML, but a key this format does not have or a value of the wrong type.
    #[error("{message}{}", at_line(*.line))]
    Shape {
        /// The reader's message (`unknown field`, `invalid type`).
        message: String,
        /// Where, when known.
        line: Option<usize>,
    },
    /// NaN or infinite.
    #[error("must be a finite number (got {})", num(*.0))]
    NotFinite(f64),
    /// Zero or negative where only positive values mean something.
    #[error("must be > 0 (got {})", num(*.0))]
    NotPositive(f64),
    /// Negative.
    #[error("must be >= 0 (got {})", num(*.0))]
    Negative(f64),
    /// A value outside a closed range.
    #[error("must be in [{}, {}] (got {})", short(*.min), short(*.max), num(*.got))]
    OutOfRange {
        /// The value given.
        got: f64,
        /// Smallest allowed.
        min: f64,
        /// Largest allowed.
        max: f64,
    },
    /// A tolerance outside (0, 1).
    #[error("must be in (0, 1) (got {})", num(*.0))]
    NotInOpenUnit(f64),
    /// A count that is fractional, too small or too large.
    #[error("must be a whole number from {min} to {max} (got {got})")]
    NotACount {
        /// The value given.
        got: String,
        /// Smallest allowed.
        min: u32,
        /// Largest allowed.
        max: u32,
    },
    /// The transient is not shorter than the run.
    #[error(
        "must be less than horizon.periods = {periods} (got {transient}): lower the transient, \
         raise the periods, or leave the transient out to scale it with the periods"
    )]
    TransientNotBelowPeriods {
        /// Leading periods not measured.
        transient: u32,
        /// Periods in all.
        periods: u32,
    },
    /// An initial state without exactly four numbers.
    #[error("must hold exactly 4 numbers x1, y1, x2, y2 (got {0})")]
    StateLength(usize),
    /// A friction law this model does not have.
    #[error("unknown law `{0}` ({laws})", laws = Friction::names())]
    UnknownLaw(String),
    /// An integration method this solver does not have.
    #[error("unknown method `{0}` ({methods})", methods = Method::names())]
    UnknownMethod(String),
    /// A measured quantity a device cannot have.
    #[error("unknown quantity `{0}` (displacement, capsule_position, mass_velocity, capsule_velocity or contact)")]
    UnknownQuantity(String),
    /// A friction constant the chosen law does not use.
    #[error("not used by law `{0}`: remove it")]
    NotUsedByLaw(&'static str),
    /// The exact method with a law that is not piecewise linear.
    #[error("exact needs a piecewise-linear friction law (coulomb, viscous), not {0}")]
    ExactNeedsPiecewiseLinear(&'static str),
}

/// A number as a user reads it: plain, or in exponent form when very small or large.
fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

fn at_line(line: Option<usize>) -> String {
    line.map(|l| format!(" (line {l})")).unwrap_or_default()
}
