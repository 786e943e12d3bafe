//! The simulator of `capsule_plant` (whichever method the scene chooses: exact, adaptive or
//! fixed-step) as [`CapsuleHardware`]: this adapter does the non-dimensional scaling, so the
//! node above it sees SI as it does for a device.

use std::time::Instant;

use capsule_plant::scene::PhysicalScale;
use capsule_plant::{ConstantForce, Simulator};

use crate::{CapsuleHardware, HardwareError, Reading, Sample};

/// Builds the scene's simulator (at configure, again after a cleanup).
pub type Build = Box<dyn Fn() -> Result<Simulator, String> + Send>;

/// The simulator of `capsule_plant` behind the plant node: each `read` integrates one sample
/// period (`1 / rate`) with the force last written; the first `read` after `configure` is the
/// initial state.
pub struct SimulatedPlant {
    build: Build,
    scale: PhysicalScale,
    rate_hz: f64,
    sim: Option<Simulator>,
    /// Samples read since configure (the next read integrates to sample `read`).
    read: u64,
    force_n: f64,
    active: bool,
}

impl SimulatedPlant {
    /// The simulator `build` makes, sampled at `rate_hz`, scaled by `scale`.
    pub fn new(build: Build, scale: PhysicalScale, rate_hz: f64) -> SimulatedPlant {
        SimulatedPlant {
            build,
            scale,
            rate_hz,
            sim: None,
            read: 0,
            force_n: 0.0,
            active: false,
        }
    }

    /// Non-dimensional time of sample `k` (the node's stamp `k / rate`, rounded to the
    /// nanosecond, so that a run is the same whatever the pacing).
    fn tau_of(&self, k: u64) -> f64 {
        let nanos = (k as f64 * 1e9 / self.rate_hz).round() as i64;
        nanos as f64 * 1e-9 / self.scale.time_s()
    }
}

impl CapsuleHardware for SimulatedPlant {
    fn label(&self) -> String {
        "simulated".into()
    }

    fn configure(&mut self) -> Result<(), HardwareError> {
        self.sim = Some((self.build)().map_err(HardwareError::Simulation)?);
        self.read = 0;
        self.force_n = 0.0;
        Ok(())
    }

    fn activate(&mut self) -> Result<(), HardwareError> {
        self.active = true;
        Ok(())
    }

    fn deactivate(&mut self) -> Result<(), HardwareError> {
        self.active = false;
        self.force_n = 0.0;
        Ok(())
    }

    fn cleanup(&mut self) -> Result<(), HardwareError> {
        self.sim = None;
        Ok(())
    }

    fn read(&mut self, _deadline: Instant) -> Result<Reading, HardwareError> {
        let tau_end = self.tau_of(self.read);
        let force = self.force_n / self.scale.force_n();
        let Some(sim) = self.sim.as_mut() else {
            return Err(HardwareError::State(
                "the simulator is not configured".into(),
            ));
        };
        if self.read > 0 {
            sim.advance(&ConstantForce(force), tau_end).map_err(|e| {
                HardwareError::Simulation(format!("on the way to tau = {tau_end}: {e}"))
            })?;
        }
        self.read += 1;
        Ok(Reading::Sample(Sample::from_snapshot(
            &sim.snapshot(),
            &self.scale,
        )))
    }

    fn write(&mut self, force_n: f64) -> Result<(), HardwareError> {
        self.force_n = if self.active { force_n } else { 0.0 };
        Ok(())
    }
}
