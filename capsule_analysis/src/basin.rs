//! Basins of attraction: a grid of initial states on a plane through the state space, each run
//! until it settles (see [`crate::attractor`]) or, by [`Method::KnownCells`], until it enters
//! cells of the Poincaré section whose basin is known ([`crate::basin_cells`]), in parallel,
//! labelled by the attractor it ends on.

use crate::attractor::{settle, Catalogue, Outcome, SettleConfig, Stop};
use crate::schedule::GainSchedule;
use capsule_plant::scene::Scene;
use capsule_plant::{SimError, State, Work};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// A coordinate of the initial state that a plane axis sets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Coord {
    /// Mass displacement.
    X1,
    /// Mass velocity.
    Y1,
    /// Capsule displacement.
    X2,
    /// Capsule velocity.
    Y2,
    /// Relative displacement `x1 - x2`.
    RelX,
    /// Relative velocity `y1 - y2`.
    RelY,
}

impl Coord {
    const ALL: [Coord; 6] = [
        Coord::X1,
        Coord::Y1,
        Coord::X2,
        Coord::Y2,
        Coord::RelX,
        Coord::RelY,
    ];

    /// The name on the command line and in outputs.
    pub fn name(self) -> &'static str {
        match self {
            Coord::X1 => "x1",
            Coord::Y1 => "y1",
            Coord::X2 => "x2",
            Coord::Y2 => "y2",
            Coord::RelX => "x1-x2",
            Coord::RelY => "y1-y2",
        }
    }

    /// Parse a name as printed by [`Coord::name`].
    pub fn parse(name: &str) -> Option<Self> {
        let name: String = name.chars().filter(|c| !c.is_whitespace()).collect();
        Coord::ALL.into_iter().find(|c| c.name() == name)
    }

    /// The state variables this coordinate involves (`x1 = 0, y1 = 1, x2 = 2, y2 = 3`).
    fn vars(self) -> &'static [usize] {
        match self {
            Coord::X1 => &[0],
            Coord::Y1 => &[1],
            Coord::X2 => &[2],
            Coord::Y2 => &[3],
            Coord::RelX => &[0, 2],
            Coord::RelY => &[1, 3],
        }
    }
}

/// A plane of initial states: two coordinates, the rest of the state from a base state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Plane {
    /// Horizontal axis.
    pub x: Coord,
    /// Vertical axis.
    pub y: Coord,
}

impl Plane {
    /// The paper's phase plane `(x1 - x2, y1 - y2)`.
    pub const RELATIVE: Plane = Plane {
        x: Coord::RelX,
        y: Coord::RelY,
    };

    /// Parse `A,B` with each a coordinate name (`x1`, `y1`, `x2`, `y2`, `x1-x2`, `y1-y2`); the
    /// two must be independent (a plane, not a line).
    pub fn parse(text: &str) -> Result<Plane, String> {
        let parts: Vec<&str> = text.split(',').collect();
        let [a, b] = parts[..] else {
            return Err(format!("`{text}`: expected two coordinates A,B"));
        };
        let coord = |s: &str| {
            Coord::parse(s).ok_or_else(|| {
                format!("`{s}` is not a state coordinate (x1, y1, x2, y2, x1-x2, y1-y2)")
            })
        };
        let plane = Plane {
            x: coord(a)?,
            y: coord(b)?,
        };
        if plane.x == plane.y {
            return Err(format!("`{text}`: the two axes are the same coordinate"));
        }
        Ok(plane)
    }

    /// The state at `(a, b)` on the plane through `base`. A relative coordinate moves the mass
    /// (`x1 = x2 + a`), or the capsule if the mass's own coordinate is the other axis.
    pub fn state(&self, base: State, a: f64, b: f64) -> State {
        let mut v = base.to_array();
        let axes = [(self.x, a), (self.y, b)];
        for (c, val) in axes {
            if let [k] = c.vars() {
                v[*k] = val;
            }
        }
        for (c, val) in axes {
            if let [m, k] = c.vars() {
                if axes.iter().any(|(o, _)| o.vars() == [*m]) {
                    v[*k] = v[*m] - val;
                } else {
                    v[*m] = v[*k] + val;
                }
            }
        }
        State::from_array(v)
    }
}

/// Cells on one side at most: larger grids are refused.
pub const MAX_SIDE: usize = 4096;
/// Cells in all at most.
pub const MAX_CELLS: usize = 4_000_000;

