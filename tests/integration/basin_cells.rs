//! Basins by known cells against the per-state method (Fig 19a: Coulomb, alpha 1.5, k_p 0),
//! the refusal of cells that cannot resolve the map, and offline commands that write files only
//! where asked (issue 32).

use crate::common::{assert_refused_at_once, capsule_in, files_in, json_of, line, stderr, TempDir};
use capsule_analysis::basin::{BasinMap, BasinRun, CellCheck, CellConfig, Grid, Method};
use capsule_analysis::basin_cells::basins_by;
use capsule_plant::scene::Scene;
use std::sync::atomic::AtomicBool;

fn fig19a() -> Scene {
    let mut s = Scene::default();
    s.drive.alpha = 1.5;
    s
}

fn map(method: &Method, grid: &Grid) -> BasinMap {
    let scene = fig19a();
    let cancel = AtomicBool::new(false);
    basins_by(method, &BasinRun::new(&scene, *grid), &|| {}, &cancel)
}

/// Each label's share of the map, in legend order.
fn shares(m: &BasinMap) -> Vec<(String, f64)> {
    m.catalogue
        .ordered()
        .into_iter()
        .map(|(i, l)| (l, m.fraction(i)))
        .collect()
}

#[test]
fn known_cells_give_the_per_state_shares_and_attractors_at_a_fraction_of_the_periods() {
    let grid = Grid::paper(60);
    let cells = Method::KnownCells(CellConfig::for_grid(&grid));
    let (exact, fast) = (map(&Method::PerState, &grid), map(&cells, &grid));
    let (a, b) = (shares(&exact), shares(&fast));
    // the same attractors (labels) and every share within 0.3 percentage points
    let names = |s: &[(String, f64)]| s.iter().map(|x| x.0.clone()).collect::<Vec<_>>();
    assert_eq!(names(&a), names(&b), "per state {a:?}, known cells {b:?}");
    for ((l, x), (_, y)) in a.iter().zip(&b) {
        assert!(
            (x - y).abs() <= 0.003,
            "{l}: per state {x}, known cells {y}"
        );
    }
    // the known-cells stop really stops early: most runs on known cells, far fewer periods
    let (pe, pc) = (exact.work.periods_per_run(), fast.work.periods_per_run());
    assert!(
        fast.work.known_cell as f64 > 0.5 * fast.work.runs as f64,
        "{:?}",
        fast.work
    );
    assert!(
        pc < 0.5 * pe,
        "periods per state: per state {pe}, cells {pc}"
    );
    assert_eq!(exact.work.known_cell, 0);
    let check = fast.check.unwrap_or_else(|| panic!("no check"));
    assert_eq!(check.sampled, 200);
    // no warning: the sample does not show the map mislabelled beyond 0.3 %
    assert!(check.mislabelled_low <= CellCheck::WARN_SHARE, "{check:?}");
    assert_eq!(check.warning(0.01), None);
}

#[test]
fn known_cells_map_is_the_same_whatever_the_threads() {
    let grid = Grid::paper(24);
    let cells = Method::KnownCells(CellConfig::for_grid(&grid));
    let on = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap_or_else(|e| panic!("{e}"))
            .install(|| map(&cells, &grid))
    };
    let (one, three) = (on(1), on(3));
    assert_eq!(one.cells, three.cells);
    assert_eq!(one.catalogue.attractors, three.catalogue.attractors);
    assert_eq!(one.work, three.work);
}

#[test]
fn cells_that_cannot_resolve_the_map_are_refused_with_the_reason() {
    let cases: [(&str, &str); 5] = [
        (
            "--grid 100,100 --cell 0.05",
            "--cell: 0.05 is coarser than the grid's spacing 0.040404",
        ),
        (
            "--grid 10,10 --cell 0",
            "--cell: 0: must be a finite number above 0",
        ),
        ("--grid 10,10 --cell nan", "must be a finite number above 0"),
        (
            "--grid 10,10 --cell 1e-9",
            "below 0.000001, the period tolerance",
        ),
        (
            "--grid 10,10 --basin-method per-state --cell 0.01",
            "only the known-cells method has cells",
        ),
    ];
    let dir = TempDir::new("basin_cells_refusals");
    for (args, needle) in cases {
        let words = format!("basins {args}");
        assert_refused_at_once(&dir, &line(&words, &[]), needle);
    }
    assert!(files_in(&dir).is_empty(), "{:?}", files_in(&dir));
}

#[test]
fn basins_and_switch_with_json_write_nothing_unasked() {
    let dir = TempDir::new("basin_cells_no_files");
    for args in [
        "basins --alpha 1.5 --grid 6,5 --periods 60 --json",
        "basins --alpha 1.5 --grid 6,5 --periods 60 --basin-method per-state",
        "switch --periods 40 --pulse-kp 0.1 --pulse-at 20 --kp-after 0.1 --json",
    ] {
        let out = capsule_in(&dir, &line(args, &[]));
        assert!(out.status.success(), "{args}: {}", stderr(&out));
        if args.contains("--json") {
            json_of(&out);
        }
        assert!(
            files_in(&dir).is_empty(),
            "{args} wrote {:?}",
            files_in(&dir)
        );
    }
    // the JSON reports the method and its cost per state
    let out = capsule_in(
        &dir,
        &line("basins --alpha 1.5 --grid 6,5 --periods 60 --json", &[]),
    );
    let v = json_of(&out);
    assert_eq!(v["basin_method"]["name"], "known-cells", "{v}");
    assert!(
        v["work"]["periods_per_state"].as_f64().unwrap_or(0.0) > 0.0,
        "{v}"
    );
    assert!(
        v["work"]["ms_per_state"].as_f64().unwrap_or(0.0) > 0.0,
        "{v}"
    );
    // sweep and continue write only with --out (their files are their result)
    for args in [
        "sweep --param alpha --from 1 --to 1.2 --steps 3 --periods 20",
        "continue --param alpha --to 1.6 --alpha 1.5",
    ] {
        let out = capsule_in(&dir, &line(args, &[]));
        assert!(!out.status.success(), "{args} ran without --out");
        assert!(stderr(&out).contains("--out"), "{args}: {}", stderr(&out));
    }
    assert!(files_in(&dir).is_empty(), "{:?}", files_in(&dir));
}
