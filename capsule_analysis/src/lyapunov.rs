//! The Lyapunov spectrum of a run, through the impacts and the stick-slip transitions.
//!
//! Müller's method (Müller 1995; Leine and Nijmeijer 2004, sec. 7.4): three tangent vectors of the
//! reduced state `[z, y1, y2]` are carried through each segment's flow Jacobian and each event's
//! saltation matrix (the one-period Jacobian of [`crate::floquet`]), re-orthonormalised by
//! Gram-Schmidt after every drive period; the exponents are the averaged logarithms of the
//! stretching factors. Units: per unit of non-dimensional time `tau`; `per_period` multiplies by
//! the drive period `T = 2 pi / omega`. On a period-`k` orbit they equal `ln|mu_i| / (k T)`.
//!
//! A direction that sticking removes (the capsule's velocity, pinned to zero) has exponent `-inf`
//! (written `null` in JSON): the stretching factor is zero, not small.

use crate::floquet::{advance_linearized, equations_of, StabilityError};
use crate::sweep::{at_each_value, Param};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{Phase, Simulator, State};
use serde::Serialize;

/// Below this (relative to the largest stretching in the period) a tangent vector counts as
/// collapsed by sticking.
const COLLAPSED: f64 = 1e-12;

/// The Lyapunov spectrum of a run's measured periods.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Lyapunov {
    /// Exponents per unit time `tau`, largest first (`-inf`, JSON `null`: removed by sticking).
    pub exponents: Vec<f64>,
    /// The exponents times the drive period (per drive period).
    pub per_period: Vec<f64>,
    /// The largest exponent over the first half of the measured periods only (convergence check).
    pub largest_half_run: f64,
    /// Measured periods.
    pub periods: u32,
}

/// Carries an orthonormal frame through period Jacobians and sums the logarithms of the
/// stretching factors.
#[derive(Debug, Clone)]
pub struct Frame {
    q: [[f64; 3]; 3],
    sums: [f64; 3],
}

impl Default for Frame {
    fn default() -> Self {
        Self::new()
    }
}

impl Frame {
    /// The identity frame, nothing summed.
    pub fn new() -> Self {
        Frame {
            q: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            sums: [0.0; 3],
        }
    }

    /// Apply `j` (row-major) to the frame (columns of `q`), re-orthonormalise, add the logs.
    pub fn push(&mut self, j: &[[f64; 3]; 3]) {
        let mut cols = [[0.0; 3]; 3];
        for (k, col) in cols.iter_mut().enumerate() {
            for (i, ci) in col.iter_mut().enumerate() {
                *ci = (0..3).map(|m| j[i][m] * self.q[m][k]).sum();
            }
        }
        let scale = cols
            .iter()
            .map(norm)
            .fold(0.0f64, f64::max)
            .max(f64::MIN_POSITIVE);
        let mut out: [[f64; 3]; 3] = [[0.0; 3]; 3];
        for k in 0..3 {
            let mut v = cols[k];
            // modified Gram-Schmidt, twice for orthogonality to rounding
            for _ in 0..2 {
                for prev in out.iter().take(k) {
                    let d = dot(&v, prev);
                    for (vi, pi) in v.iter_mut().zip(prev) {
                        *vi -= d * pi;
                    }
                }
            }
            let n = norm(&v);
            if n <= COLLAPSED * scale {
                self.sums[k] = f64::NEG_INFINITY;
                v = complement(&out[..k]);
            } else {
                self.sums[k] += n.ln();
                v.iter_mut().for_each(|x| *x /= n);
            }
            out[k] = v;
        }
        for (k, col) in out.iter().enumerate() {
            for (i, ci) in col.iter().enumerate() {
                self.q[i][k] = *ci;
            }
        }
    }

    /// The summed logarithms.
    pub fn sums(&self) -> [f64; 3] {
        self.sums
    }
}

