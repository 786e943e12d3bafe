//! The validated scene and its parts: the drive, the control gain, the horizon.

use crate::device::DeviceModel;
use crate::model::{Capsule, Friction, Model, State};
use crate::physical::PhysicalScale;
use crate::solver::SolverConfig;
use serde::Serialize;

/// The drive on the inner mass: `alpha cos(omega tau)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Drive {
    /// Amplitude `alpha = P_d / P_f`.
    pub alpha: f64,
    /// Frequency `omega = Omega / Omega_0`.
    pub omega: f64,
}

impl Drive {
    /// The drive period `2 pi / omega`.
    pub fn period(&self) -> f64 {
        std::f64::consts::TAU / self.omega
    }
}

/// Position feedback settings.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Control {
    /// Gain `k_p` of `u = k_p |x2 - x1|`; 0 means no feedback.
    pub kp: f64,
}

/// Simulated span: `periods` drive periods, of which the first `transient` are not measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Horizon {
    /// Drive periods simulated in all.
    pub periods: u32,
    /// Leading periods left out of the measurements.
    pub transient: u32,
}

impl Default for Horizon {
    fn default() -> Self {
        Horizon {
            periods: 300,
            transient: 200,
        }
    }
}

impl Horizon {
    /// The one rule for a number of periods given without a transient (in a scene file or on
    /// the command line): the transient keeps this horizon's share of the periods, rounded
    /// down (2/3 for the default 300 with 200).
    pub fn with_periods(self, periods: u32) -> Horizon {
        let transient = u64::from(periods) * u64::from(self.transient) / u64::from(self.periods);
        Horizon {
            periods,
            transient: u32::try_from(transient).unwrap_or(u32::MAX),
        }
    }
}

/// A validated scene.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Scene {
    /// Display name.
    pub name: String,
    /// Free text.
    pub description: String,
    /// Capsule and friction.
    pub model: Model,
    /// The drive.
    pub drive: Drive,
    /// The feedback gain.
    pub control: Control,
    /// Initial state.
    pub initial: State,
    /// Periods simulated and measured.
    pub horizon: Horizon,
    /// Integration method and tolerance.
    pub solver: SolverConfig,
    /// SI scale.
    pub physical: PhysicalScale,
    /// The prototype's sensor and actuator (`[device]`): `None` when the scene has no such
    /// table (the simulator is ideal; the device emulator takes [`DeviceModel::typical`]).
    pub device: Option<DeviceModel>,
}

/// The paper's section-3 parameter set (gamma 5, beta 15, delta 0.02, xi 0.01, alpha 0.8,
/// omega 0.95) with Coulomb friction, all-zero start, 300 periods of which 200 are transient,
/// the most accurate method for the law: what every scene leaves out.
impl Default for Scene {
    fn default() -> Self {
        let model = Model {
            capsule: Capsule::SECTION3,
            friction: Friction::COULOMB,
        };
        Scene {
            name: "default".into(),
            description: String::new(),
            model,
            drive: Drive {
                alpha: 0.8,
                omega: 0.95,
            },
            control: Control::default(),
            initial: State::default(),
            horizon: Horizon::default(),
            solver: SolverConfig::most_accurate_for(&model),
            physical: PhysicalScale::default(),
            device: None,
        }
    }
}

impl Scene {
    /// The capsule and friction law.
    pub fn model(&self) -> Model {
        self.model
    }

    /// The initial state.
    pub fn initial_state(&self) -> State {
        self.initial
    }

    /// The solver settings.
    pub fn solver(&self) -> SolverConfig {
        self.solver
    }

    /// The scene's device, or a typical one at its scale when it has no `[device]` table.
    pub fn device_or_typical(&self) -> DeviceModel {
        self.device
            .unwrap_or_else(|| DeviceModel::typical(&self.physical))
    }

    /// The scene's actuator law: its drive and gain `k_p` (paper eq. 2-3).
    pub fn law(&self) -> crate::law::AffineLaw {
        crate::law::AffineLaw::paper(self.drive.alpha, self.drive.omega, self.control.kp)
    }
}
