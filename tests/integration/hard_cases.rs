//! Hard cases: each must stay finite, end (no Zeno lock-up: bounded events per period, or a
//! clear error), and converge as the tolerance tightens. Plus property tests over random valid
//! scenes for the same invariants.

use crate::scene;
use capsule_analysis::{run, RunReport};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{
    Capsule, ConstantForce, Friction, Method, Model, SimError, Simulator, SolverConfig, State,
};
use proptest::prelude::*;

/// Events a well-behaved run may have per drive period.
const MAX_EVENTS_PER_PERIOD: f64 = 200.0;

fn checked(s: &Scene) -> RunReport {
    let r = run(s).unwrap_or_else(|e| panic!("{}: {e}", s.name));
    let f = r.final_state;
    assert!(
        [f.x1, f.y1, f.x2, f.y2].iter().all(|v| v.is_finite()),
        "{}: {f:?}",
        s.name
    );
    let per_period = r.work.events as f64 / s.horizon.periods as f64;
    assert!(
        per_period < MAX_EVENTS_PER_PERIOD,
        "{}: {per_period} events per period",
        s.name
    );
    r
}

fn short(mut s: Scene, periods: u32) -> Scene {
    s.horizon.periods = periods;
    s.horizon.transient = periods / 2;
    s
}

fn adaptive(s: &Scene, tol: f64) -> Scene {
    let mut a = s.clone();
    a.solver = SolverConfig {
        method: Method::Adaptive,
        tol,
        step: 1e-3,
    };
    a
}

/// |a - b| of the average progression.
fn gap(a: &RunReport, b: &RunReport) -> f64 {
    (a.avg_progression - b.avg_progression).abs()
}

#[test]
fn stiff_pre_sliding_stays_bounded_and_converges() {
    for k_s in [4e4, 1e6] {
        let mut s = short(scene("fig02d_seven_parameter.toml"), 16);
        s.drive.alpha = 1.9; // a periodic window of Fig 2d
        if let Friction::SevenParameter(ref mut law) = s.model.friction {
            law.k_s = k_s;
        }
        let coarse = checked(&adaptive(&s, 1e-7));
        let fine = checked(&adaptive(&s, 1e-10));
        let finest = checked(&adaptive(&s, 1e-12));
        assert!(
            gap(&fine, &finest) < gap(&coarse, &finest).max(1e-9),
            "k_s {k_s}"
        );
        assert!(
            gap(&fine, &finest) < 1e-5,
            "k_s {k_s}: {}",
            gap(&fine, &finest)
        );
    }
}

#[test]
fn grazing_contact_is_located_and_methods_agree() {
    // the mass starts a hair below the gap, barely moving towards it
    let mut s = short(scene("control_point.toml"), 20);
    s.initial = State {
        x1: 0.02 - 1e-10,
        y1: 1e-9,
        x2: 0.0,
        y2: 0.0,
    };
    let exact = checked(&s);
    let adapt = checked(&adaptive(&s, 1e-12));
    assert!((exact.final_state.x2 - adapt.final_state.x2).abs() < 1e-7);
}

#[test]
fn force_hovering_at_the_threshold_does_not_lock_up() {
    // a held force equal to the threshold: the capsule force settles onto f_b exactly
    let model = scene("control_point.toml").model;
    for method in [Method::Exact, Method::Adaptive] {
        let cfg = SolverConfig {
            method,
            tol: 1e-10,
            step: 1e-3,
        };
        let mut sim =
            Simulator::new(model, State::default(), 0.0, cfg).unwrap_or_else(|e| panic!("{e}"));
        sim.advance(&ConstantForce(model.friction.threshold()), 400.0)
            .unwrap_or_else(|e| panic!("{method:?}: {e}"));
        // once the overshoot breaks it away, a Coulomb capsule pushed with exactly the friction
        // level glides on at constant speed: forward, finite
        let s = sim.state();
        assert!(
            s.x2.is_finite() && s.x2 >= 0.0 && s.y2 >= 0.0,
            "{method:?}: {s:?}"
        );
        assert!(sim.work().events < 2000, "{method:?}: {:?}", sim.work());
    }
}