/// A grid of initial states.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Grid {
    /// The plane.
    pub plane: Plane,
    /// Columns.
    pub nx: usize,
    /// Rows.
    pub ny: usize,
    /// Horizontal range, both ends included (cell centres at the ends).
    pub x_range: (f64, f64),
    /// Vertical range.
    pub y_range: (f64, f64),
}

impl Grid {
    /// The paper's basin window: `n` by `n` initial states over x1 - x2 and y1 - y2 in
    /// [-2, 2], the capsule at rest (Figs 11, 18, 19; `capsule basins`' default).
    pub fn paper(n: usize) -> Grid {
        Grid {
            plane: Plane::RELATIVE,
            nx: n,
            ny: n,
            x_range: (-2.0, 2.0),
            y_range: (-2.0, 2.0),
        }
    }

    /// Check the grid: at least one cell a side, at most [`MAX_SIDE`] and [`MAX_CELLS`], finite
    /// ranges with the low end below the high one (or equal for one cell). Errors name the
    /// setting and the reason.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        for (n, name) in [(self.nx, "grid (NX)"), (self.ny, "grid (NY)")] {
            if n == 0 {
                return Err((name, "must be at least 1".into()));
            }
            if n > MAX_SIDE {
                return Err((name, format!("{n} is above the limit of {MAX_SIDE}")));
            }
        }
        let cells = self.nx * self.ny;
        if cells > MAX_CELLS {
            return Err((
                "grid",
                format!("{cells} initial states is above the limit of {MAX_CELLS}"),
            ));
        }
        for ((lo, hi), n, name) in [
            (self.x_range, self.nx, "x-range"),
            (self.y_range, self.ny, "y-range"),
        ] {
            if !(lo.is_finite() && hi.is_finite()) {
                return Err((name, format!("{lo},{hi}: both ends must be finite numbers")));
            }
            if lo > hi || (lo == hi && n > 1) {
                return Err((
                    name,
                    format!("{lo},{hi}: the first end must be below the second"),
                ));
            }
        }
        Ok(())
    }

    /// The plane coordinates of cell `(i, j)` (column, row; row 0 at the low `y` end).
    pub fn point(&self, i: usize, j: usize) -> (f64, f64) {
        let at = |(lo, hi): (f64, f64), k: usize, n: usize| {
            if n == 1 {
                0.5 * (lo + hi)
            } else {
                lo + (hi - lo) * k as f64 / (n - 1) as f64
            }
        };
        (at(self.x_range, i, self.nx), at(self.y_range, j, self.ny))
    }
}

/// One cell's result.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub enum Cell {
    /// Not computed (interrupted).
    Pending,
    /// Ended on the catalogue's attractor of this index.
    Attractor {
        /// Index into [`BasinMap::catalogue`].
        index: usize,
        /// How the run stopped.
        stop: Stop,
        /// Drive periods integrated.
        periods_run: u32,
    },
    /// The run failed (diverged, Zeno, ...).
    Failed(String),
}

/// Totals over a basin computation.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct BasinWork {
    /// Runs done.
    pub runs: u64,
    /// Drive periods integrated, all runs.
    pub periods: u64,
    /// Runs stopped because their own points repeated.
    pub settled: u64,
    /// Runs stopped on a known attractor.
    pub recognised: u64,
    /// Runs stopped on entering cells of a known basin ([`Method::KnownCells`]).
    pub known_cell: u64,
    /// Runs that reached the horizon.
    pub horizon: u64,
    /// Runs that failed.
    pub failed: u64,
    /// Integrator work, all runs.
    pub solver: Work,
}

impl BasinWork {
    /// Count one run's result.
    fn add(&mut self, cell: &Cell, outcome: Option<&Outcome>) {
        match cell {
            Cell::Pending => {}
            Cell::Failed(_) => {
                self.runs += 1;
                self.failed += 1;
            }
            Cell::Attractor {
                stop, periods_run, ..
            } => {
                self.runs += 1;
                self.periods += u64::from(*periods_run);
                match stop {
                    Stop::Settled => self.settled += 1,
                    Stop::Recognised(_) => self.recognised += 1,
                    Stop::KnownCell(_) => self.known_cell += 1,
                    Stop::Horizon => self.horizon += 1,
                }
            }
        }
        if let Some(o) = outcome {
            self.solver.steps += o.work.steps;
            self.solver.rejected += o.work.rejected;
            self.solver.rhs_evals += o.work.rhs_evals;
            self.solver.events += o.work.events;
        }
    }

