//! The documented range of every numeric flag of every binary (`capsule`, `capsule_plant`,
//! `capsule_controller`, `capsule_recorder`, `capsule_ros`, `capsule_foxglove`,
//! `capsule_replay`), checked by clap at parse time, so
//! that NaN, infinities, 1e308, negative or zero values where they mean nothing, durations that
//! overflow a [`std::time::Duration`] and counts that overflow an allocation are refused before
//! anything starts, with the flag, the value and the range in the message.
//!
//! Use: `#[arg(long, value_parser = ranges::positive(ranges::MAX_SECONDS))]`.

use capsule_plant::number_text::short;
use capsule_plant::scene::Rule;

/// Longest duration any flag takes \[s\] (about 11.6 days): far inside what a `Duration` holds.
pub const MAX_SECONDS: f64 = 1e6;
/// Longest period any millisecond flag takes \[ms\] (one minute).
pub const MAX_MILLIS: u64 = 60_000;
/// Largest magnitude of a gain or a model parameter given as a flag (the scene's own bound on a
/// gain, `control.kp`).
pub const MAX_MAGNITUDE: f64 = capsule_plant::scene::MAX_MAGNITUDE;
/// Lowest and highest sample rate of the plant node \[Hz\]: one sample per 1000 s to 1 MHz (a
/// period that every clock and `Duration` holds); the plant's settings table takes it.
pub const RATE_HZ: (f64, f64) = (1e-3, 1e6);
/// Most subscribers any node waits for.
pub const MAX_SUBSCRIBERS: u64 = 1000;

/// A parser for a flag: the text to a value, or the reason it is refused.
pub trait FlagParser<T>: Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static {}
impl<T, F: Fn(&str) -> Result<T, String> + Clone + Send + Sync + 'static> FlagParser<T> for F {}

/// The text as a finite number, or why it is not one.
pub fn number(text: &str) -> Result<f64, String> {
    let v: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("`{text}` is not a number"))?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("must be a finite number (got {text})"))
    }
}

/// A number the scene reader's `rule` admits (`const { key_rule("drive.alpha") }`): the flag
/// refuses what the scene file's key would, in the same words.
pub fn obeying(rule: Rule) -> impl FlagParser<f64> {
    move |text: &str| {
        let v = number(text)?;
        rule.admits(v)
            .map(|()| v)
            .map_err(|fault| fault.to_string())
    }
}

/// A finite number in `[min, max]`.
pub fn within(min: f64, max: f64) -> impl FlagParser<f64> {
    move |text: &str| {
        let v = number(text)?;
        if (min..=max).contains(&v) {
            Ok(v)
        } else {
            Err(format!(
                "must be in [{}, {}] (got {text})",
                short(min),
                short(max)
            ))
        }
    }
}

/// A finite number in `(0, max]`.
pub fn positive(max: f64) -> impl FlagParser<f64> {
    move |text: &str| {
        let v = number(text)?;
        if v > 0.0 && v <= max {
            Ok(v)
        } else {
            Err(format!("must be > 0 and <= {} (got {text})", short(max)))
        }
    }
}

/// A finite number in `[0, max]`.
pub fn non_negative(max: f64) -> impl FlagParser<f64> {
    within(0.0, max)
}

/// A finite number in `[-MAX_MAGNITUDE, MAX_MAGNITUDE]`.
pub fn finite() -> impl FlagParser<f64> {
    within(-MAX_MAGNITUDE, MAX_MAGNITUDE)
}

/// A number in the open interval `(0, 1)` (a tolerance).
pub fn open_unit() -> impl FlagParser<f64> {
    move |text: &str| {
        let v = number(text)?;
        if v > 0.0 && v < 1.0 {
            Ok(v)
        } else {
            Err(format!("must be in (0, 1) (got {text})"))
        }
    }
}

/// A whole number in `[min, max]`.
pub fn count(min: u64, max: u64) -> impl FlagParser<u64> {
    move |text: &str| {
        text.trim()
            .parse::<u64>()
            .ok()
            .filter(|n| (min..=max).contains(n))
            .ok_or_else(|| format!("must be a whole number from {min} to {max} (got {text})"))
    }
}

/// A whole number in `[min, max]` as a `u32` (`max` is clamped to `u32::MAX`).
pub fn count_u32(min: u32, max: u32) -> impl FlagParser<u32> {
    let inner = count(min.into(), max.into());
    move |text: &str| inner(text).map(|n| u32::try_from(n).unwrap_or(u32::MAX))
}

/// A whole number in `[min, max]` as a `usize`.
pub fn count_usize(min: usize, max: usize) -> impl FlagParser<usize> {
    let inner = count(min as u64, max as u64);
    move |text: &str| inner(text).map(|n| usize::try_from(n).unwrap_or(usize::MAX))
}

/// Milliseconds in `[1, MAX_MILLIS]`.
pub fn millis() -> impl FlagParser<u64> {
    count(1, MAX_MILLIS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_refuse_what_means_nothing() {
        let p = positive(MAX_SECONDS);
        for bad in ["nan", "inf", "-inf", "1e308", "-1", "0", "abc", ""] {
            assert!(p(bad).is_err(), "{bad}");
        }
        assert_eq!(p("2.5"), Ok(2.5));
        assert!(p("1e308").is_err_and(|e| e.contains("<= 1e6")));
        let c = count(1, 10);
        for bad in ["0", "-5", "11", "2.5", "4294967296", "18446744073709551616"] {
            assert!(c(bad).is_err(), "{bad}");
        }
        assert_eq!(c("10"), Ok(10));
        assert!(c("-5").is_err_and(|e| e.contains("from 1 to 10")));
        assert_eq!(count_u32(1, u32::MAX)("4294967296").ok(), None);
        assert!(open_unit()("1").is_err() && open_unit()("0").is_err());
        assert!(finite()("-1e308").is_err() && finite()("-3") == Ok(-3.0));
        assert!(millis()("4294967296").is_err());
        // every accepted duration converts
        assert!(std::time::Duration::try_from_secs_f64(MAX_SECONDS).is_ok());
    }
}
