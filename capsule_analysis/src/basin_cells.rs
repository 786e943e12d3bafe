//! Basins by known cells: a run stops as soon as its section points enter cells of the Poincaré
//! section already labelled by earlier runs (the idea of Datseris and Wagemakers, "Effortless
//! estimation of basins of attraction", Chaos 32, 023104 (2022), and of Attractors.jl's
//! recurrence method; no code taken).
//!
//! The section `[x1 - x2, y1 - y2, y1]` is cut into cubes of edge [`CellConfig::size`]. Every
//! section point of a finished run (its initial state's first) labels its cube with the run's
//! attractor; a cube reached by runs of two attractors is a boundary cube and labels nothing. A
//! run stops once [`CellConfig::hits`] consecutive points lie in cubes of one attractor. Runs
//! that meet no labelled cubes settle as [`crate::attractor::settle`] would, so every attractor
//! is still found by its own recurrence, and the first runs label the section for the rest.
//!
//! Deterministic whatever the threads: initial states are taken in a fixed pseudo-random order
//! in batches that double in size; the runs of a batch go in parallel against the cubes and the
//! catalogue as they were before it, and are merged in order after it.
//!
//! Where it can mislabel: a cube is one label, so a basin boundary finer than a cube (a fractal
//! or riddled boundary, or cubes coarser than the map's spacing) gives a run the label of an
//! earlier run that passed through the same cube on the other side of the boundary. Guards:
//! cubes coarser than the grid's spacing are refused ([`CellConfig::validate`]), boundary cubes
//! label nothing, and a sample of the states labelled by cubes is rerun per state
//! ([`CellCheck`]): the map keeps the per-state labels for them and reports how many differed,
//! with a warning when the share of the map that may be mislabelled is above
//! [`CellCheck::WARN_SHARE`].

use crate::attractor::{settle, settle_watched, Catalogue, Outcome, SettleConfig, Stop};
use crate::basin::{scene_at, BasinMap, Cell, Grid, Method};
use crate::schedule::GainSchedule;
use capsule_plant::scene::Scene;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// Initial states in the first batch (all of them run per state: no cube is labelled yet).
const FIRST_BATCH: usize = 64;
/// Initial states in a batch at most.
const MAX_BATCH: usize = 16_384;
/// Label of a cube reached by runs of two attractors.
const BOUNDARY: usize = usize::MAX;
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
    fn cube(&self, p: &[f64; 3]) -> Option<[i64; 3]> {
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
}

impl CellCheck {
    /// Estimated mislabelled share above which the map comes with a warning.
    pub const WARN_SHARE: f64 = 0.003;

    /// A warning when the estimate is above [`CellCheck::WARN_SHARE`], with the reason.
    pub fn warning(&self, size: f64) -> Option<String> {
        (self.estimated_mislabelled > Self::WARN_SHARE).then(|| {
            format!(
                "{} of {} sampled cube-labelled states end elsewhere when run on their own: about \
                 {:.2} % of the map may be mislabelled, the cubes ({size}) being too coarse for \
                 its basin boundaries (fractal or riddled?); use a smaller cell or the per-state \
                 method",
                self.differ,
                self.sampled,
                100.0 * self.estimated_mislabelled
            )
        })
    }
}

