//! The plant node's hardware interface, shaped like ros2_control's `SystemInterface`: a
//! lifecycle (configure, activate, deactivate, cleanup), a `read` that returns a sample, a
//! timeout or a fault, and a `write` of the actuator force in newtons. Everything is SI; the
//! simulator's adapter ([`crate::sim::SimulatedPlant`]) does the non-dimensional scaling, the
//! serial device ([`crate::serial_driver::DeviceDriver`]) speaks its protocol, and the tests
//! put a mock behind it ([`crate::mock::FreeMass`]). The command gate, watchdog, diagnostics,
//! recording and views stay above it, once, in the plant node.
//!
//! Two kinds of hardware: a simulator is paced by the node (each `read` integrates one sample
//! period with the force last written, at once), a device paces itself (it measures on its own
//! clock; `read` takes what it sent, and `write` sends at once). [`CapsuleHardware::ready`] says
//! which. Nothing here needs an async runtime: a device wakes its reader through [`Ready`], a
//! callback the node sets to whatever its runtime waits on.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Instant;

use crate::Sample;

/// Why the hardware cannot do what was asked.
#[derive(Debug, thiserror::Error)]
pub enum HardwareError {
    /// The device cannot be opened (its path named).
    #[error("cannot open {device}: {reason}")]
    Open {
        /// The device (`serial /dev/ttyUSB0 at 921600 baud`).
        device: String,
        /// Why.
        reason: String,
    },
    /// The simulation failed (a solver error).
    #[error("simulation failed: {0}")]
    Simulation(String),
    /// Asked in a lifecycle state where it makes no sense (e.g. `read` before `configure`).
    #[error("{0}")]
    State(String),
}

/// What a `read` brought.
#[derive(Debug, Clone, PartialEq)]
pub enum Reading {
    /// A new sample.
    Sample(Sample),
    /// Nothing new before the deadline.
    Timeout,
    /// A sample came but cannot be used (NaN in a measured quantity, beyond the travel): the
    /// hardware answers it with zero force; the node publishes its last sample again.
    Fault(String),
}

/// How a device is doing.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SourceHealth {
    /// What the hardware is (`serial /dev/ttyUSB0 at 921600 baud`).
    pub label: String,
    /// What is wrong now, if anything (the force is zero while it lasts).
    pub fault: Option<String>,
    /// Counters and limits, as `/diagnostics` key-value pairs.
    pub values: Vec<(&'static str, String)>,
}

/// Zeroes the actuator now, from any thread, without waiting on the sample loop: what the
/// emergency stop calls.
pub type Stopper = Arc<dyn Fn() + Send + Sync>;

/// A callback from any thread.
type Wake = Arc<dyn Fn() + Send + Sync>;

/// What a device that paces itself calls whenever `read` has something new: set once by the
/// node (to wake its loop, whichever runtime it runs on), called from the device's thread.
#[derive(Clone, Default)]
pub struct Ready {
    wake: Arc<Mutex<Option<Wake>>>,
}

impl Ready {
    /// From now on, [`Ready::notify`] calls `wake`.
    pub fn on_ready(&self, wake: impl Fn() + Send + Sync + 'static) {
        *self.wake.lock().unwrap_or_else(PoisonError::into_inner) = Some(Arc::new(wake));
    }

    /// Says that `read` has something (nothing happens before [`Ready::on_ready`]).
    pub fn notify(&self) {
        let wake = self
            .wake
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone();
        if let Some(wake) = wake {
            wake();
        }
    }
}

impl std::fmt::Debug for Ready {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Ready")
    }
}

/// A capsule the plant node can run: the simulator, a device on a serial line, a mock.
pub trait CapsuleHardware: Send {
    /// What it is, for the log and `/diagnostics`.
    fn label(&self) -> String;
    /// Unconfigured -> inactive: build the simulator, open the device. An error names the
    /// device and the reason.
    fn configure(&mut self) -> Result<(), HardwareError>;
    /// Inactive -> active: written forces apply from now on.
    fn activate(&mut self) -> Result<(), HardwareError>;
    /// Active -> inactive: zero force from the next sample on (written forces are replaced by
    /// zero).
    fn deactivate(&mut self) -> Result<(), HardwareError>;
    /// Inactive -> unconfigured: close the line, drop the simulator.
    fn cleanup(&mut self) -> Result<(), HardwareError>;
    /// The next sample, waiting until `deadline` at most (a simulator integrates one sample
    /// period with the force last written and returns at once). An error ends the run (the
    /// simulation failed, or nothing is configured); a device's faults are [`Reading::Fault`].
    fn read(&mut self, deadline: Instant) -> Result<Reading, HardwareError>;
    /// The actuator force \[N\] answering the newest sample: a device sends it at once, a
    /// simulator holds it over the next period.
    fn write(&mut self, force_n: f64) -> Result<(), HardwareError>;
    /// `Some` for hardware that paces itself (a device): notified whenever `read` has
    /// something, so the node never blocks waiting for it; `None` for a simulator.
    fn ready(&self) -> Option<Ready> {
        None
    }
    /// Zeroes the actuator whenever `engaged` is set (the emergency stop's flag), also for
    /// forces already on their way to `write`.
    fn zero_while(&mut self, engaged: Arc<AtomicBool>) {
        let _ = engaged;
    }
    /// Zeroes the actuator at once, from any thread (`None`: nothing to do out of the loop, as
    /// for a simulator, whose next step reads the flag).
    fn stopper(&self) -> Option<Stopper> {
        None
    }
    /// How a device is doing, for `/diagnostics` and the summary; `None` for a simulator.
    fn health(&self) -> Option<&SourceHealth> {
        None
    }
}

/// Hardware chosen at run time (`--source`).
impl<H: CapsuleHardware + ?Sized> CapsuleHardware for Box<H> {
    fn label(&self) -> String {
        (**self).label()
    }
    fn configure(&mut self) -> Result<(), HardwareError> {
        (**self).configure()
    }
    fn activate(&mut self) -> Result<(), HardwareError> {
        (**self).activate()
    }
    fn deactivate(&mut self) -> Result<(), HardwareError> {
        (**self).deactivate()
    }
    fn cleanup(&mut self) -> Result<(), HardwareError> {
        (**self).cleanup()
    }
    fn read(&mut self, deadline: Instant) -> Result<Reading, HardwareError> {
        (**self).read(deadline)
    }
    fn write(&mut self, force_n: f64) -> Result<(), HardwareError> {
        (**self).write(force_n)
    }
    fn ready(&self) -> Option<Ready> {
        (**self).ready()
    }
    fn zero_while(&mut self, engaged: Arc<AtomicBool>) {
        (**self).zero_while(engaged)
    }
    fn stopper(&self) -> Option<Stopper> {
        (**self).stopper()
    }
    fn health(&self) -> Option<&SourceHealth> {
        (**self).health()
    }
}