#[test]
fn zero_gap_and_very_stiff_contact() {
    let mut s = short(scene("fig15_forward.toml"), 30);
    s.model.capsule.delta = 0.0; // contact and feedback kink coincide
    let a = checked(&s);
    let b = checked(&adaptive(&s, 1e-12));
    assert!(gap(&a, &b) < 1e-8, "zero gap: {}", gap(&a, &b));
    let mut stiff = short(scene("fig02a_coulomb.toml"), 30);
    stiff.model.capsule.beta = 1e4;
    stiff.drive.alpha = 1.0;
    let a = checked(&stiff);
    let b = checked(&adaptive(&stiff, 1e-12));
    assert!(gap(&a, &b) < 1e-7, "beta 1e4: {}", gap(&a, &b));
}

#[test]
fn a_very_long_run_keeps_the_progression_to_rounding() {
    let mut s = scene("fig15_forward.toml");
    s.horizon.periods = 100_000;
    s.horizon.transient = 99_900;
    let long = checked(&s);
    let base = checked(&scene("fig15_forward.toml"));
    assert!(long.final_state.x2 > 1e5);
    assert!(
        gap(&long, &base) < 1e-10,
        "{} vs {}",
        long.avg_progression,
        base.avg_progression
    );
}

#[test]
fn extreme_gains_accelerate_or_end_with_a_clear_error() {
    let mut s = scene("control_point.toml");
    s.control.kp = 10.0; // the feedback pushes the mass, and with it the capsule, ever faster
    let r = checked(&s);
    assert!(r.final_state.y2 > 100.0);
    s.control.kp = -10.0; // negative effective stiffness on the far side of the kink
    match run(&s) {
        Err(e @ SimError::Diverged { .. }) => assert!(e.to_string().contains("diverges")),
        other => panic!("expected divergence, got {other:?}"),
    }
}

#[test]
fn very_low_and_very_high_drive_frequencies() {
    for omega in [0.05, 10.0] {
        let mut s = short(scene("control_point.toml"), 20);
        s.drive.omega = omega;
        s.drive.alpha = if omega > 1.0 { 20.0 } else { 1.6 };
        let a = checked(&s);
        let b = checked(&adaptive(&s, 1e-12));
        assert!(gap(&a, &b) < 1e-7, "omega {omega}: {}", gap(&a, &b));
    }
}

#[test]
fn frictional_memory_delay_below_and_far_above_the_step() {
    for tau_d in [1e-3, 2.0] {
        let mut s = short(scene("fig02d_seven_parameter.toml"), 10);
        s.drive.alpha = 1.9;
        if let Friction::SevenParameter(ref mut law) = s.model.friction {
            law.tau_d = tau_d;
        }
        let coarse = checked(&adaptive(&s, 1e-7));
        let fine = checked(&adaptive(&s, 1e-11));
        assert!(
            gap(&coarse, &fine) < 1e-4,
            "tau_d {tau_d}: {}",
            gap(&coarse, &fine)
        );
    }
}

