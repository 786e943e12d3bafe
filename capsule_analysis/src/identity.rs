//! Attractor identity beyond the Poincaré points a run happened to stop at.
//!
//! - **Periodic orbits** are refined to the exact orbit by Newton's method on the Poincaré map
//!   (its exact Jacobian, [`poincare_map`]): two runs that approach one orbit from different
//!   sides, or so slowly (a multiplier near -1 or on a complex pair near the unit circle) that
//!   their last cycles still differ by more than [`crate::cycle::SAME_TOL`],
//!   end on the same refined cycle, and a cycle seen at twice its period (the halves not yet
//!   equal) is reduced to its own period.
//! - **Runs that neither settle nor diverge** are told apart by their largest Lyapunov exponent
//!   ([`lyapunov`], over [`LYAPUNOV_PERIODS`] periods from where the run ended): chaotic when it
//!   is clearly positive, quasi-periodic or slowly converging when it is near zero.

use crate::cycle::{canonical, SAME_TOL};
use crate::floquet::{map_only, modulus, poincare_map};
use crate::linear::{eigenvalues3, solve};
use crate::lyapunov::lyapunov;
use capsule_controller::period::reduced;
use capsule_plant::scene::{Horizon, Scene};
use capsule_plant::State;

/// Newton iterations at most.
const NEWTON_STEPS: usize = 20;
/// Newton has converged when the map moves the point by less than this (max norm).
const NEWTON_TOL: f64 = 1e-10;
/// How far (max norm) the refined orbit may lie from the run's cycle: farther, Newton has
/// jumped to another orbit and the refinement is not used.
const NEAR: f64 = 0.05;
/// Drive periods over which the largest Lyapunov exponent of an unsettled run is measured.
pub const LYAPUNOV_PERIODS: u32 = 1000;
/// Largest Lyapunov exponent per drive period above which an unsettled run is chaotic: a
/// quasi-periodic or slowly converging run's estimate over [`LYAPUNOV_PERIODS`] periods is
/// within about 1e-3 of zero (the log of a bounded stretch over the window), a chaotic one's is
/// 0.2 and more on the paper's scenes (Fig 2a at alpha 0.6: 0.23).
pub const CHAOS_EXPONENT: f64 = 0.02;

/// A periodic orbit found by Newton's method near a run's cycle.
#[derive(Debug, Clone, PartialEq)]
pub struct Refined {
    /// Its own period (the cycle's, or a divisor of it).
    pub period: usize,
    /// The cycle `[x1 - x2, y1 - y2, y1]` at drive phase 0, from its lowest `y1`.
    pub cycle: Vec<[f64; 3]>,
    /// The largest modulus of its Floquet multipliers (below 1: an attractor).
    pub largest_modulus: f64,
}

/// `[x1 - x2, y1 - y2, y1]` (a section point) to the map's `[z, y1, y2]` and back.
fn to_map(p: &[f64; 3]) -> [f64; 3] {
    [p[0], p[2], p[2] - p[1]]
}
fn to_section(x: &[f64; 3]) -> [f64; 3] {
    [x[0], x[1] - x[2], x[1]]
}

fn max_norm(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}

/// The periodic orbit of period `k` (or a divisor) near `cycle` (a run's last `k` section
/// points), by Newton's method on the `k`-fold Poincaré map of `scene`; `None` when Newton
/// does not converge, lands far from the cycle, or the law is not covered by the map (memory).
pub fn refine(scene: &Scene, cycle: &[[f64; 3]]) -> Option<Refined> {
    let k = cycle.len();
    let start = cycle.first()?;
    let mut x = to_map(start);
    let mut converged = false;
    for _ in 0..NEWTON_STEPS {
        let lin = poincare_map(scene, x, k).ok()?;
        let f: [f64; 3] = std::array::from_fn(|i| lin.end[i] - x[i]);
        if f.iter().all(|v| v.abs() < NEWTON_TOL) {
            converged = true;
            break;
        }
        let mut a = lin.jacobian;
        for (i, row) in a.iter_mut().enumerate() {
            row[i] -= 1.0;
        }
        let dx = solve(a, f.map(|v| -v), 0.0)?;
        for i in 0..3 {
            x[i] += dx[i];
        }
    }
    if !converged || max_norm(&to_section(&x), start) > NEAR {
        return None;
    }
    let mut points = Vec::with_capacity(k);
    let mut p = x;
    for _ in 0..k {
        points.push(to_section(&p));
        p = map_only(scene, p, 1).ok()?;
    }
    let d = reduced(&points, SAME_TOL * 1e-3);
    let jac = poincare_map(scene, x, d).ok()?.jacobian;
    let largest_modulus = eigenvalues3(&jac).iter().map(modulus).fold(0.0, f64::max);
    Some(Refined {
        period: d,
        cycle: canonical(&points[..d]),
        largest_modulus,
    })
}

/// The largest Lyapunov exponent per drive period of `scene` run on from `state` (at drive
/// phase 0) for [`LYAPUNOV_PERIODS`] periods; `None` where the exponents are not defined (a law
/// with memory) or the run fails.
pub fn largest_exponent(scene: &Scene, state: State) -> Option<f64> {
    let mut s = scene.clone();
    s.initial = state;
    s.horizon = Horizon {
        periods: LYAPUNOV_PERIODS,
        transient: 0,
    };
    lyapunov(&s).ok().map(|l| l.per_period[0])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cycle::same_cycle;

    #[test]
    fn newton_refines_a_rough_cycle_onto_the_orbit() {
        // the section-5 period-1 orbit (stable), started 1e-3 off it
        let mut s = Scene::default();
        s.drive.alpha = 1.5;
        let r = crate::run(&s).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.period, Some(1));
        let exact = r.poincare[r.poincare.len() - 1];
        let off = [exact[0] + 1e-3, exact[1] - 1e-3, exact[2] + 1e-3];
        let got = refine(&s, &[off]).unwrap_or_else(|| panic!("no refinement"));
        assert_eq!(got.period, 1);
        assert!(
            max_norm(&got.cycle[0], &exact) < 1e-9,
            "{:?} vs {exact:?}",
            got.cycle
        );
        assert!(got.largest_modulus < 1.0);
        // the same orbit seen as a 2-cycle whose halves differ: reduced to period 1
        let two = [off, [exact[0] - 2e-3, exact[1], exact[2] - 1e-3]];
        let got2 = refine(&s, &two).unwrap_or_else(|| panic!("no refinement"));
        assert_eq!(got2.period, 1);
        assert!(same_cycle(&got.cycle, &got2.cycle, 1e-9));
    }
}
