//! The simulator's physics and numerics: stick-slip, events, methods, effects that cost nothing.

use crate::scene;
use capsule_analysis::{run, run_sampled};
use capsule_plant::scene::Scene;
use capsule_plant::{
    ConstantForce, EventKind, Friction, Method, SimError, Simulator, SolverConfig, State,
};

fn snapshots(s: &Scene, samples: u32) -> Vec<capsule_plant::Snapshot> {
    let mut out = Vec::new();
    run_sampled(s, samples, &mut |snap| out.push(*snap)).unwrap_or_else(|e| panic!("{e}"));
    out
}

#[test]
fn a_stuck_capsule_has_exactly_zero_velocity_and_friction_within_the_threshold() {
    for name in [
        "control_point.toml",
        "fig02a_coulomb.toml",
        "fig16_chaos_control.toml",
    ] {
        let mut s = scene(name);
        s.horizon.periods = 40;
        s.horizon.transient = 0;
        let snaps = snapshots(&s, 200);
        let fb = s.model.friction.threshold();
        let stuck: Vec<_> = snaps.iter().filter(|x| x.stuck).collect();
        assert!(
            !stuck.is_empty() && stuck.len() < snaps.len(),
            "{name}: needs stick and slip"
        );
        for x in stuck {
            assert_eq!(x.state.y2, 0.0, "{name} at tau {}", x.tau);
            assert!(
                x.friction_force.abs() <= fb + 1e-9,
                "{name}: {}",
                x.friction_force
            );
        }
        for x in snaps.iter().filter(|x| !x.stuck) {
            // slipping: friction opposes the motion with at least the Coulomb level
            assert!(
                x.friction_force * x.state.y2 >= 0.0,
                "{name} at tau {}",
                x.tau
            );
        }
    }
}

#[test]
fn a_slipping_capsule_sticks_or_reverses_only_where_the_force_says_so() {
    let s = scene("fig02a_coulomb.toml");
    let law = s.law();
    let mut sim =
        Simulator::new(s.model, s.initial, 0.0, s.solver).unwrap_or_else(|e| panic!("{e}"));
    let mut ends = Vec::new();
    sim.advance_observed(&law, 200.0, &mut |e| {
        if matches!(e.kind, EventKind::SlipEnd | EventKind::Reversal { .. }) {
            ends.push(*e)
        }
    })
    .unwrap_or_else(|e| panic!("{e}"));
    assert!(ends.iter().any(|e| e.kind == EventKind::SlipEnd));
    // replay to each slip end and check the force there against the threshold
    let mut sim =
        Simulator::new(s.model, s.initial, 0.0, s.solver).unwrap_or_else(|e| panic!("{e}"));
    for e in ends.iter().take(20) {
        sim.advance(&law, e.tau).unwrap_or_else(|e| panic!("{e}"));
        let st = sim.state();
        let m = sim.regime();
        let f = s.model.capsule_force(st.x1 - st.x2, st.y1, 0.0, m.contact);
        match e.kind {
            EventKind::SlipEnd => assert!(f.abs() <= 1.0 + 1e-9, "stuck with |F| = {f}"),
            _ => assert!(f.abs() > 1.0 - 1e-9, "reversed with |F| = {f}"),
        }
        assert!(st.y2.abs() < 1e-12, "y2 = {} at a slip end", st.y2);
    }
}

#[test]
fn fixed_steps_converge_to_the_exact_solution_and_adaptive_tolerances_too() {
    let mut s = scene("fig15_forward.toml");
    s.horizon.periods = 60;
    s.horizon.transient = 40;
    let exact = run(&s).unwrap_or_else(|e| panic!("{e}")).avg_progression;
    let err = |method: Method, tol: f64, step: f64| {
        let mut t = s.clone();
        t.solver = SolverConfig { method, tol, step };
        (run(&t).unwrap_or_else(|e| panic!("{e}")).avg_progression - exact).abs()
    };
    let fixed: Vec<f64> = [1e-2, 1e-3, 1e-4]
        .iter()
        .map(|&h| err(Method::Fixed, 0.0, h))
        .collect();
    assert!(
        fixed[0] > fixed[1] && fixed[1] > fixed[2],
        "fixed: {fixed:?}"
    );
    let adaptive: Vec<f64> = [1e-5, 1e-8, 1e-11]
        .iter()
        .map(|&t| err(Method::Adaptive, t, 0.0))
        .collect();
    assert!(
        adaptive[0] > adaptive[2] && adaptive[2] < 1e-8,
        "adaptive: {adaptive:?}"
    );
}