fn friction_strategy() -> impl Strategy<Value = Friction> {
    prop_oneof![
        Just(Friction::COULOMB),
        (0.0..1.0f64).prop_map(|mu_v| Friction::Viscous(capsule_plant::friction::Viscous { mu_v })),
        (0.02..1.0f64)
            .prop_map(|v_s| Friction::Stribeck(capsule_plant::friction::Stribeck { v_s })),
        (0.0..1.0f64, 0.02..1.0f64).prop_map(|(mu_v, v_s)| Friction::GaussianStribeck(
            capsule_plant::friction::GaussianStribeck { mu_v, v_s }
        )),
        (0.0..1.0f64, 0.02..1.0f64, 0.0..0.5f64, 1e3..1e5f64).prop_map(
            |(mu_v, v_s, tau_d, k_s)| {
                Friction::SevenParameter(capsule_plant::friction::SevenParameter {
                    mu_v,
                    v_s,
                    tau_d,
                    k_s,
                })
            }
        ),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

    #[test]
    fn random_valid_scenes_stay_finite_stick_exactly_and_end(
        gamma in 0.1..10.0f64,
        beta in prop_oneof![Just(0.0), 0.5..50.0f64],
        delta in 0.0..0.1f64,
        xi in 0.0..0.2f64,
        alpha in 0.0..3.0f64,
        omega in 0.3..3.0f64,
        kp in -0.9..0.9f64,
        friction in friction_strategy(),
    ) {
        let model = Model { capsule: Capsule { gamma, beta, delta, xi }, friction };
        let law = AffineLaw::paper(alpha, omega, kp);
        let cfg = SolverConfig { tol: 1e-9, ..SolverConfig::most_accurate_for(&model) };
        let period = std::f64::consts::TAU / omega;
        let mut sim = Simulator::new(model, State::default(), 0.0, cfg)
            .map_err(|e| TestCaseError::fail(e.to_string()))?;
        for n in 1..=6 {
            sim.advance(&law, n as f64 * period).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let snap = sim.snapshot();
            let s = snap.state;
            prop_assert!([s.x1, s.y1, s.x2, s.y2].iter().all(|v| v.is_finite()));
            if snap.stuck && model.friction.presliding().is_none() {
                prop_assert_eq!(s.y2, 0.0);
            }
        }
        prop_assert!((sim.work().events as f64) < 6.0 * MAX_EVENTS_PER_PERIOD);
        if model.friction.is_piecewise_linear() {
            // the exact and the adaptive method agree over two periods
            let mut a = Simulator::new(model, State::default(), 0.0, SolverConfig { method: Method::Adaptive, tol: 1e-12, step: 1e-3 })
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            let mut b = Simulator::new(model, State::default(), 0.0, cfg)
                .map_err(|e| TestCaseError::fail(e.to_string()))?;
            a.advance(&law, 2.0 * period).map_err(|e| TestCaseError::fail(e.to_string()))?;
            b.advance(&law, 2.0 * period).map_err(|e| TestCaseError::fail(e.to_string()))?;
            let (sa, sb) = (a.state(), b.state());
            prop_assert!((sa.x2 - sb.x2).abs() < 1e-6, "{:?} vs {:?}", sa, sb);
        }
    }
}

/// Mechanical energy: kinetic, primary spring, contact spring, pre-sliding spring.
fn energy(model: &Model, s: &capsule_plant::Snapshot, p: f64) -> f64 {
    let c = &model.capsule;
    let z = s.state.x1 - s.state.x2;
    let contact = if z > c.delta {
        0.5 * c.beta * (z - c.delta).powi(2)
    } else {
        0.0
    };
    0.5 * s.state.y1.powi(2) + 0.5 * c.gamma * s.state.y2.powi(2) + 0.5 * z * z + contact + p
}

#[test]
fn without_a_drive_the_energy_never_grows() {
    // released from a compressed contact spring with no drive: friction and damping only take
    for friction in [
        Friction::COULOMB,
        Friction::Viscous(capsule_plant::friction::Viscous { mu_v: 0.1 }),
        Friction::Stribeck(capsule_plant::friction::Stribeck { v_s: 0.1 }),
        Friction::GaussianStribeck(capsule_plant::friction::GaussianStribeck {
            mu_v: 0.1,
            v_s: 0.1,
        }),
    ] {
        let model = Model {
            capsule: Capsule {
                gamma: 0.5,
                beta: 15.0,
                delta: 0.02,
                xi: 0.01,
            },
            friction,
        };
        let cfg = SolverConfig {
            tol: 1e-11,
            ..SolverConfig::most_accurate_for(&model)
        };
        let start = State {
            x1: 0.6,
            y1: 0.0,
            x2: 0.0,
            y2: 0.0,
        };
        let mut sim = Simulator::new(model, start, 0.0, cfg).unwrap_or_else(|e| panic!("{e}"));
        let e0 = energy(&model, &sim.snapshot(), 0.0);
        let mut last = e0;
        for i in 1..=400 {
            sim.advance(&ConstantForce(0.0), i as f64 * 0.1)
                .unwrap_or_else(|e| panic!("{e}"));
            let e = energy(&model, &sim.snapshot(), 0.0);
            assert!(
                e <= last + 1e-9 * e0,
                "{friction:?} at tau {}: energy {e} after {last}",
                i as f64 * 0.1
            );
            last = e;
        }
        assert!(
            last < 0.5 * e0,
            "{friction:?}: energy {last} of {e0} left: nothing dissipated?"
        );
    }
}