    /// Drive periods integrated per run.
    pub fn periods_per_run(&self) -> f64 {
        self.periods as f64 / self.runs.max(1) as f64
    }
}

/// How a map labels its initial states.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
#[serde(tag = "name", rename_all = "kebab-case")]
pub enum Method {
    /// Each initial state runs until its own points repeat or follow a known attractor
    /// ([`crate::attractor::settle`]).
    PerState,
    /// Runs stop on entering cells of the Poincaré section already labelled by earlier runs
    /// ([`crate::basin_cells`]).
    KnownCells(CellConfig),
}

impl Method {
    /// The name on the command line and in outputs.
    pub fn name(&self) -> &'static str {
        match self {
            Method::PerState => "per-state",
            Method::KnownCells(_) => "known-cells",
        }
    }
}

/// Cube coordinates beyond this (a run far out) are not labelled.
const FAR: f64 = 1e15;

/// Cubes finer than the period tolerance are never entered twice: refused.
const MIN_SIZE: f64 = 1e-6;

/// Settings of the known-cells method.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CellConfig {
    /// Edge of a cube (max norm) on the section `[x1 - x2, y1 - y2, y1]`.
    pub size: f64,
    /// Consecutive section points in cubes of one attractor that stop a run.
    pub hits: u32,
    /// Cube-labelled initial states rerun per state as a check (see [`CellCheck`]).
    pub check: usize,
}

impl CellConfig {
    /// The defaults for a grid: cubes of half the grid's spacing, two hits, 200 checked.
    pub fn for_grid(grid: &Grid) -> Self {
        CellConfig {
            size: (0.5 * spacing(grid)).min(0.05),
            hits: 2,
            check: 200,
        }
    }

    /// Check the settings against the grid they label; errors name the setting and the reason.
    pub fn validate(&self, grid: &Grid) -> Result<(), (&'static str, String)> {
        let h = self.size;
        if !(h.is_finite() && h > 0.0) {
            return Err(("cell", format!("{h}: must be a finite number above 0")));
        }
        let d = spacing(grid);
        if h > d {
            return Err((
                "cell",
                format!(
                    "{h} is coarser than the grid's spacing {d:.6}: neighbouring initial states \
                     would share a cube, so the map could not resolve a basin boundary finer \
                     than a cube (use a cell of at most {d:.6}, or the per-state method)"
                ),
            ));
        }
        if h < MIN_SIZE {
            return Err((
                "cell",
                format!(
                    "{h} is below {MIN_SIZE}, the period tolerance: a run would never enter a \
                     labelled cube again (use the per-state method)"
                ),
            ));
        }
        if !(1..=100).contains(&self.hits) {
            return Err(("cell-hits", format!("{}: must be 1 to 100", self.hits)));
        }
        Ok(())
    }

    /// The cube a section point lies in; `None` far out or not finite.
    pub(crate) fn cube(&self, p: &[f64; 3]) -> Option<[i64; 3]> {
        let q = p.map(|v| (v / self.size).floor());
        q.iter()
            .all(|v| v.is_finite() && v.abs() < FAR)
            .then(|| q.map(|v| v as i64))
    }
}

/// The grid's spacing: the smaller distance between neighbouring initial states of its two
/// axes (infinite for a single state).
pub fn spacing(grid: &Grid) -> f64 {
    let d = |(lo, hi): (f64, f64), n: usize| {
        if n > 1 {
            (hi - lo) / (n - 1) as f64
        } else {
            f64::INFINITY
        }
    };
    d(grid.x_range, grid.nx).min(d(grid.y_range, grid.ny))
}

/// The check of a known-cells map: a sample of the states the cubes labelled, rerun per state.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct CellCheck {
    /// Share of the map's runs that stopped on known cubes.
    pub cell_share: f64,
    /// Cube-labelled states rerun per state.
    pub sampled: usize,
    /// Of those, the ones the per-state method put on another attractor (the map keeps the
    /// per-state label).
    pub differ: usize,
    /// Estimated share of the map mislabelled: `differ / sampled * cell_share`.
    pub estimated_mislabelled: f64,
    /// The lower end of its 95 % confidence interval (Wilson score): above
    /// [`CellCheck::WARN_SHARE`], the map is too likely mislabelled to pass without a warning.
    pub mislabelled_low: f64,
}

