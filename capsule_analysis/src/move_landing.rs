//! How closely the Move action's law ([`MoveRun`]) lands: the law closed around the exact
//! capsule of a scene, sampled at the node's rate with a zero-order hold, as the controller
//! node drives the simulated plant in lock-step (the command for a sample is held until the
//! next one). Measures the goal's outcome and where the capsule is some periods after it ended
//! (OFF holds it: the drift is what "stops" means).

use capsule_controller::move_goal::{MoveConfig, MoveOutcome, MoveRefusal, MoveRequest, MoveRun};
use capsule_plant::scene::Scene;
use capsule_plant::{AffineLaw, ConstantForce, SimError, Simulator};

/// One goal on one scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LandingCase {
    /// The goal.
    pub request: MoveRequest,
    /// Time in OFF before the goal arrives \[s\] (sets the drive phase it arrives at).
    pub start_s: f64,
    /// Sample rate \[Hz\].
    pub rate_hz: f64,
    /// Longest run after the goal arrives \[s\].
    pub horizon_s: f64,
    /// Drive periods in OFF after the end at which the drift is read.
    pub after_periods: u32,
}

/// What a goal did.
#[derive(Debug, Clone, PartialEq)]
pub struct Landing {
    /// The law's outcome (`None`: no end within the horizon).
    pub outcome: Option<MoveOutcome>,
    /// Capsule travel from the goal's reference to `after_periods` drive periods after the
    /// end, at a drive-period start \[m\].
    pub settled_travel_m: f64,
}

/// Why a landing run did not run.
#[derive(Debug, thiserror::Error)]
pub enum LandingError {
    /// The law refused the goal.
    #[error("goal refused: {0}")]
    Refused(#[from] MoveRefusal),
    /// The simulator failed.
    #[error(transparent)]
    Sim(#[from] SimError),
}

/// Runs `case` on `scene`'s capsule (from its initial state) with `config`.
pub fn land(
    scene: &Scene,
    case: &LandingCase,
    config: MoveConfig,
) -> Result<Landing, LandingError> {
    let scale = scene.physical;
    let mut law = AffineLaw::paper(scene.drive.alpha, scene.drive.omega, 0.0);
    let period_s = law.period() * scale.time_s();
    let mut run = MoveRun::start(case.request, config, period_s)?;
    let mut sim = Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver())?;
    let dt = 1.0 / case.rate_hz;
    let l = scale.length_m();
    let mut origin = None;
    let mut ended_at: Option<u64> = None;
    let after = (f64::from(case.after_periods) * period_s / dt).ceil() as u64;
    let steps = ((case.start_s + case.horizon_s) / dt).ceil() as u64;
    let mut settled_travel_m = f64::NAN;
    for k in 0..steps {
        let t = k as f64 * dt;
        let s = sim.snapshot();
        let (x1, x2) = (s.state.x1, s.state.x2);
        law.kp = if t >= case.start_s {
            run.sample(t, x2 * l)
        } else {
            0.0
        };
        if origin.is_none() && run.progress().travelled_m != 0.0 {
            origin = Some(x2 * l - run.progress().travelled_m);
        }
        match ended_at {
            None if run.outcome().is_some() => ended_at = Some(k),
            Some(e) if k >= e + after => {
                // the first sample at or after a drive-period start, as the law reads them
                let phase = (t / period_s).fract() * period_s;
                if phase < dt {
                    settled_travel_m = x2 * l - origin.unwrap_or(f64::NAN);
                    break;
                }
            }
            _ => {}
        }
        let tau = t / scale.time_s();
        let f = law.force_at(tau, x1, x2);
        sim.advance(&ConstantForce(f), (t + dt) / scale.time_s())?;
    }
    Ok(Landing {
        outcome: run.outcome().cloned(),
        settled_travel_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_controller::move_goal::MoveEnd;

    fn control_point() -> Scene {
        let text = include_str!("../../scenes/control_point.toml");
        Scene::from_toml_str(text, "control_point.toml").unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn forward_and_backward_goals_land_within_the_default_tolerance_at_the_control_point(
    ) -> Result<(), LandingError> {
        let scene = control_point();
        for (distance_m, start_s) in [(0.01, 0.3), (-0.005, 0.345)] {
            let case = LandingCase {
                request: MoveRequest {
                    distance_m,
                    tolerance_m: 0.0,
                    timeout_s: 0.0,
                },
                start_s,
                rate_hz: 1000.0,
                horizon_s: 10.0,
                after_periods: 10,
            };
            let r = land(&scene, &case, MoveConfig::DEFAULT)?;
            let Some(out) = r.outcome else {
                panic!("{distance_m}: no end")
            };
            assert_eq!(out.end, MoveEnd::Reached, "{distance_m}: {out:?}");
            let tol = MoveConfig::DEFAULT.default_tolerance_m;
            assert!(out.error_m.abs() <= tol, "{distance_m}: {out:?}");
            // OFF holds it: 10 periods later it is still within the tolerance
            assert!(
                (r.settled_travel_m - distance_m).abs() <= tol,
                "{distance_m}: settled at {} m",
                r.settled_travel_m
            );
            assert!(out.elapsed_s < 3.0, "{distance_m}: {out:?}");
        }
        Ok(())
    }
}
