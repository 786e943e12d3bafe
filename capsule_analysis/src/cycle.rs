//! Cycles on the Poincaré section (`[x1 - x2, y1 - y2, y1]` per drive period): one way to write
//! a cycle down whatever point a run stopped at, and when two cycles are one orbit. The one
//! place for both, shared by the attractor catalogue ([`crate::attractor`]), Newton's
//! refinement ([`crate::identity`]) and the switching check ([`crate::switch`]).

use capsule_controller::period::close;

/// Two periodic attractors whose cycles agree within this (max norm) are one.
pub const SAME_TOL: f64 = 1e-4;

/// A cycle rotated to start at its point of lowest `y1` (ties broken by the other coordinates).
pub fn canonical(cycle: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let start = (0..cycle.len())
        .min_by(|&a, &b| {
            let (p, q) = (cycle[a], cycle[b]);
            p[2].total_cmp(&q[2])
                .then(p[0].total_cmp(&q[0]))
                .then(p[1].total_cmp(&q[1]))
        })
        .unwrap_or(0);
    cycle[start..]
        .iter()
        .chain(&cycle[..start])
        .copied()
        .collect()
}

/// `a` and `b` are the same cycle, whatever point each starts at, within `tol`.
pub fn same_cycle(a: &[[f64; 3]], b: &[[f64; 3]], tol: f64) -> bool {
    let k = a.len();
    k == b.len() && k > 0 && (0..k).any(|r| (0..k).all(|i| close(&a[i], &b[(i + r) % k], tol)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cycle_is_the_same_from_any_of_its_points() {
        let a = [[0.1, 0.2, 0.3], [0.4, 0.5, -0.6], [0.7, 0.8, 0.9]];
        let b = [a[1], a[2], a[0]];
        assert!(same_cycle(&a, &b, 1e-12));
        assert_eq!(canonical(&a), canonical(&b));
        assert_eq!(canonical(&a)[0], a[1]);
        let mut moved = a;
        moved[2][0] += 1e-3;
        assert!(!same_cycle(&a, &moved, SAME_TOL));
        assert!(!same_cycle(&a, &a[..2], 1.0));
    }
}
