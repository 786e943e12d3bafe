//! One run of a scene: transient, then measured periods.

use capsule_controller::period::{self, Over};
use capsule_plant::scene::Scene;
use capsule_plant::{EventKind, SimError, Simulator, Snapshot, State, Work};
use serde::Serialize;

use crate::schedule::GainSchedule;

/// Largest period searched for on the Poincaré section.
pub const MAX_PERIOD: usize = 64;
/// Two Poincaré points closer than this (max norm) count as the same.
pub const PERIOD_TOL: f64 = 1e-6;

/// What a run measured over its measured periods.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunReport {
    /// Capsule advance per drive period, averaged over the measured periods.
    pub avg_progression: f64,
    /// Smallest `k <= 64` for which the Poincaré section repeats, or `None`.
    pub period: Option<usize>,
    /// Impacts (contact onsets) per drive period.
    pub impacts_per_period: f64,
    /// Slips starting backward (break-away or reversal to `y2 < 0`) per drive period.
    pub backward_slips_per_period: f64,
    /// Progression over actuator work on the mass (eq. 4), over the measured periods.
    pub efficiency: f64,
    /// Actuator work per drive period.
    pub work_per_period: f64,
    /// One `[x1 - x2, y1 - y2, y1]` per measured period, at drive phase 0.
    pub poincare: Vec<[f64; 3]>,
    /// State at the end.
    pub final_state: State,
    /// Measured periods.
    pub measured_periods: u32,
    /// Integrator work over the whole run.
    pub work: Work,
}

/// Run a scene and measure it.
pub fn run(scene: &Scene) -> Result<RunReport, SimError> {
    run_sampled(scene, 0, &mut |_| {})
}

/// Run a scene; with `samples_per_period > 0`, also hand `sample` that many snapshots per period
/// (from the start, transient included) for a time history.
pub fn run_sampled(
    scene: &Scene,
    samples_per_period: u32,
    sample: &mut dyn FnMut(&Snapshot),
) -> Result<RunReport, SimError> {
    let schedule = GainSchedule::constant(scene.control.kp);
    run_scheduled(scene, &schedule, samples_per_period, sample)
}

/// [`run_sampled`] with the gain of each drive period taken from `schedule` instead of the
/// scene's constant `k_p` (check it first with [`GainSchedule::validate`]).
pub fn run_scheduled(
    scene: &Scene,
    schedule: &GainSchedule,
    samples_per_period: u32,
    sample: &mut dyn FnMut(&Snapshot),
) -> Result<RunReport, SimError> {
    let report = run_scheduled_until(scene, schedule, samples_per_period, sample, &mut |_| true)?;
    // `go_on` never says stop
    Ok(report.unwrap_or_else(|| unreachable!("a run without a stop ran to its end")))
}

/// [`run_scheduled`] that asks `go_on(n)` before each drive period `n` (for progress and a
/// stop on request) and returns `None` if it said stop; what was sampled until then is
/// handed to `sample` as usual.
pub fn run_scheduled_until(
    scene: &Scene,
    schedule: &GainSchedule,
    samples_per_period: u32,
    sample: &mut dyn FnMut(&Snapshot),
    go_on: &mut dyn FnMut(u32) -> bool,
) -> Result<Option<RunReport>, SimError> {
    let period = scene.drive.period();
    let mut sim = Simulator::new(scene.model, scene.initial, 0.0, scene.solver)?;
    let periods = scene.horizon.periods;
    let transient = scene.horizon.transient;
    let mut impacts = 0u64;
    let mut backward = 0u64;
    let mut poincare = Vec::with_capacity((periods - transient) as usize);
    let mut x2_start = sim.state().x2;
    if samples_per_period > 0 {
        sample(&sim.snapshot());
    }
    for n in 0..periods {
        if !go_on(n) {
            return Ok(None);
        }
        let law = schedule.law(scene, n);
        let measuring = n >= transient;
        if n == transient {
            x2_start = sim.state().x2;
            sim.track_actuator_work(true);
        }
        let mut on_event = |e: &capsule_plant::Event| {
            if measuring {
                match e.kind {
                    EventKind::ContactOn => impacts += 1,
                    EventKind::BreakAway { dir } | EventKind::Reversal { dir } if dir < 0.0 => {
                        backward += 1
                    }
                    _ => {}
                }
            }
        };
        let t0 = n as f64 * period;
        if samples_per_period > 0 {
            for i in 1..=samples_per_period {
                let t = if i == samples_per_period {
                    (n + 1) as f64 * period
                } else {
                    t0 + period * i as f64 / samples_per_period as f64
                };
                sim.advance_observed(&law, t, &mut on_event)?;
                sample(&sim.snapshot());
            }
        } else {
            sim.advance_observed(&law, (n + 1) as f64 * period, &mut on_event)?;
        }
        if measuring {
            let s = sim.state();
            poincare.push([s.x1 - s.x2, s.y1 - s.y2, s.y1]);
        }
    }
    let measured = periods - transient;
    let m = measured as f64;
    let s = sim.state();
    let progression = s.x2 - x2_start;
    let work = sim.actuator_work();
    Ok(Some(RunReport {
        avg_progression: progression / m,
        period: detect_period(&poincare, PERIOD_TOL),
        impacts_per_period: impacts as f64 / m,
        backward_slips_per_period: backward as f64 / m,
        efficiency: progression / work,
        work_per_period: work / m,
        poincare,
        final_state: s,
        measured_periods: measured,
        work: sim.work(),
    }))
}

/// Smallest `k <= MAX_PERIOD` with `|P[n] - P[n-k]| <= tol` for every `n >= k`, if the section
/// has at least `k + 1` points (the one detector: [`capsule_controller::period`]).
pub fn detect_period(points: &[[f64; 3]], tol: f64) -> Option<usize> {
    period::smallest_lag(points, MAX_PERIOD, Over::All, tol)
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_plant::{ActuatorLaw, AffineLaw, LawShape};

    #[test]
    fn detects_the_smallest_repeating_period() {
        let pts: Vec<[f64; 3]> = (0..30).map(|n| [(n % 3) as f64, 0.0, 1.0]).collect();
        assert_eq!(detect_period(&pts, 1e-9), Some(3));
        let fixed: Vec<[f64; 3]> = vec![[0.5, 0.1, 0.2]; 10];
        assert_eq!(detect_period(&fixed, 1e-9), Some(1));
        let chaos: Vec<[f64; 3]> = (0..100)
            .map(|n| [((n * n) as f64).sin(), 0.0, 0.0])
            .collect();
        assert_eq!(detect_period(&chaos, 1e-6), None);
    }

    #[test]
    fn paper_law_shape_agrees_with_its_force() {
        let law = AffineLaw::paper(1.3, 0.95, -0.4);
        let LawShape::PiecewiseAffine(AffineLaw {
            alpha,
            omega,
            bias,
            kp,
        }) = law.shape()
        else {
            panic!("paper law must be piecewise affine");
        };
        for (tau, x1, x2) in [(0.3, 0.1, -0.2), (2.0, -1.0, 0.5), (7.7, 3.0, 3.0)] {
            let s = State {
                x1,
                y1: 0.0,
                x2,
                y2: 0.0,
            };
            let from_shape = alpha * (omega * tau).cos() + bias + kp * (x2 - x1).abs();
            assert!((law.force(tau, &s) - from_shape).abs() < 1e-15);
        }
    }
}
