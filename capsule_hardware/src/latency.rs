//! Loop latencies in constant memory: an HdrHistogram (`hdrhistogram`) with two significant
//! digits, read as order statistics.
//!
//! The plant used to keep every latency in a `Vec<f64>` to sort it at the end: 8 bytes per
//! answered sample, the ~9.7 KB/s its memory grew at 1 kHz with a controller answering (issue
//! 12). This histogram has a fixed size (36 KB) for any run length; a percentile is exact
//! to within [`LatencyHistogram::RELATIVE_ERROR`] and the maximum is exact.

use hdrhistogram::Histogram;

/// Values are nanoseconds up to 2^42 (about 73 minutes); larger ones count as that.
const TOP_NS: u64 = 1 << 42;
/// Two significant digits: 128 sub-buckets per power of two (relative resolution 1/128).
const SIGFIG: u8 = 2;

/// Counts of latencies by size, in constant memory.
#[derive(Debug, Clone)]
pub struct LatencyHistogram {
    counts: Histogram<u64>,
    max_ns: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        LatencyHistogram {
            counts: empty(),
            max_ns: 0,
        }
    }
}

fn empty() -> Histogram<u64> {
    // fixed bounds (1 <= low, 2 low <= high, sigfig <= 5): creating it cannot fail, and it
    // never grows
    Histogram::new_with_bounds(1, TOP_NS, SIGFIG)
        .unwrap_or_else(|e| panic!("latency histogram bounds: {e}"))
}

impl LatencyHistogram {
    /// Largest relative error of a reported percentile (half a bucket).
    pub const RELATIVE_ERROR: f64 = 0.5 / 128.0;

    /// Adds a latency \[s\] (negative ones, from clock steps, count as zero).
    pub fn record(&mut self, seconds: f64) {
        let ns = (seconds.max(0.0) * 1e9).round() as u64;
        self.counts.saturating_record(ns);
        self.max_ns = self.max_ns.max(ns);
    }

    /// Latencies recorded.
    pub fn count(&self) -> u64 {
        self.counts.len()
    }

    /// The `q`-quantile \[s\] (order statistic `round((n-1) q)`, to within the resolution: the
    /// middle of its bucket), `None` if empty.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        let n = self.count();
        if n == 0 {
            return None;
        }
        let rank = ((n - 1) as f64 * q.clamp(0.0, 1.0)).round() as u64;
        let mut seen = 0;
        for v in self.counts.iter_recorded() {
            seen += v.count_at_value();
            if seen > rank {
                let at = v.value_iterated_to();
                let lowest = self.counts.lowest_equivalent(at) as f64;
                let middle = lowest + (self.counts.equivalent_range(at) as f64 - 1.0) / 2.0;
                return Some(middle.min(self.max_ns as f64) / 1e9);
            }
        }
        Some(self.max_ns as f64 / 1e9)
    }

    /// What was recorded after `earlier` (an older copy of this histogram): the counts'
    /// difference; its maximum is the upper edge of its highest non-empty bucket.
    pub fn since(&self, earlier: &LatencyHistogram) -> LatencyHistogram {
        let mut counts = empty();
        let mut max_ns = 0;
        for v in self.counts.iter_recorded() {
            let at = v.value_iterated_to();
            let new = v
                .count_at_value()
                .saturating_sub(earlier.counts.count_at(at));
            if new > 0 {
                counts.saturating_record_n(at, new);
                max_ns = self.counts.highest_equivalent(at).min(self.max_ns);
            }
        }
        LatencyHistogram { counts, max_ns }
    }

    /// The largest latency \[s\], exact; `None` if empty.
    pub fn max(&self) -> Option<f64> {
        (self.count() > 0).then_some(self.max_ns as f64 / 1e9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_value_reads_back_within_the_resolution() {
        for ns in (0..5000u64).chain((12..42).map(|k| (1u64 << k) + 12_345)) {
            let mut h = LatencyHistogram::default();
            h.record(ns as f64 * 1e-9);
            // a single value is also the maximum, which caps the bucket's middle
            let v = h.quantile(0.5).unwrap_or(f64::NAN) * 1e9;
            assert!(
                (v - ns as f64).abs() <= ns as f64 * LatencyHistogram::RELATIVE_ERROR + 0.5,
                "{ns} -> {v}"
            );
        }
    }

    #[test]
    fn quantiles_match_the_order_statistics_within_the_resolution() {
        let mut h = LatencyHistogram::default();
        assert_eq!(h.quantile(0.5), None);
        // 1..=1000 us
        for k in 1..=1000 {
            h.record(f64::from(k) * 1e-6);
        }
        assert_eq!(h.count(), 1000);
        for (q, exact) in [(0.5, 501e-6), (0.99, 990e-6), (0.0, 1e-6)] {
            let got = h.quantile(q).unwrap_or(f64::NAN);
            assert!(
                (got - exact).abs() <= exact * LatencyHistogram::RELATIVE_ERROR * 2.0,
                "q {q}: {got} vs {exact}"
            );
        }
        assert_eq!(h.max(), Some(1000e-6));
    }

    #[test]
    fn memory_does_not_grow_with_the_count() {
        let mut h = LatencyHistogram::default();
        let before = h.counts.buckets();
        for k in 0..200_000 {
            h.record(f64::from(k % 977) * 1.3e-7);
        }
        h.record(1e6); // beyond the top: last bucket, max still exact
        assert!(!h.counts.is_auto_resize());
        assert_eq!(h.counts.buckets(), before);
        assert_eq!(h.max(), Some(1e6));
        assert_eq!(h.count(), 200_001);
    }

    #[test]
    fn since_keeps_what_came_after() {
        let mut h = LatencyHistogram::default();
        for k in 1..=100 {
            h.record(f64::from(k) * 1e-6);
        }
        let earlier = h.clone();
        for _ in 0..50 {
            h.record(2e-3);
        }
        let d = h.since(&earlier);
        assert_eq!(d.count(), 50);
        let q = d.quantile(0.5).unwrap_or(f64::NAN);
        assert!(
            (q - 2e-3).abs() <= 2e-3 * LatencyHistogram::RELATIVE_ERROR,
            "{q}"
        );
        assert_eq!(d.max(), Some(2e-3));
    }
}
