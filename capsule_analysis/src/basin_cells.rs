//! Basins by known cells: a run stops as soon as its section points enter cells of the Poincaré
//! section already labelled by earlier runs (the idea of Datseris and Wagemakers, "Effortless
//! estimation of basins of attraction", Chaos 32, 023104 (2022), and of Attractors.jl's
//! recurrence method; no code taken); and [`basins_by`], the map by either method. The
//! method's settings and check are types of [`crate::basin`].
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
//! with a warning when the share of the map that is mislabelled is, with 95 % confidence, above
//! [`CellCheck::WARN_SHARE`].

use crate::attractor::{settle_watched, Catalogue, Outcome, Stop};
use crate::basin::{basins, BasinMap, BasinRun, Cell, CellCheck, CellConfig, Method};
use rayon::prelude::*;
use std::collections::HashMap;
use std::sync::atomic::{AtomicBool, Ordering};

/// Initial states in the first batch (all of them run per state: no cube is labelled yet).
const FIRST_BATCH: usize = 64;
/// Initial states in a batch at most.
const MAX_BATCH: usize = 16_384;
/// Label of a cube reached by runs of two attractors.
const BOUNDARY: usize = usize::MAX;
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

/// Label every initial state of `run` by the attractor it ends on, by `method` (a
/// [`CellConfig`] checked with [`CellConfig::validate`] first). `progress` is called once per
/// cell; once `cancel` is set, cells not yet started stay [`Cell::Pending`].
pub fn basins_by(
    method: &Method,
    run: &BasinRun,
    progress: &(dyn Fn() + Sync),
    cancel: &AtomicBool,
) -> BasinMap {
    match method {
        Method::PerState => basins(run, progress, cancel),
        Method::KnownCells(cells) => basins_by_cells(run, cells, progress, cancel),
    }
}

/// [`basins_by`] by known cells (see the module doc); `cells` checked with
/// [`CellConfig::validate`] first.
pub fn basins_by_cells(
    run: &BasinRun,
    cells: &CellConfig,
    progress: &(dyn Fn() + Sync),
    cancel: &AtomicBool,
) -> BasinMap {
    let n = run.grid.nx * run.grid.ny;
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
                let v = run_one(run, c, cells, &labels, &catalogue, cancel);
                progress();
                v
            })
            .collect();
        for (&c, v) in ord[start..end].iter().zip(visits) {
            results[c] = record(v, &mut labels, &mut catalogue);
        }
        (start, batch) = (end, (2 * batch).min(MAX_BATCH));
    }
    let check = check(run, cells, &mut results, &mut catalogue, cancel);
    BasinMap::assemble(
        &run.grid,
        results,
        catalogue,
        Method::KnownCells(*cells),
        check,
    )
}

/// Run initial state `c` against the cubes labelled so far.
fn run_one(
    run: &BasinRun,
    c: usize,
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
    let result = settle_watched(
        &run.scene_at(c),
        &run.schedule,
        &run.config,
        catalogue,
        &mut watch,
    );
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
fn check(
    run: &BasinRun,
    cells: &CellConfig,
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
        .map(|&c| run.settle_at(c, &known).map_err(|e| e.to_string()))
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
    Some(CellCheck::new(
        by_cells as f64 / runs as f64,
        sample.len(),
        differ,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::basin::{spacing, Grid};

    #[test]
    fn one_difference_in_a_small_sample_does_not_warn_many_do() {
        let one = CellCheck::new(1.0, 200, 1);
        assert!((one.estimated_mislabelled - 0.005).abs() < 1e-12);
        assert!(one.mislabelled_low < CellCheck::WARN_SHARE, "{one:?}");
        assert_eq!(one.warning(0.01), None);
        let many = CellCheck::new(1.0, 200, 6);
        let w = many.warning(0.01).unwrap_or_default();
        assert!(w.contains("6 of 200") && w.contains("too coarse"), "{w}");
        assert_eq!(CellCheck::new(0.9, 200, 0).mislabelled_low, 0.0);
    }

    #[test]
    fn cells_are_checked_against_the_grid() {
        let g = Grid::paper(101);
        assert!((spacing(&g) - 0.04).abs() < 1e-12);
        let ok = CellConfig::for_grid(&g);
        assert_eq!(ok.validate(&g), Ok(()));
        let err = |size| CellConfig { size, ..ok }.validate(&g).unwrap_err().1;
        assert!(
            err(0.05).contains("coarser than the grid's spacing"),
            "{}",
            err(0.05)
        );
        assert!(err(0.0).contains("above 0"));
        assert!(err(f64::INFINITY).contains("above 0"));
        assert!(err(1e-7).contains("period tolerance"));
        let hits = CellConfig { hits: 0, ..ok }.validate(&g).unwrap_err();
        assert_eq!(hits.0, "cell-hits");
        // the cube of a point, none far out
        let c = CellConfig { size: 0.5, ..ok };
        assert_eq!(c.cube(&[0.2, -0.2, 1.0]), Some([0, -1, 2]));
        assert_eq!(c.cube(&[f64::NAN, 0.0, 0.0]), None);
        assert_eq!(c.cube(&[1e300, 0.0, 0.0]), None);
    }

    #[test]
    fn the_order_is_a_fixed_permutation() {
        let a = order(1000, 0);
        let mut sorted = a.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..1000).collect::<Vec<_>>());
        assert_eq!(a, order(1000, 0));
        assert_ne!(a[..10], (0..10).collect::<Vec<_>>()[..]);
    }
}
