//! What swapping the simulator for a prototype costs: the paper's control law closed around a
//! simulated prototype ([`Prototype`]: the exact capsule behind a sensor and an actuator model),
//! sampled at the node's rate, with the controller seeing only the measured positions and
//! converting with the nominal scale while the plant may differ from it.
//!
//! The controller is the controller node's law on positions alone: `f = alpha cos(omega tau) +
//! k_p |x2 - x1|` from the measured `x1 - x2` and `x2` at the sample's nominal time, held until the
//! next sample (a zero-order hold, as the plant node holds a command). Progression and
//! efficiency are measured on the true state, over whole drive periods after a transient.

use capsule_controller::{law::FeedbackLaw, mode::ProgressMeter};
use capsule_plant::device::prototype::Prototype;
use capsule_plant::device::DeviceModel;
use capsule_plant::scene::{PhysicalScale, Scene};
use capsule_plant::{SimError, Simulator};

/// How the real plant differs from the scene the controller was set up with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mismatch {
    /// The real friction threshold `P_f` over the scene's.
    pub friction: f64,
    /// The real primary stiffness `k1` over the scene's.
    pub stiffness: f64,
}

impl Mismatch {
    /// The plant is the scene.
    pub const NONE: Mismatch = Mismatch {
        friction: 1.0,
        stiffness: 1.0,
    };
}

/// One closed-loop run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopCase {
    /// The feedback gain `k_p` (FORWARD 0.2, BACKWARD -0.2, CHAOS_CONTROL 1.0 by default).
    pub kp: f64,
    /// The device between the law and the capsule.
    pub device: DeviceModel,
    /// The real plant against the scene.
    pub mismatch: Mismatch,
    /// Sample rate \[Hz\].
    pub rate_hz: f64,
    /// Drive periods not measured, then measured.
    pub transient: u32,
    /// Drive periods measured.
    pub periods: u32,
}

/// What a closed-loop run gave, non-dimensional in the scene's units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopResult {
    /// Mean capsule progression per drive period (true state).
    pub progression: f64,
    /// Progression over the actuator's work (true state and applied force).
    pub efficiency: f64,
}

/// Runs `case` on `scene`'s capsule; `Err` when the simulator fails.
pub fn closed_loop(scene: &Scene, case: &LoopCase) -> Result<LoopResult, SimError> {
    let nominal = scene.physical;
    let real = PhysicalScale {
        pf_n: nominal.pf_n * case.mismatch.friction,
        k1_n_per_m: nominal.k1_n_per_m * case.mismatch.stiffness,
        ..nominal
    };
    // the real plant in its own units: the scene's ratios (gamma, beta, xi) are kept; the gap
    // is physical, so its non-dimensional value scales with k1 / P_f
    let mut model = scene.model();
    model.capsule.delta *= case.mismatch.stiffness / case.mismatch.friction;
    let sim = Simulator::new(model, scene.initial_state(), 0.0, scene.solver())?;
    let mut proto = Prototype::new(sim, real, &case.device);
    let law = FeedbackLaw {
        alpha: scene.drive.alpha,
        omega: scene.drive.omega,
        kp: case.kp,
    };
    let dt = 1.0 / case.rate_hz;
    // measured on the true state, in the scene's (nominal) units
    let mut meter = ProgressMeter::new(law.period());
    let total = f64::from(case.transient + case.periods) * law.period() * nominal.time_s();
    let start = f64::from(case.transient) * law.period() * nominal.time_s();
    let steps = (total / dt).ceil() as u64;
    let mut x1x2 = (0.0, 0.0);
    for k in 0..steps {
        let t = k as f64 * dt;
        let r = proto.read();
        let (l, tau) = (nominal.length_m(), t / nominal.time_s());
        // positions alone; a sample the sensor lost keeps the last good positions
        if r.displacement_m.is_finite() && r.capsule_m.is_finite() {
            x1x2 = ((r.displacement_m + r.capsule_m) / l, r.capsule_m / l);
        }
        let force_n = law.force(tau, x1x2.0, x1x2.1) * nominal.force_n();
        if t >= start {
            let truth = proto.truth();
            meter.sample(
                tau,
                truth.x1_m / l,
                truth.x2_m / l,
                force_n / nominal.force_n(),
            );
        }
        proto.hold(force_n, dt)?;
    }
    Ok(LoopResult {
        progression: meter.progression_per_period(),
        efficiency: meter.efficiency(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn control_point() -> Scene {
        let mut s = Scene::default();
        s.model.capsule.gamma = 0.235;
        s.model.capsule.beta = 3.05;
        s.model.capsule.xi = 0.05;
        s.drive.alpha = 1.6;
        s.drive.omega = 1.1;
        s
    }

    fn case(kp: f64, device: DeviceModel) -> LoopCase {
        LoopCase {
            kp,
            device,
            mismatch: Mismatch::NONE,
            rate_hz: 1000.0,
            transient: 10,
            periods: 20,
        }
    }

    #[test]
    fn an_ideal_device_moves_forward_and_backward_as_the_node_does() -> Result<(), SimError> {
        let s = control_point();
        let ideal = DeviceModel::ideal(&s.physical);
        let fwd = closed_loop(&s, &case(0.2, ideal))?;
        let bwd = closed_loop(&s, &case(-0.2, ideal))?;
        // the ROS demo's lock-step figures at 1 kHz: +3.07 and -2.45 per period
        assert!((fwd.progression - 3.07).abs() < 0.3, "{fwd:?}");
        assert!((bwd.progression + 2.45).abs() < 0.4, "{bwd:?}");
        assert!(fwd.efficiency > 0.0, "{fwd:?}");
        Ok(())
    }

    #[test]
    fn the_typical_device_keeps_most_of_forward_and_latency_is_felt() -> Result<(), SimError> {
        let s = control_point();
        let ideal = DeviceModel::ideal(&s.physical);
        let typical = DeviceModel::typical(&s.physical);
        let a = closed_loop(&s, &case(0.2, ideal))?;
        let b = closed_loop(&s, &case(0.2, typical))?;
        assert!(b.progression > 0.5 * a.progression, "{a:?} {b:?}");
        assert_ne!(a, b);
        // a quarter of a drive period late (22 ms): the feedback acts out of phase
        let late = DeviceModel {
            latency_s: 0.022,
            ..ideal
        };
        let c = closed_loop(&s, &case(0.2, late))?;
        assert!((c.progression - a.progression).abs() > 0.05, "{a:?} {c:?}");
        Ok(())
    }
}
