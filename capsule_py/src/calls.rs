//! The bound calls: each parses the scene, runs the library function named in its doc off the
//! interpreter ([`crate::interrupt::run`]) and answers JSON text as the `capsule` command prints
//! it, with large arrays as little-endian bytes. Refused input raises `ValueError` (a scene:
//! `SceneError`) before work starts, a failure while working `SimulationError`, Ctrl-C
//! `Interrupted` with what finished as its `partial`.

use crate::exceptions::{Interrupted, SimulationError};
use crate::interrupt;
use crate::scene::parse;
use capsule_analysis::basin::{BasinRun, Cell, CellConfig, Grid, Method, Plane};
use capsule_analysis::basin_cells::basins_by;
use capsule_analysis::basin_summary::summary;
use capsule_analysis::continuation::{continue_branch_observed, ContinuationConfig};
use capsule_analysis::lyapunov::lyapunov_sweep;
use capsule_analysis::stability::of_run;
use capsule_analysis::{run_scheduled_until, sweep_following, GainSchedule, Param, Pulse};
use capsule_plant::scene::Scene;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::sync::atomic::{AtomicBool, Ordering};

/// Values per piece of a sweep between two looks at Ctrl-C.
const SWEEP_CHUNK: usize = 64;

fn to_json<T: serde::Serialize>(v: &T) -> PyResult<String> {
    serde_json::to_string(v).map_err(|e| SimulationError::new_err(e.to_string()))
}

fn f64_bytes<'py>(py: Python<'py>, v: impl IntoIterator<Item = f64>) -> Bound<'py, PyBytes> {
    let buf: Vec<u8> = v.into_iter().flat_map(f64::to_le_bytes).collect();
    PyBytes::new(py, &buf)
}

/// Ctrl-C stopped the work: `Interrupted`, with what finished as `partial`.
fn interrupted(py: Python<'_>, signal: PyErr, what: String, partial: Option<String>) -> PyErr {
    let e = Interrupted::new_err(what);
    // the signal's own exception (KeyboardInterrupt) as the cause
    e.set_cause(py, Some(signal));
    if let Err(set) = e.value(py).setattr("partial", partial) {
        return set;
    }
    e
}

/// The parameter called `name` ([`Param::parse`]).
fn param(name: &str) -> PyResult<Param> {
    Param::parse(name).ok_or_else(|| {
        let names: Vec<&str> = Param::ALL.iter().map(|p| p.name()).collect();
        PyValueError::new_err(format!(
            "param `{name}`: not a scene parameter ({})",
            names.join(", ")
        ))
    })
}

/// The scene parameters a sweep, a basin sweep or a continuation can vary ([`Param::ALL`]).
#[pyfunction]
pub fn params() -> Vec<&'static str> {
    Param::ALL.iter().map(|p| p.name()).collect()
}

/// One run ([`run_scheduled_until`]) and, when asked, its stability ([`of_run`]): the JSON of
/// `capsule simulate --json` (with `stability`, of `--stability`), and with `samples_per_period > 0` the time history as 10 columns of f64
/// (tau, x1, y1, x2, y2, stuck, contact, friction, contact and actuator force) row by row.
#[pyfunction]
#[pyo3(signature = (scene, samples_per_period=0, pulse=None, kp_after=None, stability=false))]
pub fn simulate<'py>(
    py: Python<'py>,
    scene: &str,
    samples_per_period: u32,
    pulse: Option<(f64, u32, u32)>,
    kp_after: Option<f64>,
    stability: bool,
) -> PyResult<(String, Option<Bound<'py, PyBytes>>)> {
    let scene = parse(scene)?;
    let before = scene.control.kp;
    let schedule = match pulse {
        Some((kp, at, periods)) => GainSchedule {
            before,
            pulse: Some(Pulse { kp, at, periods }),
            after: kp_after.unwrap_or(before),
        },
        None if kp_after.is_some() => {
            return Err(PyValueError::new_err(
                "kp_after: needs a pulse (pulse_kp, pulse_at)",
            ))
        }
        None => GainSchedule::constant(before),
    };
    schedule
        .validate(scene.horizon.periods)
        .map_err(|(k, r)| PyValueError::new_err(format!("{}: {r}", k.replace('-', "_"))))?;
    let t0 = std::time::Instant::now();
    let ((report, rows), signal) = interrupt::run(py, |cancel| {
        let mut rows: Vec<[f64; 10]> = Vec::new();
        let report = run_scheduled_until(
            &scene,
            &schedule,
            samples_per_period,
            &mut |s| {
                let st = s.state;
                rows.push([
                    s.tau,
                    st.x1,
                    st.y1,
                    st.x2,
                    st.y2,
                    f64::from(u8::from(s.stuck)),
                    f64::from(u8::from(s.contact)),
                    s.friction_force,
                    s.contact_force,
                    s.actuator_force,
                ])
            },
            &mut |_| !cancel.load(Ordering::Relaxed),
        );
        (report, rows)
    });
    let report =
        report.map_err(|e| SimulationError::new_err(format!("simulating {}: {e}", scene.name)))?;
    let history = (samples_per_period > 0).then(|| f64_bytes(py, rows.iter().flatten().copied()));
    let Some(report) = report else {
        let signal = signal.unwrap_or_else(|| PyValueError::new_err("stopped"));
        return Err(interrupted(
            py,
            signal,
            format!("interrupted: no summary of {}", scene.name),
            None,
        ));
    };
    let stab = if stability {
        let (s, _) = interrupt::run(py, |_| of_run(&scene, &schedule, &report));
        Some(s)
    } else {
        None
    };
    #[derive(serde::Serialize)]
    struct Output<'a> {
        scene: &'a Scene,
        schedule: &'a GainSchedule,
        #[serde(flatten)]
        report: &'a capsule_analysis::RunReport,
        #[serde(flatten)]
        stability: Option<capsule_analysis::stability::RunStability>,
        wall_time_s: f64,
    }
    let out = Output {
        scene: &scene,
        schedule: &schedule,
        report: &report,
        stability: stab,
        wall_time_s: t0.elapsed().as_secs_f64(),
    };
    Ok((to_json(&out)?, history))
}