#[test]
fn effects_a_scene_leaves_out_are_not_simulated() {
    // no feedback: no kink events; no secondary spring: no contact events
    let mut s = scene("control_point.toml");
    s.horizon.periods = 20;
    s.horizon.transient = 0;
    let law = s.law();
    let count = |s: &Scene| {
        let mut sim =
            Simulator::new(s.model, s.initial, 0.0, s.solver).unwrap_or_else(|e| panic!("{e}"));
        let (mut kinks, mut contacts) = (0, 0);
        sim.advance_observed(&s.law(), 100.0, &mut |e| match e.kind {
            EventKind::Kink => kinks += 1,
            EventKind::ContactOn | EventKind::ContactOff => contacts += 1,
            _ => {}
        })
        .unwrap_or_else(|e| panic!("{e}"));
        (kinks, contacts)
    };
    let _ = law;
    assert_eq!(count(&s).0, 0);
    let mut with_kp = s.clone();
    with_kp.control.kp = 0.1;
    assert!(count(&with_kp).0 > 0);
    let mut no_spring = s.clone();
    no_spring.model.capsule.beta = 0.0;
    assert_eq!(count(&no_spring).1, 0);
    assert!(count(&s).1 > 0);
}

#[test]
fn pre_sliding_keeps_the_stuck_capsule_within_the_spring_reach() {
    let mut s = scene("fig02d_seven_parameter.toml");
    s.horizon.periods = 12;
    s.horizon.transient = 0;
    let Friction::SevenParameter(capsule_plant::friction::SevenParameter { k_s, .. }) =
        s.model.friction
    else {
        panic!("law")
    };
    let snaps = snapshots(&s, 400);
    let fb = s.model.friction.threshold();
    let stuck: Vec<_> = snaps.iter().filter(|x| x.stuck).collect();
    assert!(!stuck.is_empty());
    for x in stuck {
        assert!(
            x.friction_force.abs() <= fb + 1e-6,
            "spring force {}",
            x.friction_force
        );
        // the spring's reach fb / k_s bounds the displacement, so velocities stay small
        assert!(x.state.y2.abs() < 10.0 * fb / k_s * (k_s / s.model.capsule.gamma).sqrt());
    }
}

#[test]
fn the_exact_method_refuses_nonlinear_friction_and_takes_a_held_command() {
    let s = scene("fig02c_stribeck.toml");
    let cfg = SolverConfig {
        method: Method::Exact,
        tol: 1e-10,
        step: 1e-3,
    };
    let err = Simulator::new(s.model, State::default(), 0.0, cfg).err();
    assert!(
        matches!(err, Some(SimError::ExactNeedsLinearLaw("stribeck"))),
        "{err:?}"
    );
    let c = scene("control_point.toml");
    let mut sim =
        Simulator::new(c.model, State::default(), 0.0, c.solver).unwrap_or_else(|e| panic!("{e}"));
    // a held force beyond the threshold drags the capsule forward
    sim.advance(&ConstantForce(3.0), 10.0)
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(sim.state().x2 > 0.0);
    let w = sim.work();
    assert!(w.steps > 0 && w.rhs_evals > 0 && w.events > 0, "{w:?}");
}

#[test]
fn a_long_run_keeps_the_progression_to_rounding() {
    // 1e4 periods in one go against 100 chunks of 100: same progression, no drift
    let mut s = scene("fig15_forward.toml");
    s.horizon.periods = 10_000;
    s.horizon.transient = 100;
    let r = run(&s).unwrap_or_else(|e| panic!("{e}"));
    let mut short = s.clone();
    short.horizon.periods = 300;
    short.horizon.transient = 200;
    let r2 = run(&short).unwrap_or_else(|e| panic!("{e}"));
    assert!(r.final_state.x2 > 1e4, "capsule went {}", r.final_state.x2);
    assert!(
        (r.avg_progression - r2.avg_progression).abs() < 1e-10,
        "{} vs {}",
        r.avg_progression,
        r2.avg_progression
    );
}