impl CellCheck {
    /// Estimated mislabelled share above which the map comes with a warning.
    pub const WARN_SHARE: f64 = 0.003;

    /// A warning when even the lower end of the estimate is above [`CellCheck::WARN_SHARE`]
    /// (one difference in a small sample is not enough), with the reason.
    pub fn warning(&self, size: f64) -> Option<String> {
        (self.mislabelled_low > Self::WARN_SHARE).then(|| {
            format!(
                "{} of {} sampled cube-labelled states end elsewhere when run on their own: about \
                 {:.2} % of the map (at least {:.2} %) may be mislabelled, the cubes ({size}) \
                 being too coarse for its basin boundaries (fractal or riddled?); use a smaller \
                 cell or the per-state method",
                self.differ,
                self.sampled,
                100.0 * self.estimated_mislabelled,
                100.0 * self.mislabelled_low
            )
        })
    }

    /// The check of `differ` of `sampled` states, of a map whose runs stopped on cubes in the
    /// share `cell_share`.
    pub fn new(cell_share: f64, sampled: usize, differ: usize) -> CellCheck {
        let (n, z) = (sampled.max(1) as f64, 1.96f64);
        let p = differ as f64 / n;
        // Wilson score interval's lower end for a proportion
        let low = (p + z * z / (2.0 * n) - z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt())
            / (1.0 + z * z / n);
        CellCheck {
            cell_share,
            sampled,
            differ,
            estimated_mislabelled: p * cell_share,
            mislabelled_low: low.max(0.0) * cell_share,
        }
    }
}

/// The labelled grid.
#[derive(Debug, Clone, Serialize)]
pub struct BasinMap {
    /// The grid.
    pub grid: Grid,
    /// Row-major cells, row 0 at the low `y` end.
    pub cells: Vec<Cell>,
    /// The attractors found.
    pub catalogue: Catalogue,
    /// Totals.
    pub work: BasinWork,
    /// How it was labelled.
    pub method: Method,
    /// For [`Method::KnownCells`]: the sample of cell-labelled states rerun per state.
    pub check: Option<CellCheck>,
}

impl BasinMap {
    /// A map of `grid` from each cell's result, with its method's check.
    pub(crate) fn assemble(
        grid: &Grid,
        results: Vec<(Cell, Option<Outcome>)>,
        catalogue: Catalogue,
        method: Method,
        check: Option<CellCheck>,
    ) -> BasinMap {
        let mut work = BasinWork::default();
        let mut cells = Vec::with_capacity(results.len());
        for (cell, outcome) in results {
            work.add(&cell, outcome.as_ref());
            cells.push(cell);
        }
        BasinMap {
            grid: *grid,
            cells,
            catalogue,
            work,
            method,
            check,
        }
    }

    /// Share of the grid (computed cells and pending alike) that ended on attractor `index`.
    pub fn fraction(&self, index: usize) -> f64 {
        let n = self
            .cells
            .iter()
            .filter(|c| matches!(c, Cell::Attractor { index: i, .. } if *i == index))
            .count();
        n as f64 / self.cells.len().max(1) as f64
    }

    /// Cells still pending (an interrupted computation).
    pub fn pending(&self) -> usize {
        self.cells.iter().filter(|c| **c == Cell::Pending).count()
    }
}

/// What a basin map runs: every initial state of `grid` (the rest of the state from
/// `scene.initial`) under `schedule`, until it settles by `config`.
#[derive(Debug, Clone, Copy)]
pub struct BasinRun<'a> {
    /// The scene, its initial state completing the grid's.
    pub scene: &'a Scene,
    /// The gain in every drive period.
    pub schedule: GainSchedule,
    /// When a run has settled.
    pub config: SettleConfig,
    /// The initial states.
    pub grid: Grid,
}

impl<'a> BasinRun<'a> {
    /// `scene` from each initial state of `grid` at its own constant `k_p`, settled as
    /// [`SettleConfig::for_scene`] says.
    pub fn new(scene: &'a Scene, grid: Grid) -> Self {
        BasinRun {
            scene,
            schedule: GainSchedule::constant(scene.control.kp),
            config: SettleConfig::for_scene(scene),
            grid,
        }
    }

