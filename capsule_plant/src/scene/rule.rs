//! What a scene's number must be, and the check that refuses it with its key; the rule of each
//! number under a fixed key ([`KEY_RULES`]), which the scene reader and the nodes' settings of
//! those keys both apply (one truth per range: the nodes' flags, parameter descriptors and
//! `set_parameters` refuse what a scene file would, with the same words).

use super::error::{Fault, Invalid};
use crate::number_text::short;

/// The largest drive amplitude `alpha = P_d / P_f` a scene may ask: the plant node's default
/// force limit, in `P_f` (a larger drive would only ever be saturated there), and far beyond
/// the paper's drives (0.1 to 1); it keeps a law's force finite.
pub const MAX_DRIVE_ALPHA: f64 = 100.0;

/// The largest magnitude of a gain a scene, a flag or a parameter may give (far beyond any
/// gain the law is stable with, and small enough that the law's force stays finite).
pub const MAX_MAGNITUDE: f64 = 1e12;

/// The rule of each number the scene file holds under a fixed key. The friction constants'
/// rules come with their table (`crate::model::FRICTION_CONSTANTS`), the device numbers' with
/// the `[device]` table.
pub const KEY_RULES: [(&str, Rule); 10] = [
    ("capsule.gamma", Rule::Positive),
    ("capsule.beta", Rule::NonNegative),
    ("capsule.delta", Rule::NonNegative),
    ("capsule.xi", Rule::NonNegative),
    ("drive.alpha", Rule::Within((0.0, MAX_DRIVE_ALPHA))),
    ("drive.omega", Rule::Positive),
    ("control.kp", Rule::Within((-MAX_MAGNITUDE, MAX_MAGNITUDE))),
    ("physical.m1_kg", Rule::Positive),
    ("physical.k1_n_per_m", Rule::Positive),
    ("physical.pf_n", Rule::Positive),
];

/// The rule of the fixed scene key `key` ([`KEY_RULES`]); a compile-time error in a constant
/// when `key` is not one (a setting that names a scene key must get its rule from here).
pub const fn key_rule(key: &str) -> Rule {
    let mut i = 0;
    while i < KEY_RULES.len() {
        if same_text(KEY_RULES[i].0, key) {
            return KEY_RULES[i].1;
        }
        i += 1;
    }
    panic!("not a fixed scene key with a rule (KEY_RULES)")
}

/// `a == b`, in a constant.
const fn same_text(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

/// What a scene's number must be.
#[derive(Debug, Clone, Copy, PartialEq)]
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
        self.admits(v).map_err(|fault| Invalid::new(key, fault))
    }

    /// Why `v` is refused, if it is (the words every source of the value uses).
    pub fn admits(self, v: f64) -> Result<(), Fault> {
        if !v.is_finite() {
            return Err(Fault::NotFinite(v));
        }
        match self {
            Rule::Finite => Ok(()),
            Rule::Positive if v > 0.0 => Ok(()),
            Rule::Positive => Err(Fault::NotPositive(v)),
            Rule::NonNegative if v >= 0.0 => Ok(()),
            Rule::NonNegative => Err(Fault::Negative(v)),
            Rule::Tolerance if v > 0.0 && v < 1.0 => Ok(()),
            Rule::Tolerance => Err(Fault::NotInOpenUnit(v)),
            Rule::Within((min, max)) if (min..=max).contains(&v) => Ok(()),
            Rule::Within((min, max)) => Err(Fault::OutOfRange { got: v, min, max }),
        }
    }

    /// The range in words, as help and refusals write it (`> 0`, `[0, 100]`); `None` for any
    /// finite number.
    pub fn range_text(self) -> Option<String> {
        match self {
            Rule::Finite => None,
            Rule::Positive => Some("> 0".into()),
            Rule::NonNegative => Some(">= 0".into()),
            Rule::Tolerance => Some("in (0, 1)".into()),
            Rule::Within((min, max)) => Some(format!("[{}, {}]", short(min), short(max))),
        }
    }

    /// The closed range a ROS parameter descriptor announces for it (the nearest closed one
    /// for an open bound); `None` for any finite number.
    pub fn bounds(self) -> Option<(f64, f64)> {
        match self {
            Rule::Finite => None,
            Rule::Positive => Some((f64::MIN_POSITIVE, f64::MAX)),
            Rule::NonNegative => Some((0.0, f64::MAX)),
            Rule::Tolerance => Some((f64::MIN_POSITIVE, 1.0 - f64::EPSILON / 2.0)),
            Rule::Within(range) => Some(range),
        }
    }
}
