//! The smallest hardware: a free mass (0.04 kg) pushed by the written force, its capsule pinned,
//! integrated exactly over each 0.01 s read; every write is kept. The plant node's tests put it
//! behind the node to check its bookkeeping and the lifecycle's gate; it is also the shortest
//! example of the trait.

use std::time::Instant;

use crate::{CapsuleHardware, HardwareError, Reading, Sample};

/// The mass of the mock \[kg\].
pub const MASS_KG: f64 = 0.04;
/// How far in time each read integrates \[s\].
pub const PERIOD_S: f64 = 0.01;

/// A free mass behind [`CapsuleHardware`].
#[derive(Debug, Default)]
pub struct FreeMass {
    configured: bool,
    x: f64,
    v: f64,
    force_n: f64,
    reads: u64,
    /// Every force written, in order \[N\].
    pub writes: Vec<f64>,
}

impl CapsuleHardware for FreeMass {
    fn label(&self) -> String {
        "mock".into()
    }
    fn configure(&mut self) -> Result<(), HardwareError> {
        self.configured = true;
        Ok(())
    }
    fn activate(&mut self) -> Result<(), HardwareError> {
        Ok(())
    }
    fn deactivate(&mut self) -> Result<(), HardwareError> {
        Ok(())
    }
    fn cleanup(&mut self) -> Result<(), HardwareError> {
        self.configured = false;
        Ok(())
    }
    fn read(&mut self, _deadline: Instant) -> Result<Reading, HardwareError> {
        if !self.configured {
            return Err(HardwareError::State("not configured".into()));
        }
        if self.reads > 0 {
            let (h, a) = (PERIOD_S, self.force_n / MASS_KG);
            self.x += self.v * h + 0.5 * a * h * h;
            self.v += a * h;
        }
        self.reads += 1;
        Ok(Reading::Sample(Sample {
            mass_position: self.x,
            mass_velocity: self.v,
            actuator_force: self.force_n,
            ..Sample::default()
        }))
    }
    fn write(&mut self, force_n: f64) -> Result<(), HardwareError> {
        self.force_n = force_n;
        self.writes.push(force_n);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_constant_force_moves_the_mass_as_the_law_of_motion_says() {
        let mut m = FreeMass::default();
        assert!(m.read(Instant::now()).is_err(), "a read before configure");
        assert!(m.configure().is_ok() && m.write(0.4).is_ok());
        let mut last = None;
        for _ in 0..3 {
            last = Some(m.read(Instant::now()));
        }
        // two periods at a = 10 m/s^2 from rest: x = a t^2 / 2, v = a t
        let Some(Ok(Reading::Sample(s))) = last else {
            panic!("{last:?}")
        };
        let t = 2.0 * PERIOD_S;
        assert!((s.mass_position - 5.0 * t * t).abs() < 1e-12, "{s:?}");
        assert!((s.mass_velocity - 10.0 * t).abs() < 1e-12, "{s:?}");
        assert_eq!(m.writes, [0.4]);
    }
}
