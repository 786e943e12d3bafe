//! Coexisting attractors (the paper's section 5.4, Figs 18-20) at coarse grids: basins and their
//! change with the gain and the drive amplitude, switching by a gain schedule.

use crate::common::{assert_refused_at_once, json, line, TempDir};
use capsule_analysis::attractor::SettleConfig;
use capsule_analysis::basin::{basins, BasinMap, BasinRun, Grid};
use capsule_analysis::switch::switch_run;
use capsule_analysis::{GainSchedule, Pulse};
use capsule_plant::scene::Scene;
use capsule_plant::State;
use std::sync::atomic::AtomicBool;

/// The section-3 set, Coulomb friction (the paper's section 5.4 system).
fn coulomb(alpha: f64, kp: f64) -> Scene {
    let mut s = Scene::default();
    s.drive.alpha = alpha;
    s.control.kp = kp;
    s
}

fn map(scene: &Scene, n: usize) -> BasinMap {
    let run = BasinRun::new(scene, Grid::paper(n));
    basins(&run, &|| {}, &AtomicBool::new(false))
}

/// Share of the grid on attractors of period `k`.
fn share(m: &BasinMap, k: usize) -> f64 {
    (0..m.catalogue.attractors.len())
        .filter(|&i| m.catalogue.attractors[i].period == Some(k))
        .map(|i| m.fraction(i))
        .sum()
}

#[test]
fn fig19_period_one_basin_grows_with_the_gain() {
    let off = map(&coulomb(1.5, 0.0), 16);
    let on = map(&coulomb(1.5, 0.1), 16);
    let (a, b) = (share(&off, 1), share(&on, 1));
    assert!(off.pending() == 0 && on.pending() == 0);
    // both coexist without control (Fig 19a)
    assert!(
        a > 0.2 && share(&off, 3) > 0.2,
        "k_p 0: P1 {a}, P3 {}",
        share(&off, 3)
    );
    assert!(b > a + 0.1, "period-1 share: k_p 0 {a}, k_p 0.1 {b}");
}

#[test]
fn fig19_gain_0_05_has_one_period_six_attractor_whatever_the_phase_it_is_reached_at() {
    // The paper: k_p 0.05 turns period 3 into period 6. The period-6 orbit has a multiplier of
    // 0.998, so runs approach it so slowly that their last cycles differed by up to 1e-2 and were
    // listed as P6a, P6b, P6c, ... and "chaos"; Newton's method on the Poincaré map finds the one
    // orbit they all approach.
    let m = map(&coulomb(1.5, 0.05), 40);
    let labels: Vec<String> = m.catalogue.ordered().into_iter().map(|(_, l)| l).collect();
    let six: Vec<usize> = (0..m.catalogue.attractors.len())
        .filter(|&i| m.catalogue.attractors[i].period == Some(6))
        .collect();
    assert_eq!(six.len(), 1, "labels {labels:?}");
    assert!(labels.contains(&"P6".to_string()), "labels {labels:?}");
    let p6 = &m.catalogue.attractors[six[0]];
    assert!(m.fraction(six[0]) > 0.2, "P6 share {}", m.fraction(six[0]));
    // its cycle is the exact orbit: six periods map its first point onto itself, and one
    // period onto the next point (the cycle is in order, whatever phase it was reached at)
    let s = coulomb(1.5, 0.05);
    let x = |p: &[f64; 3]| [p[0], p[2], p[2] - p[1]];
    let back = capsule_analysis::floquet::map_only(&s, x(&p6.poincare[0]), 6)
        .unwrap_or_else(|e| panic!("{e}"));
    let next = capsule_analysis::floquet::map_only(&s, x(&p6.poincare[0]), 1)
        .unwrap_or_else(|e| panic!("{e}"));
    let d = |a: [f64; 3], b: [f64; 3]| (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max);
    assert!(d(back, x(&p6.poincare[0])) < 1e-8, "{back:?}");
    assert!(d(next, x(&p6.poincare[1])) < 1e-8, "{next:?}");
    // no non-periodic class takes more than a sliver, and it is not called chaos
    let chaos = labels.iter().any(|l| l == "chaos");
    assert!(!chaos, "labels {labels:?}");
}

