//! Rate-limited logging for events that can repeat once per sample (refused, saturated or
//! undecodable commands): the first few, then only at powers of two, with the running count.

/// Says which occurrences of a repeating event to log: the first ten, then the 16th, 32nd, ...
#[derive(Debug, Clone, Default)]
pub struct Throttle {
    seen: u64,
}

impl Throttle {
    /// Notes one occurrence; true if this one should be logged.
    pub fn tick(&mut self) -> bool {
        self.seen += 1;
        self.seen <= 10 || self.seen.is_power_of_two()
    }

    /// Occurrences so far.
    pub fn seen(&self) -> u64 {
        self.seen
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn logs_the_first_ten_then_powers_of_two() {
        let mut t = Throttle::default();
        let logged: Vec<u64> = (1..=1000).filter(|_| t.tick()).collect();
        assert_eq!(
            logged,
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 16, 32, 64, 128, 256, 512]
        );
        assert_eq!(t.seen(), 1000);
    }
}
