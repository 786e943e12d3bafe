//! The stability of the attractor a run ended on, as `capsule simulate --json` reports it and
//! the Python bindings return it: the Floquet multipliers when the run is periodic, the Lyapunov
//! spectrum, and a note for what could not be computed. One place, so both say the same.

use crate::floquet::{floquet, Floquet};
use crate::lyapunov::{lyapunov, Lyapunov};
use crate::run::RunReport;
use crate::schedule::GainSchedule;
use capsule_plant::scene::Scene;
use serde::Serialize;

/// A run's stability: what could be computed, and why the rest could not.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RunStability {
    /// Floquet multipliers of the periodic orbit found (periodic results only).
    pub floquet: Option<Floquet>,
    /// Lyapunov spectrum over the measured periods.
    pub lyapunov: Option<Lyapunov>,
    /// Why `floquet` or `lyapunov` is missing, if it is.
    pub stability_note: Option<String>,
}

/// The stability of the attractor `report` (a run of `scene` under `schedule`) ended on. Under
/// a schedule whose gain changes, the multipliers are those of the gain after it and the
/// Lyapunov exponents are not computed (the law changes during the run).
pub fn of_run(scene: &Scene, schedule: &GainSchedule, report: &RunReport) -> RunStability {
    if schedule.pulse.is_none() && schedule.after == scene.control.kp {
        return of_scene(scene, report);
    }
    let mut after = scene.clone();
    after.control.kp = schedule.after;
    let RunStability {
        floquet,
        stability_note,
        ..
    } = of_scene(&after, report);
    let skip = "lyapunov: not computed under a gain schedule (the law changes during the run)";
    RunStability {
        floquet,
        lyapunov: None,
        stability_note: Some(stability_note.map_or(skip.to_string(), |n| format!("{n}; {skip}"))),
    }
}

/// Multipliers if periodic, the Lyapunov spectrum, and a note for what failed (a law with
/// memory, a grazing orbit).
fn of_scene(scene: &Scene, r: &RunReport) -> RunStability {
    let mut notes = Vec::new();
    let floquet = r.period.and_then(|k| {
        let f = r.final_state;
        floquet(scene, [f.x1 - f.x2, f.y1, f.y2], k)
            .map_err(|e| notes.push(format!("floquet: {e}")))
            .ok()
    });
    let lyapunov = lyapunov(scene)
        .map_err(|e| notes.push(format!("lyapunov: {e}")))
        .ok();
    let stability_note = (!notes.is_empty()).then(|| notes.join("; "));
    RunStability {
        floquet,
        lyapunov,
        stability_note,
    }
}
