//! Calendar dates of recording timestamps (nanoseconds since the Unix epoch, UTC), for file
//! names and `record info`, without a date-time dependency.

/// A UTC date and time of day.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Civil {
    /// Year.
    pub year: i64,
    /// Month, 1-12.
    pub month: u32,
    /// Day of the month, 1-31.
    pub day: u32,
    /// Hour, 0-23.
    pub hour: u64,
    /// Minute, 0-59.
    pub minute: u64,
    /// Second, 0-59.
    pub second: u64,
    /// Nanoseconds within the second.
    pub nanos: u64,
}

/// The UTC date and time of `ns` nanoseconds since the epoch (proleptic Gregorian calendar,
/// H. Hinnant's days-to-civil algorithm).
pub fn civil(ns: u64) -> Civil {
    let secs = ns / 1_000_000_000;
    let days = (secs / 86_400) as i64;
    let tod = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let month = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    Civil {
        year: yoe + era * 400 + i64::from(month <= 2),
        month,
        day,
        hour: tod / 3600,
        minute: tod / 60 % 60,
        second: tod % 60,
        nanos: ns % 1_000_000_000,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn epoch_and_a_leap_day() {
        let c = civil(0);
        assert_eq!((c.year, c.month, c.day, c.hour), (1970, 1, 1, 0));
        let c = civil(1_709_210_096_500_000_000);
        assert_eq!((c.year, c.month, c.day), (2024, 2, 29));
        assert_eq!(
            (c.hour, c.minute, c.second, c.nanos),
            (12, 34, 56, 500_000_000)
        );
    }
}