#[test]
fn the_gaussian_stribeck_law_converges_holds_its_threshold_and_is_its_own_law() {
    // the fifth law (capsule_plant::friction::GaussianStribeck) on Fig 2c's scene at alpha 1.9
    let mut s = scene("fig02c_stribeck.toml");
    s.drive.alpha = 1.9;
    s.horizon.periods = 30;
    s.horizon.transient = 20;
    let stribeck = run(&s).unwrap_or_else(|e| panic!("{e}")).avg_progression;
    s.model.friction = Friction::by_name("gaussian-stribeck").unwrap_or_else(|| panic!("law"));
    let at = |method: Method, tol: f64, step: f64| {
        let mut t = s.clone();
        t.solver = SolverConfig { method, tol, step };
        run(&t).unwrap_or_else(|e| panic!("{e}")).avg_progression
    };
    let reference = at(Method::Adaptive, 1e-12, 0.0);
    let adaptive: Vec<f64> = [1e-6, 1e-8, 1e-10]
        .iter()
        .map(|&t| (at(Method::Adaptive, t, 0.0) - reference).abs())
        .collect();
    assert!(
        adaptive[0] > adaptive[1] && adaptive[1] > adaptive[2] && adaptive[2] < 1e-8,
        "adaptive: {adaptive:?}"
    );
    let fixed: Vec<f64> = [1e-3, 1e-4]
        .iter()
        .map(|&h| (at(Method::Fixed, 0.0, h) - reference).abs())
        .collect();
    assert!(fixed[0] > fixed[1] && fixed[0] < 1e-3, "fixed: {fixed:?}");
    // a law of its own: the flat Gaussian curve moves the capsule differently
    assert!(
        (reference - stribeck).abs() > 0.01,
        "{reference} {stribeck}"
    );
    // stuck: zero velocity, friction within the law's threshold of 2
    let snaps = snapshots(&s, 200);
    let stuck: Vec<_> = snaps.iter().filter(|x| x.stuck).collect();
    assert!(!stuck.is_empty() && stuck.len() < snaps.len());
    for x in stuck {
        assert_eq!(x.state.y2, 0.0);
        assert!(x.friction_force.abs() <= 2.0 + 1e-9, "{}", x.friction_force);
    }
    // the exact method needs a piecewise-linear law
    let mut exact = s.clone();
    exact.solver.method = Method::Exact;
    assert!(matches!(
        Simulator::new(exact.model, exact.initial, 0.0, exact.solver),
        Err(SimError::ExactNeedsLinearLaw("gaussian-stribeck"))
    ));
}

#[test]
fn an_advance_says_why_it_stopped_and_an_observer_can_stop_it_at_an_event() {
    use capsule_plant::Stop;
    use std::ops::ControlFlow;
    for method in [Method::Exact, Method::Adaptive, Method::Fixed] {
        let mut s = scene("fig02a_coulomb.toml");
        s.solver.method = method;
        let law = s.law();
        let new = || Simulator::new(s.model, s.initial, 0.0, s.solver);
        let mut whole = new().unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(whole.advance(&law, 60.0).ok(), Some(Stop::Horizon));
        // stop at the first impact: the state is the one just after it
        let mut sim = new().unwrap_or_else(|e| panic!("{e}"));
        let stop = sim
            .advance_until(&law, 60.0, &mut |t| {
                if t.event.kind == EventKind::ContactOn {
                    ControlFlow::Break(())
                } else {
                    ControlFlow::Continue(())
                }
            })
            .unwrap_or_else(|e| panic!("{e}"));
        let Stop::Requested(event) = stop else {
            panic!("{method:?}: no impact before 60: {stop:?}")
        };
        assert_eq!(event.kind, EventKind::ContactOn, "{method:?}");
        assert_eq!(sim.time(), event.tau, "{method:?}");
        assert!(sim.regime().contact && event.tau < 60.0, "{method:?}");
        // and it goes on from there to the same end as the run that was not stopped
        assert_eq!(sim.advance(&law, 60.0).ok(), Some(Stop::Horizon));
        let (a, b) = (sim.state(), whole.state());
        let gap = (a.x1 - b.x1).abs().max((a.y2 - b.y2).abs());
        assert!(gap < 1e-6, "{method:?}: {gap}");
    }
}
