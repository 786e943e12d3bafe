//! Numbers in messages (refusals, reasons, errors): as short as they read back exactly, so that
//! a gain of 1e308 is written `1e308`, not as 309 digits.

/// `v` as short as it round-trips: the shorter of Rust's plain (`{}`) and exponent (`{:e}`)
/// forms, both of which parse back to exactly `v`; plain on a tie. `0.2`, `-5`, `1e308`,
/// `1.5e-7`, `1e6`, `NaN`, `inf`.
pub fn short(v: f64) -> String {
    let plain = v.to_string();
    let exponent = format!("{v:e}");
    if exponent.len() < plain.len() {
        exponent
    } else {
        plain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_written_short_and_read_back_exactly() {
        for (v, text) in [
            (1e308, "1e308"),
            (-1e308, "-1e308"),
            (f64::MAX, "1.7976931348623157e308"),
            (0.2, "0.2"),
            (-5.0, "-5"),
            (100.0, "100"),
            (123456.0, "123456"),
            (1e6, "1e6"),
            (1000.0, "1e3"),
            (0.02, "0.02"),
            (1.5e-7, "1.5e-7"),
            (5e-324, "5e-324"),
            (0.0, "0"),
            (f64::INFINITY, "inf"),
            (f64::NAN, "NaN"),
        ] {
            assert_eq!(short(v), text, "{v:?}");
        }
        // every finite double reads back to itself, in at most 24 characters
        let mut bits: u64 = 0x9E37_79B9_7F4A_7C15;
        for _ in 0..100_000 {
            bits ^= bits << 13;
            bits ^= bits >> 7;
            bits ^= bits << 17;
            let v = f64::from_bits(bits);
            if v.is_finite() {
                let s = short(v);
                assert_eq!(s.parse::<f64>().ok().map(f64::to_bits), Some(bits), "{s}");
                assert!(s.len() <= 24, "{v:?}: {s}");
            }
        }
    }
}
