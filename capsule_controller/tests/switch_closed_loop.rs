//! The attractor switch against the exact model under a zero-order hold at the plant node's
//! default 1 kHz: alpha 1.5, from (-1.5, 0, 0, 0) (period 3 at k_p = 0), a one-period pulse of
//! k_p = 0.3 moves the orbit to period 1, and it stays after the release.

use capsule_controller::switch::{
    AttractorSwitch, OrbitWatch, SwitchConfig, SwitchRequest, SwitchState,
};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{ConstantForce, Simulator};

/// The bundled live scene of the switch: alpha 1.5, k_p 0, from (-1.5, 0, 0, 0).
const SCENE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/switch_alpha15.toml");

struct Loop {
    sim: Simulator,
    law: AffineLaw,
    dt: f64,
    k: u64,
}

impl Loop {
    fn new() -> Loop {
        let text = std::fs::read_to_string(SCENE).expect("scene file");
        let scene = Scene::from_toml_str(&text, SCENE).expect("scene");
        let dt = 1e-3 * scene.physical.omega0();
        let sim = Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver())
            .expect("simulator");
        let law = AffineLaw::paper(scene.drive.alpha, scene.drive.omega, 0.0);
        Loop { sim, law, dt, k: 0 }
    }

    /// One sample: the state now, the gain `gain_of` answers, the force held for one step.
    fn step(&mut self, gain_of: &mut dyn FnMut(f64, [f64; 4]) -> f64) -> (f64, [f64; 4]) {
        let tau = self.k as f64 * self.dt;
        let s = self.sim.state().to_array();
        self.law.kp = gain_of(tau, s);
        let f = self.law.force_at(tau, s[0], s[2]);
        self.k += 1;
        self.sim
            .advance(&ConstantForce(f), self.k as f64 * self.dt)
            .expect("advance");
        (tau, s)
    }
}

#[test]
fn a_one_period_pulse_moves_period_3_to_period_1_in_closed_loop() {
    let settings = SwitchConfig::default();
    let mut lp = Loop::new();
    let period = lp.law.period();
    let mut watch = OrbitWatch::new(period, &settings);
    let steps_per_period = (period / lp.dt).ceil() as u64;
    // 60 periods at k_p = 0: period 3
    for _ in 0..60 * steps_per_period {
        let (tau, s) = lp.step(&mut |_, _| 0.0);
        watch.sample(tau, s);
    }
    assert_eq!(watch.period(), Some(3), "the start is not on period 3");
    let request = SwitchRequest {
        gain: 0.3,
        pulse_periods: 1,
        target_period: 1,
        max_tries: 4,
    };
    let mut sw = AttractorSwitch::new(request, settings, 0.0, period);
    let mut n = 0;
    let mut last = (sw.state(), sw.tries());
    while !sw.state().is_done() && n < 400 * steps_per_period {
        let (tau, s) = lp.step(&mut |tau, s| sw.sample(tau, s));
        if let Some(p) = watch.sample(tau, s) {
            if std::env::var_os("SWITCH_TRACE").is_some() {
                eprintln!(
                    "{:.1} {:?} {:?} {p:?}",
                    tau / period,
                    sw.state(),
                    sw.detected()
                );
            }
        }
        if (sw.state(), sw.tries()) != last {
            last = (sw.state(), sw.tries());
            eprintln!(
                "period {:.2}: {:?} try {} (orbit seen: {:?})",
                tau / period,
                last.0,
                last.1,
                sw.detected()
            );
        }
        n += 1;
    }
    eprintln!(
        "phase {:?} tries {} before {:?} detected {:?} pulse {:?}..{:?} after {} periods",
        sw.state(),
        sw.tries(),
        sw.before(),
        sw.detected(),
        sw.pulse_start(),
        sw.pulse_end(),
        n / steps_per_period
    );
    assert_eq!(sw.state(), SwitchState::Succeeded);
    assert_eq!(sw.before(), Some(3));
    assert!((1..=3).contains(&sw.tries()), "tries {}", sw.tries());
    // released: 40 more periods at k_p = 0 stay on period 1
    for _ in 0..40 * steps_per_period {
        let (tau, s) = lp.step(&mut |_, _| 0.0);
        watch.sample(tau, s);
    }
    assert_eq!(
        watch.period(),
        Some(1),
        "the orbit did not stay on period 1"
    );
}
