//! Stability analysis: the Poincaré map's exact Jacobian against central finite differences on
//! orbits that cross every kind of event, Floquet multipliers, Lyapunov exponents.

use crate::common::{assert_holds, assert_ok, capsule, json, line, TempDir};
use crate::scene;
use capsule_analysis::floquet::{floquet, map_only, poincare_map};
use capsule_analysis::lyapunov::{largest_by_divergence, lyapunov};
use capsule_analysis::run;
use capsule_plant::scene::Scene;
use capsule_plant::EventKind;

/// A scene with `alpha` and `k_p` set.
fn at(name: &str, alpha: Option<f64>, kp: f64) -> Scene {
    let mut s = scene(name);
    if let Some(a) = alpha {
        s.drive.alpha = a;
    }
    s.control.kp = kp;
    s
}

/// The section point and period of the scene's attractor (must be periodic).
fn orbit(s: &Scene) -> ([f64; 3], usize) {
    let r = run(s).unwrap_or_else(|e| panic!("{}: {e}", s.name));
    let k = r
        .period
        .unwrap_or_else(|| panic!("{} (alpha {}) not periodic", s.name, s.drive.alpha));
    let f = r.final_state;
    ([f.x1 - f.x2, f.y1, f.y2], k)
}

/// Largest difference between the exact Jacobian and central differences with step `h`,
/// relative to the Jacobian's largest entry, and the events along the orbit.
fn fd_error(s: &Scene, x: [f64; 3], k: usize, h: f64) -> (f64, Vec<EventKind>) {
    let lin = poincare_map(s, x, k).unwrap_or_else(|e| panic!("{}: {e}", s.name));
    let dims = if lin.stuck_at_start { 2 } else { 3 };
    let scale = lin
        .jacobian
        .iter()
        .flatten()
        .fold(0.0f64, |m, v| m.max(v.abs()))
        .max(1.0);
    let mut err = 0.0f64;
    for c in 0..dims {
        let (mut xp, mut xm) = (x, x);
        xp[c] += h;
        xm[c] -= h;
        let p = map_only(s, xp, k).unwrap_or_else(|e| panic!("{e}"));
        let m = map_only(s, xm, k).unwrap_or_else(|e| panic!("{e}"));
        for r in 0..3 {
            let fd = (p[r] - m[r]) / (2.0 * h);
            err = err.max((fd - lin.jacobian[r][c]).abs() / scale);
        }
    }
    (err, lin.events)
}

fn kinds(events: &[EventKind]) -> String {
    let mut names: Vec<&str> = events
        .iter()
        .map(|e| match e {
            EventKind::ContactOn => "contact-on",
            EventKind::ContactOff => "contact-off",
            EventKind::BreakAway { .. } => "break-away",
            EventKind::SlipEnd => "stick-entry",
            EventKind::Reversal { .. } => "reversal",
            EventKind::Kink => "kink",
        })
        .collect();
    names.sort_unstable();
    names.dedup();
    names.join(" ")
}

#[test]
fn poincare_jacobian_agrees_with_finite_differences_through_every_event() {
    let cases: Vec<(Scene, f64)> = vec![
        (at("fig02a_coulomb.toml", Some(1.0), 0.0), 1e-6),
        (at("fig02a_coulomb.toml", Some(1.4), 0.0), 1e-6),
        (at("fig02a_coulomb.toml", Some(1.9), 0.0), 1e-6),
        (at("fig02b_viscous.toml", Some(1.2), 0.0), 1e-6),
        (at("control_point.toml", None, 0.1), 1e-6),
        (at("control_point.toml", None, -0.1), 1e-6),
        (at("control_point.toml", None, 0.0), 1e-6),
    ];
    let mut seen = String::new();
    for (s, tol) in cases {
        let (x, k) = orbit(&s);
        let (err, events) = fd_error(&s, x, k, 1e-7);
        let kinds = kinds(&events);
        println!(
            "{:45} alpha {:4} kp {:5}: period {k}, |J - FD| / |J| = {err:.1e}  events: {kinds}",
            s.name, s.drive.alpha, s.control.kp
        );
        assert!(
            err < tol,
            "{} alpha {} kp {}: {err:e}",
            s.name,
            s.drive.alpha,
            s.control.kp
        );
        seen.push_str(&kinds);
        seen.push(' ');
    }
    for kind in [
        "contact-on",
        "contact-off",
        "break-away",
        "stick-entry",
        "kink",
    ] {
        assert!(seen.contains(kind), "no orbit crossed {kind}: {seen}");
    }
}