#[test]
fn a_run_held_near_an_unstable_orbit_is_quasi_periodic_not_periodic_nor_chaos() {
    // the period-3 orbit at alpha 1.5, k_p 0.05 is just past its period doubling (a multiplier
    // of modulus 1.0005): a run started on it repeats with period 3 to 1e-6 for hundreds of
    // periods, but it is no attractor; its largest Lyapunov exponent is near zero
    let s = coulomb(1.5, 0.05);
    let near = [
        [0.652863, -1.848207, -1.265976],
        [0.439382, 2.415634, 2.395457],
        [0.340639, -0.424285, -0.129855],
    ];
    let p3 = capsule_analysis::identity::refine(&s, &near).unwrap_or_else(|| panic!("no orbit"));
    assert_eq!(p3.period, 3);
    assert!(
        p3.largest_modulus > 1.0 && p3.largest_modulus < 1.01,
        "{}",
        p3.largest_modulus
    );
    let mut on = s.clone();
    let q = p3.cycle[0];
    on.initial = State {
        x1: q[0],
        y1: q[2],
        x2: 0.0,
        y2: q[2] - q[1],
    };
    let cfg = SettleConfig::for_scene(&on);
    let o = capsule_analysis::attractor::settle(
        &on,
        &GainSchedule::constant(0.05),
        &cfg,
        &capsule_analysis::attractor::Catalogue::default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(o.attractor.period, None, "{:?}", o.attractor.period);
    let l = o.attractor.largest_lyapunov.unwrap_or(f64::NAN);
    assert!(
        l.abs() < capsule_analysis::identity::CHAOS_EXPONENT,
        "largest exponent {l}"
    );
    let mut cat = capsule_analysis::attractor::Catalogue::default();
    let i = cat.insert(&o.attractor);
    assert_eq!(cat.ordered(), vec![(i, "QP".to_string())]);
}

#[test]
fn fig18_period_three_basin_shrinks_toward_alpha_1_654() {
    let shares: Vec<f64> = [1.3, 1.5, 1.64]
        .iter()
        .map(|&alpha| share(&map(&coulomb(alpha, 0.0), 16), 3))
        .collect();
    assert!(shares[0] > 0.0, "{shares:?}");
    assert!(
        shares[0] > shares[1] && shares[1] > shares[2],
        "period-3 share over alpha 1.3, 1.5, 1.64: {shares:?}"
    );
}

#[test]
fn fig20_control_switched_on_at_period_300_moves_period_3_to_period_1() {
    let scene = from_period_three(1.3, 600);
    let on = one_period_pulse(0.1, 300, 0.1);
    on.validate(600).unwrap();
    let r = switch_run(&scene, &on, 0, &mut |_| {}).unwrap();
    assert_eq!(r.before.period, Some(3));
    assert_eq!(r.before.impacts_per_period * 3.0, 5.0);
    assert_eq!(r.after.period, Some(1));
    assert_eq!(r.after.impacts_per_period, 1.0);
    assert!(r.switched);
    assert!(r.after.avg_progression > r.before.avg_progression);
}

/// A start in the period-3 basin at alpha 1.3 and 1.5 (k_p 0): x1 - x2 = -1.5, all at rest.
/// From rest the motion ends on the period-2 (alpha 1.3) or period-1 (alpha 1.5) orbit.
fn from_period_three(alpha: f64, periods: u32) -> Scene {
    let mut scene = coulomb(alpha, 0.0);
    scene.initial = State {
        x1: -1.5,
        ..State::default()
    };
    scene.horizon.periods = periods;
    scene
}

/// k_p 0, then `kp` for the one period `at`, then `after`.
fn one_period_pulse(kp: f64, at: u32, after: f64) -> GainSchedule {
    GainSchedule {
        before: 0.0,
        pulse: Some(Pulse { kp, at, periods: 1 }),
        after,
    }
}

#[test]
fn alpha_1_5_a_released_pulse_switches_at_a_suitable_phase_only() {
    let scene = from_period_three(1.5, 400);
    let outcomes: Vec<(u32, Option<usize>, Option<usize>)> = (200..206)
        .map(|at| {
            let r = switch_run(&scene, &one_period_pulse(0.3, at, 0.0), 0, &mut |_| {}).unwrap();
            (at, r.before.period, r.after.period)
        })
        .collect();
    assert!(outcomes.iter().all(|o| o.1 == Some(3)), "{outcomes:?}");
    assert!(
        outcomes.iter().any(|o| o.2 == Some(1)),
        "no phase switches: {outcomes:?}"
    );
    assert!(
        outcomes.iter().any(|o| o.2 == Some(3)),
        "every phase switches: {outcomes:?}"
    );
    // the switch depends on the phase on the cycle only: three drive periods later, the same
    let by_phase = |at: u32| outcomes.iter().find(|o| o.0 == at).map(|o| o.2);
    for at in 200..203 {
        assert_eq!(by_phase(at), by_phase(at + 3), "{outcomes:?}");
    }
}

#[test]
fn cli_refuses_bad_grids_planes_and_schedules_before_any_work() {
    let cases: [(&[&str], &str); 8] = [
        (
            &["basins", "--grid", "0,10"],
            "--grid (NX): must be at least 1",
        ),
        (&["basins", "--grid", "40000,40000"], "above the limit"),
        (&["basins", "--plane", "x1,x3"], "not a state coordinate"),
        (&["basins", "--plane", "y1,y1"], "the same coordinate"),
        (&["basins", "--x-range", "nan,1"], "--x-range"),
        (&["basins", "--y-range", "2,-2"], "--y-range"),
        (
            &[
                "simulate",
                "--pulse-kp",
                "0.3",
                "--pulse-at",
                "299",
                "--pulse-periods",
                "5",
            ],
            "--pulse-at",
        ),
        (
            &["simulate", "--pulse-kp", "nan", "--pulse-at", "10"],
            "--pulse-kp",
        ),
    ];
    // run elsewhere than the repository, so that nothing lands there if a case goes through
    let dir = TempDir::new("attractors_refusals");
    for (args, needle) in cases {
        assert_refused_at_once(&dir, args, needle);
    }
}

#[test]
fn cli_basins_json_has_the_issue_shape_and_writes_its_files() {
    let dir = TempDir::new("attractors_basins");
    let v = json(&line(
        "basins --alpha 1.5 --grid 3,2 --periods 40 --known-tol 2e-4 --json --out",
        &[&dir.arg("b_kp0.05")],
    ));
    let atts = v["attractors"].as_array().unwrap();
    assert!(!atts.is_empty());
    let mut total = 0.0;
    for a in atts {
        for key in [
            "label",
            "period",
            "impacts_per_period",
            "avg_progression",
            "poincare",
        ] {
            assert!(a.get(key).is_some(), "{key} missing in {a}");
        }
        assert!(a["period"].is_u64() || a["period"].is_null());
        assert_eq!(a["poincare"][0].as_array().unwrap().len(), 3);
        total += a["fraction"].as_f64().unwrap();
    }
    assert!((total - 1.0).abs() < 1e-12, "fractions sum to {total}");
    assert_eq!(v["grid"]["nx"], 3);
    assert_eq!(v["work"]["runs"], 6);
    for ext in ["svg", "png", "csv", "json"] {
        let f = dir.file(&format!("b_kp0.05.{ext}"));
        assert!(
            f.metadata().map(|m| m.len() > 0).unwrap_or(false),
            "{}",
            f.display()
        );
    }
    let png = std::fs::read(dir.file("b_kp0.05.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // the file reports the settings the map ran with, as the printed summary does
    let file = std::fs::read_to_string(dir.file("b_kp0.05.json")).unwrap();
    assert!(v.to_string().contains("\"known_tol\":0.0002"), "{v}");
    assert!(file.contains("\"known_tol\":0.0002"), "{file}");
}
