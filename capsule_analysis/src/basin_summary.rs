//! A basin map's summary, as `capsule basins --json` prints it and the Python bindings return
//! it: the attractors in legend order with their labels and shares, the grid, the work.

use crate::attractor::SettleConfig;
use crate::basin::{BasinMap, BasinWork, CellCheck, Method};
use serde::Serialize;

/// One map's summary as printed with `--json`.
#[derive(Debug, Serialize)]
pub struct Summary {
    /// The attractors in legend order.
    pub attractors: Vec<AttractorOut>,
    /// The grid.
    pub grid: GridOut,
    /// The work done.
    pub work: WorkOut,
    /// How the states were labelled, with the method's settings.
    pub basin_method: Method,
    /// For the known-cells method: the sample rerun per state.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub check: Option<CellCheck>,
    /// Why the map may be wrong, if it may.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub warning: Option<String>,
}

/// An attractor with its label and share of the grid.
#[derive(Debug, Serialize)]
pub struct AttractorOut {
    /// Legend label (`P1`, `P3a`, `chaos`).
    pub label: String,
    /// Period in drive periods, if periodic.
    pub period: Option<usize>,
    /// Impacts per drive period.
    pub impacts_per_period: f64,
    /// Capsule advance per drive period.
    pub avg_progression: f64,
    /// Its Poincaré points `[x1 - x2, y1 - y2, y1]`.
    pub poincare: Vec<[f64; 3]>,
    /// Share of the grid that ends on it.
    pub fraction: f64,
}

/// The grid as printed.
#[derive(Debug, Serialize)]
pub struct GridOut {
    /// The plane's coordinates (horizontal, vertical).
    pub plane: [&'static str; 2],
    /// Columns.
    pub nx: usize,
    /// Rows.
    pub ny: usize,
    /// Horizontal range (cell centres at both ends).
    pub x_range: [f64; 2],
    /// Vertical range.
    pub y_range: [f64; 2],
    /// Cells not computed (interrupted).
    pub pending: usize,
}

/// The work as printed.
#[derive(Debug, Serialize)]
pub struct WorkOut {
    /// Run and integrator totals.
    #[serde(flatten)]
    pub totals: BasinWork,
    /// Wall time in seconds.
    pub wall_s: f64,
    /// Wall time per initial state in milliseconds.
    pub ms_per_state: f64,
    /// Drive periods integrated per initial state.
    pub periods_per_state: f64,
    /// Drive periods a run may take at most.
    pub max_periods: u32,
    /// Distance within which a run follows a known attractor.
    pub known_tol: f64,
}

/// A map's summary, labels in legend order.
pub fn summary(map: &BasinMap, wall_s: f64, cfg: &SettleConfig) -> Summary {
    let g = &map.grid;
    let attractors = map
        .catalogue
        .ordered()
        .into_iter()
        .map(|(i, label)| {
            let a = &map.catalogue.attractors[i];
            AttractorOut {
                label,
                period: a.period,
                impacts_per_period: a.impacts_per_period,
                avg_progression: a.avg_progression,
                poincare: a.poincare.clone(),
                fraction: map.fraction(i),
            }
        })
        .collect();
    Summary {
        attractors,
        grid: GridOut {
            plane: [g.plane.x.name(), g.plane.y.name()],
            nx: g.nx,
            ny: g.ny,
            x_range: [g.x_range.0, g.x_range.1],
            y_range: [g.y_range.0, g.y_range.1],
            pending: map.pending(),
        },
        work: WorkOut {
            totals: map.work,
            wall_s,
            ms_per_state: 1e3 * wall_s / map.work.runs.max(1) as f64,
            periods_per_state: map.work.periods_per_run(),
            max_periods: cfg.max_periods,
            known_tol: cfg.known_tol,
        },
        basin_method: map.method,
        check: map.check,
        warning: match (map.method, map.check) {
            (Method::KnownCells(c), Some(k)) => k.warning(c.size),
            _ => None,
        },
    }
}