/// A fixed pseudo-random order of `0..n` (splitmix64 of each index).
fn order(n: usize, salt: u64) -> Vec<usize> {
    let mix = |i: usize| {
        let mut z = (i as u64 ^ salt).wrapping_add(0x9e37_79b9_7f4a_7c15);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let mut idx: Vec<usize> = (0..n).collect();
    idx.sort_by_key(|&i| mix(i));
    idx
}

/// One run of a batch: its result and the cubes it passed through.
struct Visit {
    result: Option<Result<Outcome, String>>,
    cubes: Vec<[i64; 3]>,
}

/// [`crate::basin::basins_by`] by known cells (see the module doc); `cells` checked with
/// [`CellConfig::validate`] first.
pub fn basins_by_cells(
    scene: &Scene,
    schedule: &GainSchedule,
    config: &SettleConfig,
    cells: &CellConfig,
    grid: &Grid,
    progress: &(dyn Fn() + Sync),
    cancel: &AtomicBool,
) -> BasinMap {
    let n = grid.nx * grid.ny;
    let mut labels: HashMap<[i64; 3], usize> = HashMap::new();
    let mut catalogue = Catalogue::default();
    let mut results: Vec<(Cell, Option<Outcome>)> = vec![(Cell::Pending, None); n];
    let ord = order(n, 0);
    let (mut start, mut batch) = (0, FIRST_BATCH);
    while start < n {
        let end = (start + batch).min(n);
        let visits: Vec<Visit> = ord[start..end]
            .par_iter()
            .map(|&c| {
                let s = scene_at(scene, grid, c);
                let v = run_one(&s, schedule, config, cells, &labels, &catalogue, cancel);
                progress();
                v
            })
            .collect();
        for (&c, v) in ord[start..end].iter().zip(visits) {
            results[c] = record(v, &mut labels, &mut catalogue);
        }
        (start, batch) = (end, (2 * batch).min(MAX_BATCH));
    }
    let check = check(
        scene,
        schedule,
        config,
        cells,
        grid,
        &mut results,
        &mut catalogue,
        cancel,
    );
    BasinMap::assemble(grid, results, catalogue, Method::KnownCells(*cells), check)
}

/// Run one initial state against the cubes labelled so far.
fn run_one(
    scene: &Scene,
    schedule: &GainSchedule,
    config: &SettleConfig,
    cells: &CellConfig,
    labels: &HashMap<[i64; 3], usize>,
    catalogue: &Catalogue,
    cancel: &AtomicBool,
) -> Visit {
    let mut cubes = Vec::new();
    if cancel.load(Ordering::Relaxed) {
        return Visit {
            result: None,
            cubes,
        };
    }
    let (mut on, mut streak) = (BOUNDARY, 0u32);
    let mut watch = |p: &[f64; 3]| {
        let label = cells.cube(p).and_then(|k| {
            cubes.push(k);
            labels.get(&k).copied()
        });
        match label {
            Some(l) if l != BOUNDARY => {
                streak = if l == on { streak + 1 } else { 1 };
                on = l;
            }
            _ => (on, streak) = (BOUNDARY, 0),
        }
        (streak >= cells.hits).then_some(on)
    };
    let result = settle_watched(scene, schedule, config, catalogue, &mut watch);
    Visit {
        result: Some(result.map_err(|e| e.to_string())),
        cubes,
    }
}

/// A finished run's cell, its attractor put in the catalogue, its cubes labelled.
fn record(
    v: Visit,
    labels: &mut HashMap<[i64; 3], usize>,
    catalogue: &mut Catalogue,
) -> (Cell, Option<Outcome>) {
    match v.result {
        None => (Cell::Pending, None),
        Some(Err(e)) => (Cell::Failed(e), None),
        Some(Ok(o)) => {
            let index = index_of(&o, catalogue);
            for k in v.cubes {
                labels
                    .entry(k)
                    .and_modify(|l| {
                        if *l != index {
                            *l = BOUNDARY;
                        }
                    })
                    .or_insert(index);
            }
            let cell = Cell::Attractor {
                index,
                stop: o.stop,
                periods_run: o.periods_run,
            };
            (cell, Some(o))
        }
    }
}

/// The catalogue's index of the attractor a run ended on, adding it if new.
fn index_of(o: &Outcome, catalogue: &mut Catalogue) -> usize {
    match o.stop {
        Stop::Recognised(i) | Stop::KnownCell(i) => i,
        Stop::Settled | Stop::Horizon => catalogue.insert(&o.attractor),
    }
}

/// Rerun up to `cells.check` of the cube-labelled states per state (a fixed sample), keep
/// their per-state labels, and count those that differ.
#[allow(clippy::too_many_arguments)]
fn check(
    scene: &Scene,
    schedule: &GainSchedule,
    config: &SettleConfig,
    cells: &CellConfig,
    grid: &Grid,
    results: &mut [(Cell, Option<Outcome>)],
    catalogue: &mut Catalogue,
    cancel: &AtomicBool,
) -> Option<CellCheck> {
    let on_cell = |c: &usize| {
        matches!(
            results[*c].0,
            Cell::Attractor {
                stop: Stop::KnownCell(_),
                ..
            }
        )
    };
    let by_cells = (0..results.len()).filter(on_cell).count();
    let runs = results
        .iter()
        .filter(|r| !matches!(r.0, Cell::Pending))
        .count();
    if cancel.load(Ordering::Relaxed) || runs == 0 {
        return None;
    }
    let sample: Vec<usize> = order(results.len(), 0x5eed)
        .into_iter()
        .filter(on_cell)
        .take(cells.check)
        .collect();
    let known = catalogue.clone();
    let reruns: Vec<Result<Outcome, String>> = sample
        .par_iter()
        .map(|&c| {
            settle(&scene_at(scene, grid, c), schedule, config, &known).map_err(|e| e.to_string())
        })
        .collect();
    let mut differ = 0;
    for (&c, r) in sample.iter().zip(reruns) {
        let before = match results[c].0 {
            Cell::Attractor { index, .. } => Some(index),
            _ => None,
        };
        results[c] = record(
            Visit {
                result: Some(r),
                cubes: Vec::new(),
            },
            &mut HashMap::new(),
            catalogue,
        );
        let after = match results[c].0 {
            Cell::Attractor { index, .. } => Some(index),
            _ => None,
        };
        differ += usize::from(before != after);
    }
    let cell_share = by_cells as f64 / runs as f64;
    Some(CellCheck {
        cell_share,
        sampled: sample.len(),
        differ,
        estimated_mislabelled: if sample.is_empty() {
            0.0
        } else {
            differ as f64 / sample.len() as f64 * cell_share
        },
    })
}
