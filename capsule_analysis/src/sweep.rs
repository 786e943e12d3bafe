//! One parameter over a range, every value an independent run, in parallel.

use crate::run::{run, RunReport};
use capsule_plant::scene::Scene;
use capsule_plant::SimError;
use rayon::prelude::*;
use serde::Serialize;

/// A sweepable parameter, named after the paper's symbol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Param {
    /// Drive amplitude.
    Alpha,
    /// Drive frequency.
    Omega,
    /// Mass ratio.
    Gamma,
    /// Stiffness ratio.
    Beta,
    /// Gap.
    Delta,
    /// Damping ratio.
    Xi,
    /// Feedback gain.
    Kp,
}

impl Param {
    /// Every parameter: the one list the command line's choices come from.
    pub const ALL: [Param; 7] = [
        Param::Alpha,
        Param::Omega,
        Param::Gamma,
        Param::Beta,
        Param::Delta,
        Param::Xi,
        Param::Kp,
    ];

    /// The parameter called `name` (see [`Param::name`]).
    pub fn parse(name: &str) -> Option<Self> {
        Param::ALL.into_iter().find(|p| p.name() == name)
    }

    /// The parameter's name (as [`Param::parse`] reads it).
    pub fn name(self) -> &'static str {
        match self {
            Param::Alpha => "alpha",
            Param::Omega => "omega",
            Param::Gamma => "gamma",
            Param::Beta => "beta",
            Param::Delta => "delta",
            Param::Xi => "xi",
            Param::Kp => "kp",
        }
    }

    /// The parameter's value in `scene`.
    pub fn value(self, scene: &Scene) -> f64 {
        match self {
            Param::Alpha => scene.drive.alpha,
            Param::Omega => scene.drive.omega,
            Param::Gamma => scene.model.capsule.gamma,
            Param::Beta => scene.model.capsule.beta,
            Param::Delta => scene.model.capsule.delta,
            Param::Xi => scene.model.capsule.xi,
            Param::Kp => scene.control.kp,
        }
    }

    /// A copy of `scene` with this parameter set to `v`.
    pub fn apply(self, scene: &Scene, v: f64) -> Scene {
        let mut s = scene.clone();
        match self {
            Param::Alpha => s.drive.alpha = v,
            Param::Omega => s.drive.omega = v,
            Param::Gamma => s.model.capsule.gamma = v,
            Param::Beta => s.model.capsule.beta = v,
            Param::Delta => s.model.capsule.delta = v,
            Param::Xi => s.model.capsule.xi = v,
            Param::Kp => s.control.kp = v,
        }
        s
    }
}

/// One value of a sweep and what its run measured.
#[derive(Debug, Clone, Serialize)]
pub struct SweepPoint {
    /// The parameter value.
    pub value: f64,
    /// The run's measurements, or why it failed.
    pub result: Result<RunReport, String>,
}

/// Run `scene` for every value of `param` in `values` in order, each run starting from the
/// previous run's final state (continuation: it follows one attractor, as bifurcation diagrams
/// are usually drawn); `progress` is called once per finished value.
pub fn sweep_following(
    scene: &Scene,
    param: Param,
    values: &[f64],
    progress: &(dyn Fn() + Sync),
) -> Vec<SweepPoint> {
    let mut start = scene.initial;
    values
        .iter()
        .map(|&v| {
            let mut s = param.apply(scene, v);
            s.initial = start;
            let result = s
                .validate()
                .map_err(|e| e.to_string())
                .and_then(|()| run(&s).map_err(|e: SimError| e.to_string()));
            if let Ok(r) = &result {
                start = r.final_state;
            }
            progress();
            SweepPoint { value: v, result }
        })
        .collect()
}

/// Run `scene` for every value of `param` in `values`, in parallel, each from the scene's
/// initial state; `progress` is called once per finished value (from worker threads).
pub fn sweep(
    scene: &Scene,
    param: Param,
    values: &[f64],
    progress: &(dyn Fn() + Sync),
) -> Vec<SweepPoint> {
    let results = at_each_value(scene, param, values, progress, |s| {
        run(s).map_err(|e| e.to_string())
    });
    values
        .iter()
        .zip(results)
        .map(|(&value, result)| SweepPoint { value, result })
        .collect()
}

/// `f` of the scene at every value of `param` in `values`, in parallel, each from the scene's
/// initial state; a value the scene refuses gives the reason; `progress` is called once per
/// finished value (from worker threads).
pub fn at_each_value<T: Send>(
    scene: &Scene,
    param: Param,
    values: &[f64],
    progress: &(dyn Fn() + Sync),
    f: impl Fn(&Scene) -> Result<T, String> + Sync,
) -> Vec<Result<T, String>> {
    values
        .par_iter()
        .map(|&v| {
            let s = param.apply(scene, v);
            let r = s.validate().map_err(|e| e.to_string()).and_then(|()| f(&s));
            progress();
            r
        })
        .collect()
}
