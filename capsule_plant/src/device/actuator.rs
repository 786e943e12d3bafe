//! The actuator model: a commanded force in, the force on the mass out (dead band, saturation,
//! and the first-order lag of the coil current).

use super::DeviceModel;

/// A voice coil or solenoid: its force follows the limited command with time constant `lag_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Actuator {
    max_force_n: f64,
    dead_band_n: f64,
    lag_s: f64,
    force_n: f64,
}

impl Actuator {
    /// The actuator of `model`, at rest.
    pub fn new(model: &DeviceModel) -> Actuator {
        Actuator {
            max_force_n: model.max_force_n,
            dead_band_n: model.dead_band_n,
            lag_s: model.lag_s,
            force_n: 0.0,
        }
    }

    /// The force a command asks for once the coil has settled: zero inside the dead band (and
    /// for a non-finite command), saturated at the limit.
    pub fn target(&self, command_n: f64) -> f64 {
        if !command_n.is_finite() || command_n.abs() < self.dead_band_n {
            0.0
        } else {
            command_n.clamp(-self.max_force_n, self.max_force_n)
        }
    }

    /// The force now \[N\].
    pub fn force_n(&self) -> f64 {
        self.force_n
    }

    /// Holds `command_n` for `dt_s`: returns the mean force over the interval (what a
    /// constant-force step of the simulator applies) and moves the force to its value at the end
    /// (exact for the lag: `f(t) = f* + (f0 - f*) exp(-t / lag)`).
    pub fn hold(&mut self, command_n: f64, dt_s: f64) -> f64 {
        let target = self.target(command_n);
        if self.lag_s <= 0.0 || dt_s <= 0.0 {
            self.force_n = target;
            return target;
        }
        let r = dt_s / self.lag_s;
        let gap = self.force_n - target;
        let mean = target + gap * (-(-r).exp_m1()) / r;
        self.force_n = target + gap * (-r).exp();
        mean
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::physical::PhysicalScale;

    #[test]
    fn dead_band_and_saturation_shape_the_command() {
        let a = Actuator::new(&DeviceModel {
            dead_band_n: 0.01,
            max_force_n: 1.0,
            ..DeviceModel::ideal(&PhysicalScale::default())
        });
        assert_eq!(a.target(0.005), 0.0);
        assert_eq!(a.target(-0.5), -0.5);
        assert_eq!(a.target(7.0), 1.0);
        assert_eq!(a.target(-7.0), -1.0);
        assert_eq!(a.target(f64::NAN), 0.0);
    }

    #[test]
    fn the_lag_is_first_order_and_its_mean_is_exact() {
        let mut a = Actuator::new(&DeviceModel {
            lag_s: 0.001,
            ..DeviceModel::ideal(&PhysicalScale::default())
        });
        // one time constant: 1 - 1/e of the way; mean over it: 1 - (1 - 1/e) = 1/e
        let mean = a.hold(0.2, 0.001);
        let e = std::f64::consts::E;
        assert!((a.force_n() - 0.2 * (1.0 - 1.0 / e)).abs() < 1e-15);
        assert!((mean - 0.2 / e).abs() < 1e-15, "{mean}");
        // many small holds reach the same point as one long one
        let mut b = Actuator::new(&DeviceModel {
            lag_s: 0.001,
            ..DeviceModel::ideal(&PhysicalScale::default())
        });
        for _ in 0..100 {
            b.hold(0.2, 1e-5);
        }
        assert!((b.force_n() - a.force_n()).abs() < 1e-15);
        let mut ideal = Actuator::new(&DeviceModel::ideal(&PhysicalScale::default()));
        assert_eq!(ideal.hold(0.3, 1e-3), 0.3);
    }
}