#[test]
fn stribeck_stick_slip_orbit_jacobian_agrees_with_finite_differences() {
    // nonlinear slip: the variational equation is integrated; the map itself by the adaptive
    // method, whose tolerance bounds how well finite differences can be taken
    let mut s = at("fig02c_stribeck.toml", Some(1.8), 0.0);
    s.solver.tol = 1e-13;
    let (x, k) = orbit(&s);
    let (err, events) = fd_error(&s, x, k, 1e-5);
    println!(
        "stribeck alpha 1.8: period {k}, |J - FD| / |J| = {err:.1e}, events {}",
        kinds(&events)
    );
    assert!(events.iter().any(|e| matches!(e, EventKind::SlipEnd)));
    assert!(err < 1e-5, "{err:e}");
}

#[test]
fn floquet_multipliers_of_stable_orbits_are_inside_the_unit_circle() {
    for kp in [-0.2, -0.1, 0.0, 0.1, 0.2] {
        let s = at("control_point.toml", None, kp);
        let (x, k) = orbit(&s);
        let f = floquet(&s, x, k).unwrap_or_else(|e| panic!("{e}"));
        println!("kp {kp}: {:?}", f.multipliers);
        assert!(
            f.closure < 1e-8,
            "kp {kp}: not on the orbit ({})",
            f.closure
        );
        assert!(f.largest_modulus < 1.0, "kp {kp}: {}", f.largest_modulus);
    }
}

/// `ln|mu| / (k T)` per multiplier, largest first; a multiplier of rounding size is the exact
/// zero of the stick projection (`-inf`).
fn log_multipliers(s: &Scene, x: [f64; 3], k: usize) -> Vec<f64> {
    let f = floquet(s, x, k).unwrap_or_else(|e| panic!("{e}"));
    let t = k as f64 * s.drive.period();
    let mut out: Vec<f64> = f
        .multipliers
        .iter()
        .map(|m| {
            let r = m[0].hypot(m[1]);
            if r < 1e-12 {
                f64::NEG_INFINITY
            } else {
                r.ln() / t
            }
        })
        .collect();
    out.sort_by(|a, b| b.total_cmp(a));
    out
}

#[test]
fn lyapunov_exponents_of_a_periodic_orbit_are_log_multipliers_over_the_period() {
    // the frame starts off the eigenvectors, so the estimate is off by O(1 / run length):
    // checked by the error falling about fourfold when the run is four times longer
    for kp in [-0.1, 0.1] {
        let mut s = at("control_point.toml", None, kp);
        let (x, k) = orbit(&s);
        let want = log_multipliers(&s, x, k);
        let mut errs = Vec::new();
        for measured in [100u32, 400] {
            s.horizon.periods = s.horizon.transient + measured;
            let l = lyapunov(&s).unwrap_or_else(|e| panic!("{e}"));
            println!(
                "kp {kp}, {measured} periods: lyapunov {:?} vs ln|mu|/T {want:?}",
                l.exponents
            );
            let mut err = 0.0f64;
            for (a, b) in l.exponents.iter().zip(&want) {
                if b.is_finite() {
                    err = err.max((a - b).abs());
                } else {
                    assert_eq!(a, b, "kp {kp}: the stick direction");
                }
            }
            errs.push(err);
        }
        assert!(
            errs[1] < 1e-3 && errs[1] < errs[0] / 3.0,
            "kp {kp}: {errs:?}"
        );
    }
}

/// Largest exponent over `measured` periods after the scene's transient, and the two-trajectory
/// estimate over the same periods.
fn largest(s: &Scene, measured: u32) -> (f64, f64) {
    let mut s = s.clone();
    s.horizon.periods = s.horizon.transient + measured;
    let l = lyapunov(&s).unwrap_or_else(|e| panic!("{e}"));
    let d = largest_by_divergence(&s, 1e-9).unwrap_or_else(|e| panic!("{e}"));
    (l.exponents[0], d)
}

