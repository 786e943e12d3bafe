//! Switching between coexisting attractors with a gain schedule (the paper's Fig 20): run the
//! schedule and name the attractor before the gain changes and the one at the end.

use crate::attractor::{Attractor, Trajectory};
use crate::cycle::{same_cycle, SAME_TOL};
use crate::run::PERIOD_TOL;
use crate::schedule::GainSchedule;
use capsule_plant::scene::Scene;
use capsule_plant::{SimError, Snapshot};
use serde::Serialize;

/// What a scheduled run did.
#[derive(Debug, Clone, Serialize)]
pub struct SwitchReport {
    /// The attractor over the last third of the periods before the gain first changes.
    pub before: Attractor,
    /// The attractor over the last third of the periods after the last change.
    pub after: Attractor,
    /// `before` and `after` are different orbits.
    pub switched: bool,
    /// `[x1 - x2, y1 - y2, y1]` at the end of every drive period.
    pub poincare: Vec<[f64; 3]>,
    /// Gain in every drive period.
    pub kp: Vec<f64>,
}

/// Run `scene` for its horizon under `schedule` (checked beforehand with
/// [`GainSchedule::validate`]); with `samples > 0` hand `sample` that many snapshots per period.
pub fn switch_run(
    scene: &Scene,
    schedule: &GainSchedule,
    samples: u32,
    sample: &mut dyn FnMut(&Snapshot),
) -> Result<SwitchReport, SimError> {
    let periods = scene.horizon.periods;
    let mut run = Trajectory::new(scene)?;
    if samples > 0 {
        sample(&run.snapshot());
    }
    for n in 0..periods {
        run.step(&schedule.law(scene, n), samples, sample)?;
    }
    let (start, end) = match schedule.pulse {
        Some(p) => (p.at as usize, (p.at + p.periods) as usize),
        None => (periods as usize, periods as usize),
    };
    let n = run.len();
    let before = run.classify(start - start / 3, start, PERIOD_TOL);
    let after = run.classify(n - (n - end) / 3, n, PERIOD_TOL);
    let switched = match (before.period, after.period) {
        (Some(_), Some(_)) => !same_cycle(&before.poincare, &after.poincare, SAME_TOL),
        (None, None) => false,
        _ => true,
    };
    Ok(SwitchReport {
        before,
        after,
        switched,
        kp: (0..periods).map(|n| schedule.kp_at(n)).collect(),
        poincare: run.points,
    })
}