/// A sweep of `param` over `values`: [`capsule_analysis::sweep()`] (every value from the scene's
/// initial state, in parallel) or [`sweep_following`] (each from the previous final state), and
/// with `lyapunov` the spectra ([`lyapunov_sweep`]): the JSON rows `capsule sweep` writes.
#[pyfunction]
#[pyo3(signature = (scene, param_name, values, follow=false, lyapunov=false))]
pub fn sweep(
    py: Python<'_>,
    scene: &str,
    param_name: &str,
    values: Vec<f64>,
    follow: bool,
    lyapunov: bool,
) -> PyResult<String> {
    let scene = parse(scene)?;
    let p = param(param_name)?;
    if let Some(v) = values.iter().find(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "values: {v} is not a finite number"
        )));
    }
    let (rows, signal) = interrupt::run(py, |cancel| {
        let mut points = Vec::with_capacity(values.len());
        let mut start = scene.clone();
        for part in values.chunks(SWEEP_CHUNK) {
            if cancel.load(Ordering::Relaxed) {
                break;
            }
            let done = if follow {
                let done = sweep_following(&start, p, part, &|| {});
                if let Some(r) = done.iter().rev().find_map(|q| q.result.as_ref().ok()) {
                    start.initial = r.final_state;
                }
                done
            } else {
                capsule_analysis::sweep(&scene, p, part, &|| {})
            };
            points.extend(done);
        }
        let spectra = lyapunov.then(|| lyapunov_sweep(&scene, p, &values[..points.len()], &|| {}));
        let rows: Vec<serde_json::Value> = points
            .iter()
            .enumerate()
            .map(|(i, point)| {
                let mut v = serde_json::to_value(point).unwrap_or_default();
                if let (Some(ls), Some(obj)) = (&spectra, v.as_object_mut()) {
                    obj.insert(
                        "lyapunov".into(),
                        serde_json::to_value(&ls[i]).unwrap_or_default(),
                    );
                }
                v
            })
            .collect();
        rows
    });
    let text = to_json(&rows)?;
    match signal {
        Some(s) if rows.len() < values.len() => Err(interrupted(
            py,
            s,
            format!(
                "interrupted: {} of {} values done",
                rows.len(),
                values.len()
            ),
            Some(text),
        )),
        _ => Ok(text),
    }
}

