//! The sensor model: a true sample in, what the device reports out (unmeasured quantities NaN,
//! Gaussian noise, quantisation, sample jitter, latency).

use std::collections::VecDeque;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use super::DeviceModel;

/// A sample of the capsule, SI: what the simulator knows.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Truth {
    /// Time of the sample \[s\].
    pub t_s: f64,
    /// Mass position \[m\].
    pub x1_m: f64,
    /// Mass velocity \[m/s\].
    pub v1_m_per_s: f64,
    /// Shell position \[m\].
    pub x2_m: f64,
    /// Shell velocity \[m/s\].
    pub v2_m_per_s: f64,
    /// The mass touches the stop.
    pub contact: bool,
    /// Force the actuator applies \[N\].
    pub force_n: f64,
}

/// What the device reports: NaN (or `None`) for what it does not measure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// When the sample was taken \[s\] (nominal time plus jitter).
    pub t_s: f64,
    /// `x1 - x2` \[m\].
    pub displacement_m: f64,
    /// `x2` \[m\].
    pub capsule_m: f64,
    /// Mass velocity \[m/s\].
    pub mass_v: f64,
    /// Shell velocity \[m/s\].
    pub capsule_v: f64,
    /// Contact, when measured.
    pub contact: Option<bool>,
    /// Force the actuator applies \[N\] (the coil current times its constant: always measured).
    pub force_n: f64,
}

/// A sensor: noise from its own seeded generator, readings delayed by the latency.
pub struct Sensor {
    model: DeviceModel,
    rng: ChaCha8Rng,
    unit: Normal<f64>,
    line: VecDeque<Reading>,
}

impl Sensor {
    /// The sensor of `model`.
    pub fn new(model: &DeviceModel) -> Sensor {
        Sensor {
            model: *model,
            rng: ChaCha8Rng::seed_from_u64(u64::from(model.seed)),
            // mean 0, deviation 1: valid constants
            unit: Normal::new(0.0, 1.0).unwrap_or_else(|_| unreachable!()),
            line: VecDeque::new(),
        }
    }

    fn gauss(&mut self, sd: f64) -> f64 {
        if sd > 0.0 {
            sd * self.unit.sample(&mut self.rng)
        } else {
            0.0
        }
    }

    fn position(&mut self, x: f64) -> f64 {
        let noisy = x + self.gauss(self.model.noise_m);
        let q = self.model.quantum_m;
        if q > 0.0 {
            (noisy / q).round() * q
        } else {
            noisy
        }
    }

    /// Takes the sample `truth` and returns what leaves the device at `truth.t_s`: the newest
    /// reading at least `latency_s` old (the first reading until one is that old).
    ///
    /// Jitter: the sample is taken at `t + e`, `e` Gaussian, and the positions are moved by the
    /// velocities times `e` (first order: the jitter is far shorter than a drive period).
    pub fn observe(&mut self, truth: &Truth) -> Reading {
        let m = self.model.measured;
        let e = self.gauss(self.model.jitter_s);
        let (x1, x2) = (
            truth.x1_m + truth.v1_m_per_s * e,
            truth.x2_m + truth.v2_m_per_s * e,
        );
        let nan = f64::NAN;
        let displacement_m = if m.displacement {
            self.position(x1 - x2)
        } else {
            nan
        };
        let capsule_m = if m.capsule_position {
            self.position(x2)
        } else {
            nan
        };
        let mass_v = if m.mass_velocity {
            truth.v1_m_per_s + self.gauss(self.model.noise_m_per_s)
        } else {
            nan
        };
        let capsule_v = if m.capsule_velocity {
            truth.v2_m_per_s + self.gauss(self.model.noise_m_per_s)
        } else {
            nan
        };
        self.line.push_back(Reading {
            t_s: truth.t_s + e,
            displacement_m,
            capsule_m,
            mass_v,
            capsule_v,
            contact: m.contact.then_some(truth.contact),
            force_n: truth.force_n,
        });
        // keep only the newest reading old enough, and what is younger
        let due = truth.t_s - self.model.latency_s;
        while self.line.len() > 1 && self.line[1].t_s <= due + 1e-12 {
            self.line.pop_front();
        }
        self.line[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Measured;
    use crate::physical::PhysicalScale;

    fn truth(t: f64) -> Truth {
        Truth {
            t_s: t,
            x1_m: 2.0 * t,
            v1_m_per_s: 2.0,
            x2_m: t,
            v2_m_per_s: 1.0,
            contact: true,
            force_n: 0.5,
        }
    }

    #[test]
    fn an_ideal_sensor_reports_the_truth_at_once() {
        let mut s = Sensor::new(&DeviceModel::ideal(&PhysicalScale::default()));
        let r = s.observe(&truth(0.25));
        assert_eq!(
            (r.displacement_m, r.capsule_m, r.mass_v, r.capsule_v),
            (0.25, 0.25, 2.0, 1.0)
        );
        assert_eq!((r.contact, r.force_n, r.t_s), (Some(true), 0.5, 0.25));
    }

    #[test]
    fn unmeasured_quantities_are_nan_and_latency_delays_whole_samples() {
        let model = DeviceModel {
            jitter_s: 0.0,
            noise_m: 0.0,
            quantum_m: 0.0,
            latency_s: 0.002,
            ..DeviceModel::typical(&PhysicalScale::default())
        };
        assert_eq!(model.measured, Measured::POSITIONS);
        let mut s = Sensor::new(&model);
        let times: Vec<f64> = (0..10)
            .map(|k| s.observe(&truth(k as f64 * 1e-3)).t_s)
            .collect();
        let want = [0.0, 0.0, 0.0, 1e-3, 2e-3, 3e-3, 4e-3, 5e-3, 6e-3, 7e-3];
        for (got, want) in times.iter().zip(want) {
            assert!((got - want).abs() < 1e-12, "{times:?}");
        }
        let r = s.observe(&truth(0.01));
        assert!(r.mass_v.is_nan() && r.capsule_v.is_nan() && r.contact.is_none());
        assert!((r.displacement_m - 0.008).abs() < 1e-15);
    }

    #[test]
    fn noise_has_its_deviation_and_quantisation_its_grid() {
        let model = DeviceModel {
            noise_m: 1e-5,
            quantum_m: 1e-6,
            latency_s: 0.0,
            jitter_s: 0.0,
            ..DeviceModel::typical(&PhysicalScale::default())
        };
        let mut s = Sensor::new(&model);
        let n = 20_000;
        let errs: Vec<f64> = (0..n)
            .map(|k| {
                let t = Truth {
                    t_s: k as f64,
                    ..Truth::default()
                };
                let r = s.observe(&t);
                let on_grid = (r.capsule_m / 1e-6 - (r.capsule_m / 1e-6).round()).abs();
                assert!(on_grid < 1e-9, "{}", r.capsule_m);
                r.capsule_m
            })
            .collect();
        let mean = errs.iter().sum::<f64>() / n as f64;
        let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(mean.abs() < 3e-7, "{mean}");
        assert!((sd - 1e-5).abs() < 3e-7, "{sd}");
        // the same seed gives the same readings
        let mut again = Sensor::new(&model);
        let first = again.observe(&Truth::default()).capsule_m;
        assert_eq!(first, errs[0]);
    }
}
