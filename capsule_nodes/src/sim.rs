//! [`PlantSim`] for the simulator of `capsule_plant` (whichever method the scene chooses: exact,
//! adaptive or fixed-step).

use anyhow::{Context as _, Result};
use capsule_plant::{ConstantForce, Simulator};

use crate::plant::{PlantSample, PlantSim};

/// The simulator of `capsule_plant` behind the plant node.
pub struct SimulatedPlant(pub Simulator);

impl PlantSim for SimulatedPlant {
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
        self.0
            .advance(&ConstantForce(force), tau_end)
            .map_err(|e| anyhow::anyhow!("{e}"))
            .with_context(|| format!("simulation failed on the way to tau = {tau_end}"))
    }

    fn sample(&self) -> PlantSample {
        let s = self.0.snapshot();
        PlantSample {
            tau: s.tau,
            x1: s.state.x1,
            y1: s.state.y1,
            x2: s.state.x2,
            y2: s.state.y2,
            stuck: s.stuck,
            contact: s.contact,
            friction_force: s.friction_force,
            contact_force: s.contact_force,
            actuator_force: s.actuator_force,
        }
    }
}
