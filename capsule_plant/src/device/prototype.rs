//! A simulated prototype: the exact capsule with a device's actuator on its input and its
//! sensor on its output, stepped at the device's sample rate. What the device emulator serves
//! on a serial line and what an offline closed loop runs against.

use super::actuator::Actuator;
use super::sensor::{Reading, Sensor, Truth};
use super::DeviceModel;
use crate::physical::PhysicalScale;
use crate::solver::{SimError, Simulator};
use crate::ConstantForce;

/// Most constant-force pieces a hold is cut into to follow the coil's lag.
const MAX_PIECES: u32 = 16;

/// The capsule behind a device's actuator and sensor.
pub struct Prototype {
    sim: Simulator,
    scale: PhysicalScale,
    sensor: Sensor,
    actuator: Actuator,
    lag_s: f64,
    /// The mean force on the mass over the last hold \[N\].
    applied_n: f64,
}

impl Prototype {
    /// `sim` (at its start) seen through `device`, in SI through `scale`.
    pub fn new(sim: Simulator, scale: PhysicalScale, device: &DeviceModel) -> Prototype {
        Prototype {
            sim,
            scale,
            sensor: Sensor::new(device),
            actuator: Actuator::new(device),
            lag_s: device.lag_s,
            applied_n: 0.0,
        }
    }

    /// The true sample now, SI.
    pub fn truth(&self) -> Truth {
        let s = self.sim.snapshot();
        let (l, v) = (self.scale.length_m(), self.scale.velocity_m_per_s());
        Truth {
            t_s: s.tau * self.scale.time_s(),
            x1_m: s.state.x1 * l,
            v1_m_per_s: s.state.y1 * v,
            x2_m: s.state.x2 * l,
            v2_m_per_s: s.state.y2 * v,
            contact: s.contact,
            force_n: self.actuator.force_n(),
        }
    }

    /// What the sensor reports now (call once per sample: the sensor's delay line and noise
    /// advance with each call).
    pub fn read(&mut self) -> Reading {
        let truth = self.truth();
        self.sensor.observe(&truth)
    }

    /// Holds the command `command_n` \[N\] for `dt_s` \[s\]: the actuator's force, in pieces
    /// short against its lag (at most 16), each a constant-force step of the exact
    /// simulator at the piece's mean force.
    pub fn hold(&mut self, command_n: f64, dt_s: f64) -> Result<(), SimError> {
        let pieces = if self.lag_s > 0.0 {
            ((4.0 * dt_s / self.lag_s).ceil() as u32).clamp(1, MAX_PIECES)
        } else {
            1
        };
        let t0 = self.sim.snapshot().tau;
        let dtau = dt_s / self.scale.time_s();
        let mut sum_n = 0.0;
        for i in 1..=pieces {
            let mean_n = self.actuator.hold(command_n, dt_s / f64::from(pieces));
            sum_n += mean_n;
            let tau_end = t0 + dtau * f64::from(i) / f64::from(pieces);
            self.sim
                .advance(&ConstantForce(mean_n / self.scale.force_n()), tau_end)?;
        }
        self.applied_n = sum_n / f64::from(pieces);
        Ok(())
    }

    /// The mean force the actuator put on the mass over the last hold \[N\] (zero before
    /// the first): what acted over the sample period that ends now, whenever its command came.
    pub fn applied_n(&self) -> f64 {
        self.applied_n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    #[test]
    fn an_ideal_prototype_is_the_simulator() -> Result<(), SimError> {
        let scene = Scene::default();
        let sim = || Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver());
        let mut proto =
            Prototype::new(sim()?, scene.physical, &DeviceModel::ideal(&scene.physical));
        let mut plain = sim()?;
        let dt = 1e-3;
        for k in 1..=200 {
            let f = 0.3 * scene.physical.force_n() * (k as f64 * 0.05).sin();
            proto.hold(f, dt)?;
            let tau = k as f64 * dt / scene.physical.time_s();
            plain.advance(&ConstantForce(f / scene.physical.force_n()), tau)?;
        }
        let r = proto.read();
        let s = plain.snapshot();
        let l = scene.physical.length_m();
        assert!((r.capsule_m - s.state.x2 * l).abs() < 1e-15, "{r:?} {s:?}");
        assert!((r.displacement_m - (s.state.x1 - s.state.x2) * l).abs() < 1e-15);
        Ok(())
    }

    #[test]
    fn a_lagging_coil_moves_the_mass_less_in_the_first_millisecond() -> Result<(), SimError> {
        let scene = Scene::default();
        let sim = || Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver());
        let ideal = DeviceModel::ideal(&scene.physical);
        let lagging = DeviceModel {
            lag_s: 1e-3,
            ..ideal
        };
        let f = 5.0 * scene.physical.force_n();
        let mut a = Prototype::new(sim()?, scene.physical, &ideal);
        let mut b = Prototype::new(sim()?, scene.physical, &lagging);
        a.hold(f, 1e-3)?;
        b.hold(f, 1e-3)?;
        let (ta, tb) = (a.truth(), b.truth());
        assert!(
            tb.v1_m_per_s > 0.0 && tb.v1_m_per_s < 0.5 * ta.v1_m_per_s,
            "{ta:?} {tb:?}"
        );
        // after one time constant the coil carries 1 - 1/e of the command
        assert!((tb.force_n / f - (1.0 - (-1.0f64).exp())).abs() < 1e-12);
        // and its mean over the hold (what the device reports as applied) is 1/e of it
        assert!((b.applied_n() / f - (-1.0f64).exp()).abs() < 1e-12);
        assert_eq!(a.applied_n(), f);
        Ok(())
    }
}