#[test]
fn chaotic_scenes_have_a_positive_converging_largest_exponent() {
    let coulomb = at("fig02a_coulomb.toml", Some(0.5), 0.0);
    let stribeck = at("fig02c_stribeck.toml", Some(1.3), 0.0);
    for (s, runs) in [(coulomb, [250u32, 500, 1000]), (stribeck, [100, 200, 400])] {
        let est: Vec<(f64, f64)> = runs.iter().map(|&n| largest(&s, n)).collect();
        println!(
            "{} alpha {}: {runs:?} periods -> (jacobians, two trajectories) {est:?}",
            s.name, s.drive.alpha
        );
        for (l, d) in &est {
            assert!(*l > 0.0, "{}: {est:?}", s.name);
            // the same quantity measured without the Jacobians; a finite separation (1e-9) does
            // not follow the linearization through near-grazing crossings, hence 20 %
            assert!((l - d).abs() < 0.2 * l, "{}: {est:?}", s.name);
        }
        // converges as the run grows: the estimates over 1x, 2x, 4x the run stay within 15 %
        // of each other (a finite-time exponent fluctuates like 1 / sqrt(run))
        let ls: Vec<f64> = est.iter().map(|e| e.0).collect();
        let (lo, hi) = ls.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &l| {
            (lo.min(l), hi.max(l))
        });
        assert!(hi - lo < 0.15 * lo, "{}: {ls:?}", s.name);
    }
}