/// Basins of attraction on a grid of initial states ([`basin_map`], then [`summary`]): the
/// JSON summary of `capsule basins --json` and the label grid as little-endian i32 row by row
/// (row 0 at the low `y` end): the attractor's position in `attractors`, -1 failed, -2 not
/// computed. `basin_method` is `known-cells` (with `cell` its cube size, `None` for the
/// default) or `per-state` ([`Method`]).
#[pyfunction]
#[pyo3(signature = (scene, nx, ny, x_range, y_range, plane, known_tol, basin_method, cell, cell_hits, cell_check))]
#[allow(clippy::too_many_arguments)]
pub fn basins<'py>(
    py: Python<'py>,
    scene: &str,
    nx: usize,
    ny: usize,
    x_range: (f64, f64),
    y_range: (f64, f64),
    plane: &str,
    known_tol: f64,
    basin_method: &str,
    cell: Option<f64>,
    cell_hits: u32,
    cell_check: usize,
) -> PyResult<(String, Bound<'py, PyBytes>)> {
    let scene = parse(scene)?;
    let grid = Grid {
        plane: Plane::parse(plane).map_err(|e| PyValueError::new_err(format!("plane {e}")))?,
        nx,
        ny,
        x_range,
        y_range,
    };
    grid.validate()
        .map_err(|(k, r)| PyValueError::new_err(format!("{}: {r}", k.replace('-', "_"))))?;
    if !(known_tol >= 0.0 && known_tol.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "known_tol {known_tol}: must be a finite number >= 0"
        )));
    }
    let method = match (basin_method, cell) {
        ("per-state", None) => Method::PerState,
        ("per-state", Some(_)) => {
            return Err(PyValueError::new_err(
                "cell: only the known-cells method has cells (basin_method=\"known-cells\")",
            ))
        }
        ("known-cells", _) => {
            let c = CellConfig {
                size: cell.unwrap_or(CellConfig::for_grid(&grid).size),
                hits: cell_hits,
                check: cell_check,
            };
            c.validate(&grid)
                .map_err(|(k, r)| PyValueError::new_err(format!("{}: {r}", k.replace('-', "_"))))?;
            Method::KnownCells(c)
        }
        (other, _) => {
            return Err(PyValueError::new_err(format!(
                "basin_method {other:?}: must be \"known-cells\" or \"per-state\""
            )))
        }
    };
    let mut run = BasinRun::new(&scene, grid);
    run.config.known_tol = known_tol;
    let t0 = std::time::Instant::now();
    let (map, signal) = interrupt::run(py, |cancel: &AtomicBool| {
        basins_by(&method, &run, &|| {}, cancel)
    });
    let wall = t0.elapsed().as_secs_f64();
    let order = map.catalogue.ordered();
    let labels: Vec<u8> = map
        .cells
        .iter()
        .map(|c| match c {
            Cell::Attractor { index, .. } => order
                .iter()
                .position(|(i, _)| i == index)
                .map_or(-1, |p| p as i32),
            Cell::Failed(_) => -1,
            Cell::Pending => -2,
        })
        .flat_map(i32::to_le_bytes)
        .collect();
    let text = to_json(&summary(&map, wall, &run.config))?;
    match signal {
        Some(s) if map.pending() > 0 => Err(interrupted(
            py,
            s,
            format!("interrupted: {} initial states not computed", map.pending()),
            Some(text),
        )),
        _ => Ok((text, PyBytes::new(py, &labels))),
    }
}

/// Pseudo-arclength continuation of the periodic orbit the scene settles on
/// ([`continue_branch_observed`]): the branch's JSON as `capsule continue` writes it. Ctrl-C
/// ends the branch at the next point and raises `Interrupted` with the branch so far.
#[pyfunction]
#[pyo3(signature = (scene, param_name, to, arc_step=0.01, max_arc_step=0.02, max_points=5000))]
pub fn continue_branch(
    py: Python<'_>,
    scene: &str,
    param_name: &str,
    to: f64,
    arc_step: f64,
    max_arc_step: f64,
    max_points: usize,
) -> PyResult<String> {
    let scene = parse(scene)?;
    let p = param(param_name)?;
    if !to.is_finite() {
        return Err(PyValueError::new_err(format!(
            "to {to}: must be a finite number"
        )));
    }
    if !(arc_step > 0.0 && max_arc_step >= arc_step && max_arc_step <= 10.0) {
        return Err(PyValueError::new_err(format!(
            "arc_step {arc_step}, max_arc_step {max_arc_step}: need 0 < arc_step <= max_arc_step <= 10"
        )));
    }
    if max_points < 2 {
        return Err(PyValueError::new_err("max_points: must be at least 2"));
    }
    let mut settings = ContinuationConfig::new(p, to);
    settings.step = arc_step;
    settings.max_step = max_arc_step;
    settings.max_points = max_points;
    let (branch, signal) = interrupt::run(py, |cancel| {
        continue_branch_observed(&scene, &settings, &mut |_| !cancel.load(Ordering::Relaxed))
    });
    let branch = branch.map_err(|e| {
        SimulationError::new_err(format!(
            "continuing {} from {} = {}: {e}",
            scene.name,
            p.name(),
            p.value(&scene)
        ))
    })?;
    let text = to_json(&branch)?;
    match signal {
        Some(s) => Err(interrupted(
            py,
            s,
            format!("interrupted: {} branch points done", branch.points.len()),
            Some(text),
        )),
        None => Ok(text),
    }
}

