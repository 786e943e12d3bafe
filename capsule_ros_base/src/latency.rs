//! Loop latencies in constant memory: a log-linear histogram (as HdrHistogram lays it out).
//!
//! The plant used to keep every latency in a `Vec<f64>` to sort it at the end: 8 bytes per
//! answered sample, the ~9.7 KB/s its memory grew at 1 kHz with a controller answering (issue
//! 12). This histogram has a fixed size (36 KB) for any run length; a percentile is exact
//! to within [`LatencyHistogram::RELATIVE_ERROR`] and the maximum is exact.

/// Sub-buckets per power of two (relative resolution 1/128).
const SUB: u64 = 128;
const SUB_BITS: u32 = 7;
/// Values are nanoseconds below 2^41 (about 36 minutes); larger ones land in the last bucket.
const TOP_BIT: u32 = 41;
const BUCKETS: usize = ((TOP_BIT - SUB_BITS + 2) as u64 * SUB) as usize;

/// Counts of latencies by size, in constant memory.
#[derive(Debug, Clone)]
pub struct LatencyHistogram {
    counts: Vec<u64>,
    count: u64,
    max_ns: u64,
}

impl Default for LatencyHistogram {
    fn default() -> Self {
        LatencyHistogram {
            counts: vec![0; BUCKETS],
            count: 0,
            max_ns: 0,
        }
    }
}

fn index(ns: u64) -> usize {
    if ns < SUB {
        return ns as usize;
    }
    let top = (63 - ns.leading_zeros()).min(TOP_BIT);
    let ns = ns.min((1u64 << (TOP_BIT + 1)) - 1);
    let shift = top - SUB_BITS;
    let sub = (ns >> shift) - SUB;
    ((u64::from(shift) + 1) * SUB + sub) as usize
}

/// The middle of bucket `i` [ns].
fn value(i: usize) -> f64 {
    let i = i as u64;
    if i < SUB {
        return i as f64;
    }
    let shift = i / SUB - 1;
    let lower = (SUB + i % SUB) << shift;
    lower as f64 + ((1u64 << shift) as f64 - 1.0) / 2.0
}

impl LatencyHistogram {
    /// Largest relative error of a reported percentile (half a bucket).
    pub const RELATIVE_ERROR: f64 = 0.5 / SUB as f64;

    /// Adds a latency \[s\] (negative ones, from clock steps, count as zero).
    pub fn record(&mut self, seconds: f64) {
        let ns = (seconds.max(0.0) * 1e9).round() as u64;
        self.counts[index(ns)] += 1;
        self.count += 1;
        self.max_ns = self.max_ns.max(ns);
    }

    /// Latencies recorded.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The `q`-quantile \[s\] (order statistic `round((n-1) q)`, to within the resolution),
    /// `None` if empty.
    pub fn quantile(&self, q: f64) -> Option<f64> {
        if self.count == 0 {
            return None;
        }
        let rank = ((self.count - 1) as f64 * q.clamp(0.0, 1.0)).round() as u64;
        let mut seen = 0;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                return Some(value(i).min(self.max_ns as f64) / 1e9);
            }
        }
        Some(self.max_ns as f64 / 1e9)
    }

    /// What was recorded after `earlier` (an older copy of this histogram): the counts'
    /// difference; its maximum is the upper edge of its highest non-empty bucket.
    pub fn since(&self, earlier: &LatencyHistogram) -> LatencyHistogram {
        let counts: Vec<u64> = self
            .counts
            .iter()
            .zip(&earlier.counts)
            .map(|(a, b)| a.saturating_sub(*b))
            .collect();
        let max_ns = counts
            .iter()
            .rposition(|&c| c > 0)
            .map_or(0, |i| (value(i).ceil() as u64).min(self.max_ns));
        LatencyHistogram {
            count: counts.iter().sum(),
            counts,
            max_ns,
        }
    }

    /// The largest latency \[s\], exact; `None` if empty.
    pub fn max(&self) -> Option<f64> {
        (self.count > 0).then_some(self.max_ns as f64 / 1e9)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buckets_are_contiguous_and_within_the_resolution() {
        let mut last = 0;
        for ns in 0..5000u64 {
            let i = index(ns);
            assert!(i == last || i == last + 1, "{ns}: {i} after {last}");
            last = i;
            let v = value(i);
            assert!(
                (v - ns as f64).abs() <= ns as f64 * LatencyHistogram::RELATIVE_ERROR + 0.5,
                "{ns} -> {v}"
            );
        }
        for ns in (0..64).map(|k| 1u64 << k).chain([u64::MAX]) {
            assert!(index(ns) < BUCKETS, "{ns}");
        }
        assert_eq!(index(u64::MAX), BUCKETS - 1);
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
        let before = h.counts.capacity();
        for k in 0..200_000 {
            h.record(f64::from(k % 977) * 1.3e-7);
        }
        h.record(1e6); // beyond the top: last bucket, max still exact
        assert_eq!(h.counts.capacity(), before);
        assert_eq!(h.max(), Some(1e6));
        assert_eq!(h.count(), 200_001);
    }
}