/// `capsule simulate` with `extra` flags, its debug log on: the JSON, and how many stretches of
/// trajectory the process linearized (the stability analyses' counter it logs).
fn simulate_counting(extra: &str) -> (serde_json::Value, u64) {
    let args = line(
        "simulate --scene scenes/control_point.toml --kp 0.1 --periods 220 --json",
        &[],
    );
    let out = crate::common::command("capsule")
        .args(args)
        .args(extra.split_whitespace())
        .env("RUST_LOG", "debug")
        .output()
        .unwrap_or_else(|e| panic!("cannot run capsule: {e}"));
    let log = crate::common::stderr(&out);
    // the log line says `linearizations=N`; colour codes (ESC [ ... m) removed first
    let mut plain = String::new();
    let mut rest = log.as_str();
    while let Some(at) = rest.find('\u{1b}') {
        plain.push_str(&rest[..at]);
        rest = rest[at..].split_once('m').map_or("", |(_, after)| after);
    }
    plain.push_str(rest);
    let count = plain
        .split("linearizations=")
        .nth(1)
        .and_then(|t| t.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no linearization count in the log:\n{log}"));
    (crate::common::json_of(&out), count)
}

#[test]
fn stability_runs_only_when_asked() {
    let (plain, none) = simulate_counting("");
    assert_eq!(none, 0, "an unrequested stability analysis ran");
    for field in ["floquet", "lyapunov", "stability_note"] {
        assert!(
            plain.get(field).is_none(),
            "{field} without --stability: {plain}"
        );
    }
    let (asked, some) = simulate_counting("--stability");
    // one Floquet map and one linearized period per measured period for the Lyapunov spectrum
    assert!(some > 20, "{some} linearizations with --stability");
    assert!(
        asked["floquet"].is_object() && asked["lyapunov"].is_object(),
        "{asked}"
    );
    // the rest of the output is the same either way
    let mut trimmed = asked.clone();
    for field in ["floquet", "lyapunov", "stability_note", "wall_time_s"] {
        trimmed.as_object_mut().map(|o| o.remove(field));
    }
    let mut plain = plain;
    plain.as_object_mut().map(|o| o.remove("wall_time_s"));
    assert_eq!(trimmed, plain);
}

#[test]
fn simulate_and_sweep_report_the_stability() {
    let v = json(&line(
        "simulate --scene scenes/control_point.toml --kp 0.1 --periods 220 --json --stability",
        &[],
    ));
    let m = v["floquet"]["largest_modulus"].as_f64().unwrap_or(f64::NAN);
    assert!(m > 0.0 && m < 1.0, "{v}");
    assert_eq!(
        v["floquet"]["multipliers"].as_array().map(Vec::len),
        Some(3)
    );
    let l = v["lyapunov"]["exponents"][0].as_f64().unwrap_or(f64::NAN);
    assert!(l < 0.0, "{v}");
    // a law with memory: no stability figures, and a note that says why
    let v = json(&line(
        "simulate --scene scenes/fig02d_seven_parameter.toml --periods 12 --transient 10 --json \
         --stability",
        &[],
    ));
    assert!(v["lyapunov"].is_null(), "{v}");
    assert!(
        v["stability_note"]
            .as_str()
            .unwrap_or("")
            .contains("memory"),
        "{v}"
    );
    let dir = TempDir::new("stability_sweep");
    let prefix = dir.file("ly");
    assert_ok(&capsule(&line(
        "sweep --scene scenes/fig02a_coulomb.toml --param alpha --from 0.5 --to 1.5 --steps 3 \
         --periods 250 --lyapunov --out",
        &[prefix.to_str().unwrap_or_default()],
    )));
    let csv = std::fs::read_to_string(prefix.with_extension("csv")).unwrap_or_default();
    assert!(csv
        .lines()
        .next()
        .unwrap_or("")
        .ends_with("lyapunov_1,lyapunov_2,lyapunov_3"));
    // alpha 0.5 is in the chaotic band, alpha 1.5 on the period-1 branch
    let first = |a: &str| -> f64 {
        csv.lines()
            .find(|l| l.starts_with(&format!("{a},0,")))
            .and_then(|l| l.split(',').nth(10))
            .and_then(|x| x.parse().ok())
            .unwrap_or(f64::NAN)
    };
    assert!(first("0.5") > 0.0 && first("1.5") < 0.0, "{csv}");
    let svg = std::fs::read_to_string(prefix.with_extension("svg")).unwrap_or_default();
    assert!(svg.contains("largest Lyapunov exponent"));
}

mod continuation {
    use super::{assert_holds, at};
    use capsule_analysis::continuation::{
        continue_branch, switch_at_period_doubling, Branch, ContinuationConfig, ContinuationError,
        SpecialKind, SpecialPoint,
    };
    use capsule_analysis::{run, Param};
    use capsule_plant::scene::Scene;

    /// Where the branch has special points of this kind.
    fn values(b: &Branch, kind: SpecialKind) -> Vec<f64> {
        b.special
            .iter()
            .filter(|p| p.kind == kind)
            .map(|p| p.value)
            .collect()
    }

    /// The period of the brute-force run of `s` at `alpha`.
    fn period_at(s: &Scene, alpha: f64) -> Option<usize> {
        run(&Param::Alpha.apply(s, alpha))
            .ok()
            .and_then(|r| r.period)
    }

    /// Continued from alpha 2 down to 0.93: the period-1 branch, its first period doubling,
    /// and the period-2 branch switched onto there.
    fn down_to_period_two(s: &Scene) -> (SpecialPoint, Branch) {
        let settings = ContinuationConfig::new(Param::Alpha, 0.93);
        let b = continue_branch(s, &settings).unwrap_or_else(|e| panic!("{e}"));
        let pd = b
            .special
            .iter()
            .find(|p| p.kind == SpecialKind::PeriodDoubling)
            .unwrap_or_else(|| panic!("no period doubling: {:?}", b.special));
        println!("period-1 branch: {:?}", b.special);
        let b2 = switch_at_period_doubling(s, &settings, 1, pd).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(b2.period, 2);
        println!("period-2 branch: {:?}", b2.special);
        (pd.clone(), b2)
    }

    #[test]
    fn fig2a_main_branch_period_doubles_where_the_sweep_changes_period() {
        let s = at("fig02a_coulomb.toml", Some(2.0), 0.0);
        let b = continue_branch(&s, &ContinuationConfig::new(Param::Alpha, 0.95))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(b.stopped.is_none(), "{:?}", b.stopped);
        assert_eq!(b.period, 1);
        let pd = values(&b, SpecialKind::PeriodDoubling);
        assert_eq!(pd.len(), 1, "{:?}", b.special);
        let pd = pd[0];
        println!("period doubling at alpha = {pd}");
        // stable above it, unstable below, and the brute-force runs agree on both sides
        for p in &b.points {
            assert_eq!(
                p.stable,
                p.value > pd,
                "alpha {}: {:?}",
                p.value,
                p.multipliers
            );
        }
        assert_eq!(period_at(&s, pd + 0.03), Some(1));
        assert_eq!(period_at(&s, pd - 0.03), Some(2));
        // along the stable part the branch is the attractor the sweep finds
        let mut compared = 0;
        for p in b.points.iter().filter(|p| p.value > pd + 0.02).step_by(5) {
            let r = run(&Param::Alpha.apply(&s, p.value)).unwrap_or_else(|e| panic!("{e}"));
            let f = r.final_state;
            let d = [f.x1 - f.x2 - p.x[0], f.y1 - p.x[1], f.y2 - p.x[2]];
            assert!(d.iter().all(|v| v.abs() < 1e-6), "alpha {}: {d:?}", p.value);
            compared += 1;
        }
        assert!(compared >= 5, "{compared}");
    }

    #[test]
    fn fig2a_switching_at_the_period_doubling_follows_the_period_two_orbit_down_to_0_94() {
        let s = at("fig02a_coulomb.toml", Some(2.0), 0.0);
        let (pd, b2) = down_to_period_two(&s);
        assert!(b2.stopped.is_none(), "{:?}", b2.stopped);
        // the period-2 orbit is born where the period-1 orbit loses stability, and doubles again
        // near alpha 0.94, where the brute-force run is period-4 and the chaotic band begins
        let pd2 = values(&b2, SpecialKind::PeriodDoubling);
        assert!(
            pd2.len() == 1 && pd2[0] > 0.935 && pd2[0] < 0.945,
            "{pd2:?}"
        );
        for p in &b2.points {
            assert_eq!(
                p.stable,
                p.value > pd2[0] && p.value < pd.value,
                "alpha {}",
                p.value
            );
        }
        let r = run(&Param::Alpha.apply(&s, 0.94)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.period, Some(4));
        // at alpha 1.0 the brute-force run settles on this period-2 orbit
        let p = b2
            .points
            .iter()
            .min_by(|a, b| (a.value - 1.0).abs().total_cmp(&(b.value - 1.0).abs()))
            .unwrap_or_else(|| panic!("empty branch"));
        let r = run(&Param::Alpha.apply(&s, p.value)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(r.period, Some(2));
        let near = r.poincare[r.poincare.len() - 2..]
            .iter()
            .any(|q| (q[0] - p.x[0]).abs() < 1e-6 && (q[2] - p.x[1]).abs() < 1e-6);
        assert!(
            near,
            "alpha {}: {:?} vs {:?}",
            p.value,
            &r.poincare[r.poincare.len() - 2..],
            p.x
        );
    }

    #[test]
    fn fig2b_viscous_transitions_are_found_by_continuation_and_agree_with_the_sweep() {
        // Fig 2b (Coulomb + viscous): periodic from alpha 0.942 in the paper; here period 1
        // above a period doubling near 1.33 and period 2 below it, down to a second doubling
        // near 0.95 where the chaotic band begins
        let s = at("fig02b_viscous.toml", Some(2.0), 0.0);
        let (pd, b2) = down_to_period_two(&s);
        assert!(pd.value > 1.30 && pd.value < 1.36, "{}", pd.value);
        assert_eq!(period_at(&s, pd.value + 0.03), Some(1));
        assert_eq!(period_at(&s, pd.value - 0.03), Some(2));
        let pd2 = values(&b2, SpecialKind::PeriodDoubling);
        assert!(pd2.len() == 1 && pd2[0] > 0.94 && pd2[0] < 0.96, "{pd2:?}");
        assert_eq!(period_at(&s, pd2[0] + 0.01), Some(2));
    }

    #[test]
    fn fig15_gain_range_is_period_one_and_stable_with_the_second_impact_located() {
        let s = at("control_point.toml", None, -0.2);
        let b = continue_branch(&s, &ContinuationConfig::new(Param::Kp, 0.2))
            .unwrap_or_else(|e| panic!("{e}"));
        assert!(b.stopped.is_none(), "{:?}", b.stopped);
        assert_eq!(b.period, 1);
        assert!(b.points.last().is_some_and(|p| p.value >= 0.2));
        assert!(
            b.points.iter().all(|p| p.stable),
            "an unstable point in [-0.2, 0.2]"
        );
        assert!(!b.special.iter().any(|p| matches!(
            p.kind,
            SpecialKind::PeriodDoubling | SpecialKind::Fold | SpecialKind::Torus
        )));
        // the second impact appears between k_p = 0.07 and 0.08 (the sweep's finding, docs/model.md)
        let g = values(&b, SpecialKind::Grazing);
        assert!(
            g.len() == 1 && g[0] > 0.07 && g[0] < 0.08,
            "{:?}",
            b.special
        );
        let impacts = |kp: f64| {
            run(&Param::Kp.apply(&s, kp))
                .map(|r| r.impacts_per_period)
                .unwrap_or(f64::NAN)
        };
        assert_eq!(impacts(g[0] - 2e-3), 1.0);
        assert_eq!(impacts(g[0] + 2e-3), 2.0);
    }

    #[test]
    fn a_chaotic_start_is_refused_with_a_clear_message() {
        let s = at("fig02a_coulomb.toml", Some(0.5), 0.0);
        let e = continue_branch(&s, &ContinuationConfig::new(Param::Alpha, 1.0));
        assert!(
            matches!(e, Err(ContinuationError::NotPeriodic { .. })),
            "{e:?}"
        );
        let msg = e.err().map(|e| e.to_string()).unwrap_or_default();
        assert_holds(&msg, &["alpha = 0.5", "not periodic"]);
    }
}

#[test]
fn continue_command_writes_the_branch_and_refuses_bad_input() {
    let dir = TempDir::new("stability_continue");
    let prefix = dir.file("b");
    let p = prefix.to_str().unwrap_or_default();
    let base = line("continue --scene scenes/control_point.toml --out", &[p]);
    let run = |extra: &[&str]| capsule(&[&base[..], extra].concat());
    let ok = run(&["--kp", "0.05", "--param", "kp", "--to", "0.1"]);
    assert_ok(&ok);
    let out = String::from_utf8_lossy(&ok.stdout);
    assert!(out.contains("Grazing at kp = 0.07"), "{out}");
    let csv = std::fs::read_to_string(prefix.with_extension("csv")).unwrap_or_default();
    assert!(csv.starts_with("kp,x1_minus_x2,y1,y2,stable"), "{csv}");
    let svg = std::fs::read_to_string(prefix.with_extension("svg")).unwrap_or_default();
    assert!(svg.contains("grazing") && svg.contains("<line"), "svg");
    for (extra, says) in [
        (
            &["--param", "mu", "--to", "1"][..],
            "invalid value 'mu' for '--param <PARAM>'",
        ),
        (
            &line(
                "--alpha 0.3 --param alpha --to 1 --gamma 5 --beta 15 --xi 0.01 --omega 0.95",
                &[],
            )[..],
            "not periodic",
        ),
    ] {
        let bad = run(extra);
        let err = String::from_utf8_lossy(&bad.stderr);
        assert!(
            !bad.status.success() && err.contains(says),
            "{extra:?}: {err}"
        );
    }
}

#[test]
fn near_grazing_the_linearization_holds_only_for_perturbations_below_the_distance() {
    // k_p just past the grazing where the second impact appears (located by continuation at
    // 0.070170953): the new contact is shallow. Contact switches a stiffness on at zero force, so
    // the saltation is the identity and the map stays C1 through grazing, but its second
    // derivative grows like distance^(-1/2): central differences with a step larger than the
    // penetration depth see the other side of the grazing.
    let kg = 0.070170953;
    let mut at_h5 = Vec::new();
    for dk in [1e-3, 1e-5] {
        let s = at("control_point.toml", None, kg + dk);
        let (x, k) = orbit(&s);
        let lin = poincare_map(&s, x, k).unwrap_or_else(|e| panic!("{e}"));
        let errs: Vec<(f64, f64)> = [1e-9, 1e-7, 1e-5, 1e-3]
            .iter()
            .map(|&h| (h, fd_error(&s, x, k, h).0))
            .collect();
        println!(
            "kp = grazing + {dk:e}: transversality {:.2e}, (h, |J - FD|/|J|) {errs:?}",
            lin.min_transversality
        );
        // small steps agree
        assert!(errs[1].1 < 1e-6, "{errs:?}");
        at_h5.push(errs[2].1);
    }
    // a step of 1e-5 is fine 1e-3 from grazing and not 1e-5 from it
    assert!(at_h5[1] > 100.0 * at_h5[0], "{at_h5:?}");
}