fn dot(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

fn norm(a: &[f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

/// A unit vector orthogonal to the (orthonormal) `basis`.
fn complement(basis: &[[f64; 3]]) -> [f64; 3] {
    let mut best = [0.0; 3];
    let mut best_n = -1.0;
    for e in 0..3 {
        let mut v = [0.0; 3];
        v[e] = 1.0;
        for b in basis {
            let d = dot(&v, b);
            for (vi, bi) in v.iter_mut().zip(b) {
                *vi -= d * bi;
            }
        }
        let n = norm(&v);
        if n > best_n {
            best_n = n;
            best = v.map(|x| x / n);
        }
    }
    best
}

/// The scene's run at the end of its transient, with the law that drives it.
fn past_transient(scene: &Scene) -> Result<(AffineLaw, Simulator), StabilityError> {
    let law = scene.law();
    let mut sim = Simulator::new(scene.model, scene.initial, 0.0, scene.solver)?;
    sim.advance(&law, scene.horizon.transient as f64 * scene.drive.period())?;
    Ok((law, sim))
}

/// The Lyapunov spectrum of `scene` over its measured periods (after the transient).
pub fn lyapunov(scene: &Scene) -> Result<Lyapunov, StabilityError> {
    let eq = equations_of(scene)?;
    let (law, mut sim) = past_transient(scene)?;
    let period = scene.drive.period();
    let (transient, periods) = (scene.horizon.transient, scene.horizon.periods);
    let measured = periods - transient;
    let half = measured / 2;
    let mut frame = Frame::new();
    let mut largest_half_run = f64::NAN;
    let mut events = Vec::new();
    let mut transversality = f64::INFINITY;
    for n in transient..periods {
        let stuck = sim.regime().phase == Phase::Stick;
        events.clear();
        let j4 = advance_linearized(
            &mut sim,
            &eq,
            &law,
            (n + 1) as f64 * period,
            &mut events,
            &mut transversality,
        )?;
        let mut j = [[0.0; 3]; 3];
        for i in 0..3 {
            for k in 0..3 {
                j[i][k] = if stuck && k == 2 { 0.0 } else { j4[i][k] };
            }
        }
        frame.push(&j);
        if n + 1 - transient == half && half > 0 {
            largest_half_run = frame.sums()[0] / (half as f64 * period);
        }
    }
    let time = measured as f64 * period;
    let exponents: Vec<f64> = frame.sums().iter().map(|s| s / time).collect();
    Ok(Lyapunov {
        per_period: exponents.iter().map(|l| l * period).collect(),
        exponents,
        largest_half_run,
        periods: measured,
    })
}

/// The Lyapunov spectrum for every value of `param` in `values`, in parallel, each run from the
/// scene's initial state (as [`crate::sweep::sweep`] runs them); `progress` is called once per
/// finished value.
pub fn lyapunov_sweep(
    scene: &Scene,
    param: Param,
    values: &[f64],
    progress: &(dyn Fn() + Sync),
) -> Vec<Result<Lyapunov, String>> {
    at_each_value(scene, param, values, progress, |s| {
        lyapunov(s).map_err(|e| e.to_string())
    })
}

/// The largest exponent estimated from two trajectories (Benettin et al.): a neighbour `d0` away
/// in `z`, its distance in `[z, y1, y2]` measured and rescaled to `d0` after every period.
/// Independent of the Jacobians: a check on them.
pub fn largest_by_divergence(scene: &Scene, d0: f64) -> Result<f64, StabilityError> {
    let (law, mut sim) = past_transient(scene)?;
    let period = scene.drive.period();
    let (transient, periods) = (scene.horizon.transient, scene.horizon.periods);
    let mut offset = [d0, 0.0, 0.0];
    let mut sum = 0.0;
    for n in transient..periods {
        let t0 = n as f64 * period;
        let s = sim.state();
        let near = State {
            x1: s.x1 + offset[0],
            y1: s.y1 + offset[1],
            x2: s.x2,
            y2: s.y2 + offset[2],
        };
        let mut other = Simulator::new(scene.model, near, t0, scene.solver)?;
        sim.advance(&law, t0 + period)?;
        other.advance(&law, t0 + period)?;
        let (a, b) = (sim.core(), other.core());
        let diff = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        let d = norm(&diff);
        if d == 0.0 {
            return Ok(f64::NEG_INFINITY);
        }
        sum += (d / d0).ln();
        offset = diff.map(|x| x * d0 / d);
    }
    Ok(sum / ((periods - transient) as f64 * period))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_under_a_diagonal_map_sums_its_logs() {
        let mut f = Frame::new();
        let j = [[2.0, 0.0, 0.0], [0.0, 0.5, 0.0], [0.0, 0.0, 0.0]];
        for _ in 0..10 {
            f.push(&j);
        }
        let s = f.sums();
        assert!((s[0] - 10.0 * 2f64.ln()).abs() < 1e-12, "{s:?}");
        assert!((s[1] - 10.0 * 0.5f64.ln()).abs() < 1e-12, "{s:?}");
        assert_eq!(s[2], f64::NEG_INFINITY);
    }
}
