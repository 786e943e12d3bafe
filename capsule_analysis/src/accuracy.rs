//! What accuracy costs: every method at a ladder of settings against the tightest reference,
//! and the error a sampled (zero-order-hold) controller adds at each control rate.

use crate::run::{run, RunReport};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{ConstantForce, Method, SimError, Simulator, SolverConfig, Work};
use serde::Serialize;
use std::time::Instant;

/// One method at one setting, measured against the reference.
#[derive(Debug, Clone, Serialize)]
pub struct Point {
    /// Scene name.
    pub scene: String,
    /// Friction law.
    pub friction: &'static str,
    /// Method name.
    pub method: &'static str,
    /// Tolerance (adaptive) or step (fixed); 0 for exact.
    pub setting: f64,
    /// Error of the average progression.
    pub err_progression: f64,
    /// Error of the final capsule position.
    pub err_final_x2: f64,
    /// Largest error of a Poincaré point (max norm).
    pub err_poincare: f64,
    /// Best wall time of the run, seconds.
    pub wall_s: f64,
    /// Integrator work.
    pub work: Work,
}

/// Tolerances of the adaptive ladder.
pub const TOLERANCES: [f64; 6] = [1e-4, 1e-6, 1e-8, 1e-10, 1e-11, 1e-12];
/// Steps of the fixed ladder.
pub const STEPS: [f64; 5] = [3e-2, 1e-2, 3e-3, 1e-3, 3e-4];

/// Run `scene` `repeat` times (at least once); the last report and the best wall time, seconds.
pub fn best_of(scene: &Scene, repeat: u32) -> Result<(RunReport, f64), SimError> {
    let t0 = Instant::now();
    let mut report = run(scene)?;
    let mut best = t0.elapsed().as_secs_f64();
    for _ in 1..repeat {
        let t0 = Instant::now();
        report = run(scene)?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    Ok((report, best))
}

fn compare(
    scene: &Scene,
    method: &'static str,
    setting: f64,
    r: &RunReport,
    wall: f64,
    reference: &RunReport,
) -> Point {
    let err_poincare = r
        .poincare
        .iter()
        .zip(&reference.poincare)
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    Point {
        scene: scene.name.clone(),
        friction: scene.model.friction.name(),
        method,
        setting,
        err_progression: (r.avg_progression - reference.avg_progression).abs(),
        err_final_x2: (r.final_state.x2 - reference.final_state.x2).abs(),
        err_poincare,
        wall_s: wall,
        work: r.work,
    }
}

/// The reference run: exact where the law allows, else adaptive at 1e-13.
pub fn reference(scene: &Scene) -> Result<RunReport, SimError> {
    let mut s = scene.clone();
    s.solver = SolverConfig {
        tol: 1e-13,
        ..SolverConfig::most_accurate_for(&s.model)
    };
    run(&s)
}

/// Every method on `scene` against its reference; `repeat` runs per point, the best time kept.
pub fn ladder(scene: &Scene, repeat: u32) -> Result<Vec<Point>, SimError> {
    let reference = reference(scene)?;
    let mut out = Vec::new();
    if scene.model.friction.is_piecewise_linear() {
        let mut s = scene.clone();
        s.solver.method = Method::Exact;
        let (r, wall) = best_of(&s, repeat)?;
        out.push(compare(scene, "exact", 0.0, &r, wall, &reference));
    }
    for tol in TOLERANCES {
        let mut s = scene.clone();
        s.solver = SolverConfig {
            method: Method::Adaptive,
            tol,
            step: 0.0,
        };
        let (r, wall) = best_of(&s, repeat)?;
        out.push(compare(scene, "adaptive", tol, &r, wall, &reference));
    }
    for step in STEPS {
        let mut s = scene.clone();
        s.solver = SolverConfig {
            method: Method::Fixed,
            tol: 0.0,
            step,
        };
        let (r, wall) = best_of(&s, 1)?;
        out.push(compare(scene, "fixed", step, &r, wall, &reference));
    }
    Ok(out)
}

/// Average progression of `scene` when the feedback law is sampled `samples` times per drive
/// period and held (zero-order hold), as a ROS controller driving the plant does.
pub fn sampled_progression(scene: &Scene, samples: u32) -> Result<f64, SimError> {
    let law = AffineLaw::paper(scene.drive.alpha, scene.drive.omega, scene.control.kp);
    let period = law.period();
    let dt = period / samples as f64;
    let mut sim = Simulator::new(scene.model, scene.initial, 0.0, scene.solver)?;
    let mut x2_start = 0.0;
    for n in 0..scene.horizon.periods {
        if n == scene.horizon.transient {
            x2_start = sim.state().x2;
        }
        for i in 0..samples {
            let t0 = n as f64 * period + i as f64 * dt;
            let s = sim.state();
            let hold = ConstantForce(law.force_at(t0, s.x1, s.x2));
            let t1 = if i + 1 == samples {
                (n + 1) as f64 * period
            } else {
                t0 + dt
            };
            sim.advance(&hold, t1)?;
        }
    }
    let measured = (scene.horizon.periods - scene.horizon.transient) as f64;
    Ok((sim.state().x2 - x2_start) / measured)
}

/// One control rate and the error it adds to the average progression.
#[derive(Debug, Clone, Serialize)]
pub struct RatePoint {
    /// Control samples per drive period.
    pub samples_per_period: u32,
    /// Average progression with the sampled law.
    pub avg_progression: f64,
    /// Relative error against the continuous law.
    pub rel_error: f64,
}

/// The zero-order-hold error ladder for `scene`.
pub fn rate_ladder(scene: &Scene, rates: &[u32]) -> Result<Vec<RatePoint>, SimError> {
    let continuous = run(scene)?.avg_progression;
    rates
        .iter()
        .map(|&n| {
            let p = sampled_progression(scene, n)?;
            Ok(RatePoint {
                samples_per_period: n,
                avg_progression: p,
                rel_error: ((p - continuous) / continuous).abs(),
            })
        })
        .collect()
}