    /// The scene started from the grid's initial state number `c` (row-major).
    pub fn scene_at(&self, c: usize) -> Scene {
        let grid = &self.grid;
        let (a, b) = grid.point(c % grid.nx, c / grid.nx);
        let mut s = self.scene.clone();
        s.initial = grid.plane.state(self.scene.initial, a, b);
        s
    }

    /// Initial state `c` run until it settles, against the attractors `known`.
    pub(crate) fn settle_at(&self, c: usize, known: &Catalogue) -> Result<Outcome, SimError> {
        settle(&self.scene_at(c), &self.schedule, &self.config, known)
    }
}

/// Each initial state on its own ([`Method::PerState`]), in parallel (see
/// [`crate::basin_cells::basins_by`]).
pub fn basins(run: &BasinRun, progress: &(dyn Fn() + Sync), cancel: &AtomicBool) -> BasinMap {
    let grid = &run.grid;
    let shared = Mutex::new(Arc::new(Catalogue::default()));
    let snapshot = || shared.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let results: Vec<(Cell, Option<Outcome>)> = (0..grid.nx * grid.ny)
        .into_par_iter()
        .map(|c| {
            if cancel.load(Ordering::Relaxed) {
                return (Cell::Pending, None);
            }
            let cell = match run.settle_at(c, &snapshot()) {
                Err(e) => (Cell::Failed(e.to_string()), None),
                Ok(o) => {
                    let index = match o.stop {
                        Stop::Recognised(i) | Stop::KnownCell(i) => i,
                        _ => {
                            let mut guard = shared.lock().unwrap_or_else(|e| e.into_inner());
                            Arc::make_mut(&mut guard).insert(&o.attractor)
                        }
                    };
                    let cell = Cell::Attractor {
                        index,
                        stop: o.stop,
                        periods_run: o.periods_run,
                    };
                    (cell, Some(o))
                }
            };
            progress();
            cell
        })
        .collect();
    let catalogue = Arc::unwrap_or_clone(snapshot());
    BasinMap::assemble(grid, results, catalogue, Method::PerState, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn planes_set_the_state_they_name() {
        let base = State {
            x1: 0.0,
            y1: 0.0,
            x2: 1.0,
            y2: 0.0,
        };
        let s = Plane::RELATIVE.state(base, 0.3, -0.2);
        assert!((s.x1 - s.x2 - 0.3).abs() < 1e-15 && (s.x2, s.y1, s.y2) == (1.0, -0.2, 0.0));
        let p = Plane::parse("x1, x1-x2").unwrap();
        let s = p.state(base, 0.5, 0.2);
        assert!((s.x1 - 0.5).abs() < 1e-15 && (s.x1 - s.x2 - 0.2).abs() < 1e-15);
        let p = Plane::parse("x2,x1-x2").unwrap();
        let s = p.state(base, 2.0, 0.1);
        assert!((s.x2 - 2.0).abs() < 1e-15 && (s.x1 - s.x2 - 0.1).abs() < 1e-15);
        let p = Plane::parse("y2,y1").unwrap();
        let s = p.state(base, 0.7, 0.4);
        assert_eq!((s.y2, s.y1, s.x1, s.x2), (0.7, 0.4, 0.0, 1.0));
    }

    #[test]
    fn bad_planes_and_grids_are_refused() {
        assert!(Plane::parse("x1,x1").is_err());
        assert!(Plane::parse("x3,y1").is_err());
        assert!(Plane::parse("x1").is_err());
        let g = Grid::paper(10);
        assert_eq!(g.validate(), Ok(()));
        let err = |g: Grid| g.validate().unwrap_err().0;
        assert_eq!(err(Grid { nx: 0, ..g }), "grid (NX)");
        assert_eq!(
            err(Grid {
                nx: 4000,
                ny: 4000,
                ..g
            }),
            "grid"
        );
        assert_eq!(
            err(Grid {
                x_range: (f64::NAN, 1.0),
                ..g
            }),
            "x-range"
        );
        assert_eq!(
            err(Grid {
                y_range: (1.0, -1.0),
                ..g
            }),
            "y-range"
        );
        assert_eq!(g.point(0, 9), (-2.0, 2.0));
    }
}
