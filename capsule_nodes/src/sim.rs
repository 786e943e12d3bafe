//! [`PlantSim`] for the simulator of `capsule_plant` (whichever method the scene chooses: exact,
//! adaptive or fixed-step).

use capsule_plant::{ConstantForce, Simulator, Snapshot};
use capsule_ros_base::error::{Context as _, Result};

use crate::plant::PlantSim;

/// The simulator of `capsule_plant` behind the plant node.
pub struct SimulatedPlant(pub Simulator);

impl PlantSim for SimulatedPlant {
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
        self.0
            .advance(&ConstantForce(force), tau_end)
            .map(|_| ())
            .with_context(|| format!("simulation failed on the way to tau = {tau_end}"))
    }

    fn sample(&self) -> Snapshot {
        self.0.snapshot()
    }
}
