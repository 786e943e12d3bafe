//! The one period detector, on Poincaré-section points (`[x1 - x2, y1 - y2, y1]` at the drive
//! phase 0, one point per drive period): the smallest lag with which the points repeat, and the
//! reduction of a cycle to its smallest period. The offline runs and attractor catalogue
//! (`capsule_analysis`), the controller node's orbit watch and the attractor switch all ask it.

/// Two section points are within `tol` of each other in every coordinate (max norm).
pub fn close(a: &[f64; 3], b: &[f64; 3], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

/// Which points must repeat for a lag `k` to count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Over {
    /// Every point from the `k`-th on (a whole measured stretch: the offline runs).
    All,
    /// The last `cycles * k` points, and so `(cycles + 1) k` points are needed (a window that
    /// grows while the orbit settles: the controller's watch).
    Cycles(usize),
}

/// The smallest lag `k <= max_period` for which the points `over` says are each within `tol`
/// of the point `k` before them, or `None`.
pub fn smallest_lag(points: &[[f64; 3]], max_period: usize, over: Over, tol: f64) -> Option<usize> {
    let n = points.len();
    (1..=max_period)
        .take_while(|&k| match over {
            Over::All => k < n,
            Over::Cycles(c) => (c + 1) * k <= n,
        })
        .find(|&k| {
            let from = match over {
                Over::All => k,
                Over::Cycles(c) => n - c * k,
            };
            (from..n).all(|i| close(&points[i], &points[i - k], tol))
        })
}

/// The smallest divisor `d` of the cycle's length whose shift maps the cycle onto itself
/// within `tol` (the length itself if none smaller does). An orbit approached along a Floquet
/// multiplier near -1 (or a complex pair) repeats at a recurrence tolerance with a multiple of
/// its period before it does with the period itself; this finds the period.
pub fn reduced(cycle: &[[f64; 3]], tol: f64) -> usize {
    let k = cycle.len();
    (1..=k)
        .filter(|d| k.is_multiple_of(*d))
        .find(|&d| (0..k).all(|i| close(&cycle[i], &cycle[(i + d) % k], tol)))
        .unwrap_or(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_smallest_repeating_lag_over_everything_or_the_last_cycles() {
        let p3: Vec<[f64; 3]> = (0..30).map(|n| [(n % 3) as f64, 0.0, 1.0]).collect();
        assert_eq!(smallest_lag(&p3, 64, Over::All, 1e-9), Some(3));
        assert_eq!(smallest_lag(&p3[..12], 12, Over::Cycles(2), 1e-3), Some(3));
        // Cycles(2) needs three cycles
        assert_eq!(smallest_lag(&p3[..8], 12, Over::Cycles(2), 1e-3), None);
        let fixed = vec![[0.5, 0.1, 0.2]; 10];
        assert_eq!(smallest_lag(&fixed, 64, Over::All, 1e-9), Some(1));
        assert_eq!(smallest_lag(&fixed[..1], 64, Over::All, 1e-9), None);
        let chaos: Vec<[f64; 3]> = (0..100)
            .map(|n| [((n * n) as f64).sin(), 0.0, 0.0])
            .collect();
        assert_eq!(smallest_lag(&chaos, 64, Over::All, 1e-6), None);
        // a settling transient: the whole stretch does not repeat, its last cycles do
        let settling: Vec<[f64; 3]> = (0..9)
            .map(|n| [if n < 3 { n as f64 } else { 7.0 }, 0.0, 0.0])
            .collect();
        assert_eq!(smallest_lag(&settling, 12, Over::All, 1e-9), None);
        assert_eq!(smallest_lag(&settling, 12, Over::Cycles(2), 1e-9), Some(1));
    }

    #[test]
    fn a_cycle_reduces_to_its_smallest_period() {
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert_eq!(reduced(&a, 1e-4), 3);
        assert_eq!(reduced(&[a[0], a[1], a[0], a[1]], 1e-4), 2);
        let near = [[0.0, 0.0, 0.0], [5e-5, 0.0, 0.0]];
        assert_eq!(reduced(&near, 1e-4), 1);
        assert!(!close(&a[0], &[f64::NAN, 0.0, 0.0], 1.0));
    }
}