/// Floquet multipliers of the period-`period` orbit through `x` = (x1 - x2, y1, y2) at drive
/// phase 0 ([`capsule_analysis::floquet::floquet`]); without `x`, of the orbit the scene's run
/// ends on (as `capsule simulate` reports them).
#[pyfunction]
#[pyo3(signature = (scene, x=None, period=None))]
pub fn floquet(
    py: Python<'_>,
    scene: &str,
    x: Option<[f64; 3]>,
    period: Option<usize>,
) -> PyResult<String> {
    let scene = parse(scene)?;
    if period == Some(0) {
        return Err(PyValueError::new_err("period: must be at least 1"));
    }
    let (out, _) = interrupt::run(py, |_| -> Result<_, String> {
        let (x, k) = match (x, period) {
            (Some(x), Some(k)) => (x, k),
            (Some(x), None) => (x, 1),
            (None, _) => {
                let r = capsule_analysis::run(&scene).map_err(|e| e.to_string())?;
                let k = period.or(r.period).ok_or_else(|| {
                    "the run is not periodic (no period <= 64): no multipliers".to_string()
                })?;
                let f = r.final_state;
                ([f.x1 - f.x2, f.y1, f.y2], k)
            }
        };
        capsule_analysis::floquet::floquet(&scene, x, k).map_err(|e| e.to_string())
    });
    to_json(&out.map_err(|e| SimulationError::new_err(format!("floquet: {e}")))?)
}

/// The Lyapunov spectrum of the scene's run ([`capsule_analysis::lyapunov::lyapunov`]).
#[pyfunction]
pub fn lyapunov(py: Python<'_>, scene: &str) -> PyResult<String> {
    let scene = parse(scene)?;
    let (out, _) = interrupt::run(py, |_| capsule_analysis::lyapunov::lyapunov(&scene));
    to_json(&out.map_err(|e| SimulationError::new_err(format!("lyapunov: {e}")))?)
}

/// A twin identified from a recording ([`capsule_analysis::identify::identify_and_validate`],
/// the recording read by [`capsule_record::series::series`]): the JSON of `capsule identify
/// --json`. `segment`: `(t0, t1)` in seconds; `validate`: another recording.
#[pyfunction]
#[pyo3(signature = (recording, scene, free, segment=None, validate=None, patience=None))]
pub fn identify(
    py: Python<'_>,
    recording: std::path::PathBuf,
    scene: &str,
    free: Vec<String>,
    segment: Option<(f64, f64)>,
    validate: Option<std::path::PathBuf>,
    patience: Option<usize>,
) -> PyResult<String> {
    use capsule_analysis::identify::{self as id, Segment, Settings};
    let scene = parse(scene)?;
    id::free_keys(&scene, &free).map_err(|e| PyValueError::new_err(e.to_string()))?;
    let read = |p: &std::path::Path| {
        capsule_record::series::series(p).map_err(|e| PyValueError::new_err(e.to_string()))
    };
    let recorded = |s: capsule_record::series::Series| {
        let acted = s.forces.acted();
        capsule_analysis::twin::Recorded::new(s.h_s, s.rel_m, s.x2_m, s.command_n).with_acted(acted)
    };
    let rec = read(&recording)?;
    let forces = rec.forces.name();
    let rec = recorded(rec);
    let other = validate.as_deref().map(read).transpose()?.map(recorded);
    let segment = match segment {
        Some((t0_s, t1_s)) if t0_s >= 0.0 && t1_s > t0_s => Some(Segment { t0_s, t1_s }),
        Some((a, b)) => {
            return Err(PyValueError::new_err(format!(
                "segment ({a}, {b}): give (t0, t1) in seconds, 0 <= t0 < t1"
            )))
        }
        None => None,
    };
    let settings = Settings {
        patience: patience
            .unwrap_or(Settings::default().patience)
            .clamp(1, 1000),
        ..Settings::default()
    };
    let t0 = std::time::Instant::now();
    let (out, _) = interrupt::run(py, |_| {
        id::identify_and_validate(&scene, &rec, &free, segment, other.as_ref(), &settings)
    });
    let (_, outcome) = out.map_err(|e| match e {
        id::IdentifyError::NoConvergence(_) | id::IdentifyError::Pinned { .. } => {
            SimulationError::new_err(format!("identify: {e}"))
        }
        other => PyValueError::new_err(format!("{}: {other}", recording.display())),
    })?;
    to_json(&id::Printed {
        recording: recording.display().to_string(),
        forces: forces.to_string(),
        outcome: &outcome,
        out: None,
        wall_time_s: t0.elapsed().as_secs_f64(),
    })
}
