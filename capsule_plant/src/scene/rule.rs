//! What a scene's number must be, and the check that refuses it with its key.

use super::error::{Fault, Invalid};

/// What a scene's number must be.
#[derive(Debug, Clone, Copy)]
pub enum Rule {
    /// Finite.
    Finite,
    /// Finite and > 0.
    Positive,
    /// Finite and >= 0.
    NonNegative,
    /// In (0, 1).
    Tolerance,
    /// In `[min, max]`.
    Within((f64, f64)),
}

impl Rule {
    /// `v`, the value of `key`, is refused with the key and why, or passes.
    pub fn check(self, key: &str, v: f64) -> Result<(), Invalid> {
        let fault = if !v.is_finite() {
            Fault::NotFinite(v)
        } else {
            match self {
                Rule::Finite => return Ok(()),
                Rule::Positive if v > 0.0 => return Ok(()),
                Rule::Positive => Fault::NotPositive(v),
                Rule::NonNegative if v >= 0.0 => return Ok(()),
                Rule::NonNegative => Fault::Negative(v),
                Rule::Tolerance if v > 0.0 && v < 1.0 => return Ok(()),
                Rule::Tolerance => Fault::NotInOpenUnit(v),
                Rule::Within((min, max)) if (min..=max).contains(&v) => return Ok(()),
                Rule::Within((min, max)) => Fault::OutOfRange { got: v, min, max },
            }
        };
        Err(Invalid::new(key, fault))
    }
}
