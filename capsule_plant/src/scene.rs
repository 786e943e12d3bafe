//! Scene files: a capsule, its friction, the drive and control, the start, the horizon, the solver.
//!
//! A scene is TOML, and every table and key is optional: what a scene leaves out takes the value
//! of [`Scene::default`] (below; `capsule simulate --print-scene` prints a scene with everything
//! filled in). Unknown keys, values of the wrong type, missing or non-finite numbers and
//! out-of-range values are refused with the file, the key and the reason ([`SceneError`]).
//! Parsing takes text, not a path: reading the file is the caller's business.
//!
//! ```toml
//! name = "Section 5.1 control point"   # default: the file name
//! [capsule]
//! gamma = 0.235   # m2 / m1          > 0      default 5
//! beta = 3.05     # k2 / k1          >= 0     default 15 (0: no secondary spring)
//! delta = 0.02    # gap              >= 0     default 0.02
//! xi = 0.05       # damping ratio    >= 0     default 0.01
//! [friction]
//! law = "coulomb" # default; or "viscous" (mu_v), "stribeck" (v_s),
//!                 # "seven-parameter" (mu_v, v_s, tau_d, k_s); a constant the law uses and
//!                 # the scene leaves out takes the paper's value (model::FRICTION_CONSTANTS)
//! [drive]
//! alpha = 1.6     # amplitude        >= 0     default 0.8
//! omega = 1.1     # frequency        > 0      default 0.95
//! [control]
//! kp = 0.0        # position feedback gain    default 0
//! [initial]
//! state = [0.0, 0.0, 0.0, 0.0]   # x1, y1, x2, y2 (exactly four)   default all zero
//! [horizon]
//! periods = 300   # whole number >= 1         default 300
//! transient = 200 # whole number < periods    default 200, or 2/3 of `periods` when only
//!                 #                           `periods` is given
//! [solver]
//! method = "exact" # default: the most accurate for the law (exact, else adaptive)
//! tol = 1e-10      # adaptive, in (0, 1)
//! step = 1e-3      # fixed, > 0
//! [physical]       # the SI scale used by the ROS nodes (each > 0)
//! m1_kg = 0.05
//! k1_n_per_m = 200.0
//! pf_n = 0.1
//! [node]           # the plant node's: read and checked by capsule_args::node_table, which
//!                  # every binary's scene reader runs; passed over here
//! rate_hz = 1000.0         # [1e-3, 1e6]
//! command_timeout_s = 0.1  # [1e-6, 1e6]
//! [device]         # a prototype's sensor and actuator (device::DeviceModel), SI; optional:
//!                  # without it the simulator is ideal and the device emulator takes
//!                  # DeviceModel::typical (the values below for this scale)
//! measured = ["displacement", "capsule_position"]  # or mass_velocity, capsule_velocity, contact
//! noise_m = 5e-6           # position noise, standard deviation   >= 0
//! noise_m_per_s = 3.2e-4   # velocity noise, standard deviation   >= 0
//! quantum_m = 1e-6         # position resolution (0: exact)       >= 0
//! latency_s = 0.002        # age of a measurement when sent       >= 0
//! jitter_s = 1e-4          # sample instant, standard deviation   >= 0
//! seed = 1                 # of the noise, 0 to 4294967295
//! max_force_n = 1.0        # actuator limit                       > 0
//! dead_band_n = 0.0        # smaller commands give no force       >= 0
//! lag_s = 5e-4             # coil current time constant           >= 0
//! max_travel_m = 0.01      # |x1 - x2| the mechanics allow        > 0
//! command_timeout_s = 0.1  # the device zeroes its force after   > 0
//! ```

use crate::device::{DeviceModel, Measured};
use crate::model::{Capsule, Friction, Model, State, FRICTION_CONSTANTS};
use crate::solver::{Method, SolverConfig};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A scene refused: which file, which key, why.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}: {key}: {reason}")]
pub struct SceneError {
    /// The file (or other source name) the scene came from.
    pub file: String,
    /// The key, as a dotted path (`capsule.gamma`), or `(syntax)` when the text is not TOML.
    pub key: String,
    /// Why.
    pub reason: Fault,
}

/// A value of a scene refused by [`Scene::validate`]: which key, why.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{key}: {reason}")]
pub struct Invalid {
    /// The key, as a dotted path (`capsule.gamma`).
    pub key: String,
    /// Why.
    pub reason: Fault,
}

impl Invalid {
    fn new(key: impl Into<String>, reason: Fault) -> Self {
        Invalid {
            key: key.into(),
            reason,
        }
    }

    /// The same refusal, naming the file it came from.
    pub fn in_file(self, file: &str) -> SceneError {
        SceneError {
            file: file.to_string(),
            key: self.key,
            reason: self.reason,
        }
    }
}

/// Why a scene (or one of its values) is refused.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Fault {
    /// The file could not be read (the reader's message).
    #[error("cannot read: {0}")]
    Unreadable(String),
    /// The bytes are not UTF-8 text.
    #[error("not a text file (a scene is UTF-8 TOML)")]
    NotText,
    /// The text is not TOML (also: a key given twice).
    #[error("not valid TOML: {message}{}", at_line(*.line))]
    Syntax {
        /// The TOML parser's message.
        message: String,
        /// Where, when known.
        line: Option<usize>,
    },
    /// Valid TOML, but a key this format does not have or a value of the wrong type.
    #[error("{message}{}", at_line(*.line))]
    Shape {
        /// The reader's message (`unknown field`, `invalid type`).
        message: String,
        /// Where, when known.
        line: Option<usize>,
    },
    /// NaN or infinite.
    #[error("must be a finite number (got {})", num(*.0))]
    NotFinite(f64),
    /// Zero or negative where only positive values mean something.
    #[error("must be > 0 (got {})", num(*.0))]
    NotPositive(f64),
    /// Negative.
    #[error("must be >= 0 (got {})", num(*.0))]
    Negative(f64),
    /// A value outside a closed range.
    #[error("must be in [{min:e}, {max:e}] (got {})", num(*.got))]
    OutOfRange {
        /// The value given.
        got: f64,
        /// Smallest allowed.
        min: f64,
        /// Largest allowed.
        max: f64,
    },
    /// A tolerance outside (0, 1).
    #[error("must be in (0, 1) (got {})", num(*.0))]
    NotInOpenUnit(f64),
    /// A count that is fractional, too small or too large.
    #[error("must be a whole number from {min} to {max} (got {got})")]
    NotACount {
        /// The value given.
        got: String,
        /// Smallest allowed.
        min: u32,
        /// Largest allowed.
        max: u32,
    },
    /// The transient is not shorter than the run.
    #[error(
        "must be less than horizon.periods = {periods} (got {transient}): lower the transient, \
         raise the periods, or leave the transient out to scale it with the periods"
    )]
    TransientNotBelowPeriods {
        /// Leading periods not measured.
        transient: u32,
        /// Periods in all.
        periods: u32,
    },
    /// An initial state without exactly four numbers.
    #[error("must hold exactly 4 numbers x1, y1, x2, y2 (got {0})")]
    StateLength(usize),
    /// A friction law this model does not have.
    #[error("unknown law `{0}` ({laws})", laws = Friction::names())]
    UnknownLaw(String),
    /// An integration method this solver does not have.
    #[error("unknown method `{0}` ({methods})", methods = Method::names())]
    UnknownMethod(String),
    /// A measured quantity a device cannot have.
    #[error("unknown quantity `{0}` (displacement, capsule_position, mass_velocity, capsule_velocity or contact)")]
    UnknownQuantity(String),
    /// A friction constant the chosen law does not use.
    #[error("not used by law `{0}`: remove it")]
    NotUsedByLaw(&'static str),
    /// The exact method with a law that is not piecewise linear.
    #[error("exact needs a piecewise-linear friction law (coulomb, viscous), not {0}")]
    ExactNeedsPiecewiseLinear(&'static str),
}

/// A number as a user reads it: plain, or in exponent form when very small or large.
fn num(v: f64) -> String {
    if v != 0.0 && v.is_finite() && !(1e-4..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        v.to_string()
    }
}

fn at_line(line: Option<usize>) -> String {
    line.map(|l| format!(" (line {l})")).unwrap_or_default()
}

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

/// The physical scale that turns the non-dimensional model into SI units (paper sec. 2.1):
/// `Omega_0 = sqrt(k1 / m1)`, length `P_f / k1`, time `1 / Omega_0`, force `P_f`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PhysicalScale {
    /// Inner mass `m1` in kg.
    pub m1_kg: f64,
    /// Primary spring stiffness `k1` in N/m.
    pub k1_n_per_m: f64,
    /// Coulomb friction threshold `P_f` in N.
    pub pf_n: f64,
}

impl Default for PhysicalScale {
    fn default() -> Self {
        PhysicalScale {
            m1_kg: 0.05,
            k1_n_per_m: 200.0,
            pf_n: 0.1,
        }
    }
}

impl PhysicalScale {
    /// Natural frequency `Omega_0` in rad/s.
    pub fn omega0(&self) -> f64 {
        (self.k1_n_per_m / self.m1_kg).sqrt()
    }
    /// Metres per unit of non-dimensional length.
    pub fn length_m(&self) -> f64 {
        self.pf_n / self.k1_n_per_m
    }
    /// Seconds per unit of non-dimensional time.
    pub fn time_s(&self) -> f64 {
        1.0 / self.omega0()
    }
    /// Metres per second per unit of non-dimensional velocity.
    pub fn velocity_m_per_s(&self) -> f64 {
        self.length_m() * self.omega0()
    }
    /// Newtons per unit of non-dimensional force.
    pub fn force_n(&self) -> f64 {
        self.pf_n
    }
    /// Checks every value (each finite and > 0); the key is `physical.<name>`.
    pub fn validate(&self) -> Result<(), Invalid> {
        for (key, v) in [
            ("physical.m1_kg", self.m1_kg),
            ("physical.k1_n_per_m", self.k1_n_per_m),
            ("physical.pf_n", self.pf_n),
        ] {
            Rule::Positive.check(key, v)?;
        }
        Ok(())
    }
}

// The file as written: every table and key optional (defaults from `Scene::default`), the same
// shape serialized by `Scene::to_toml`.

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct CapsuleSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    gamma: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    beta: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    delta: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    xi: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    law: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    mu_v: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    v_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tau_d: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    k_s: Option<f64>,
}

impl FrictionSpec {
    /// The field of the [`FrictionConstant`] with key `key` (every key of
    /// [`FRICTION_CONSTANTS`] has one: a test checks it).
    fn slot(&mut self, key: &str) -> Option<&mut Option<f64>> {
        match key {
            "mu_v" => Some(&mut self.mu_v),
            "v_s" => Some(&mut self.v_s),
            "tau_d" => Some(&mut self.tau_d),
            "k_s" => Some(&mut self.k_s),
            _ => None,
        }
    }
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DriveSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    alpha: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    omega: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct ControlSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    kp: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct InitialSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    state: Option<Vec<f64>>,
}

/// A count as written: a whole number; a fraction or another type is refused with the key.
#[derive(Debug, Clone, Copy, Serialize)]
#[serde(untagged)]
enum Count {
    Whole(i64),
    Fraction(f64),
}

impl<'de> Deserialize<'de> for Count {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl serde::de::Visitor<'_> for V {
            type Value = Count;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a whole number")
            }
            fn visit_i64<E>(self, v: i64) -> Result<Count, E> {
                Ok(Count::Whole(v))
            }
            fn visit_u64<E>(self, v: u64) -> Result<Count, E> {
                Ok(i64::try_from(v).map_or(Count::Fraction(v as f64), Count::Whole))
            }
            fn visit_f64<E>(self, v: f64) -> Result<Count, E> {
                Ok(Count::Fraction(v))
            }
        }
        d.deserialize_any(V)
    }
}

impl Count {
    fn check(self, key: &str, min: u32) -> Result<u32, Invalid> {
        let bad = |got: String| {
            Invalid::new(
                key,
                Fault::NotACount {
                    got,
                    min,
                    max: u32::MAX,
                },
            )
        };
        match self {
            Count::Whole(n) => u32::try_from(n)
                .ok()
                .filter(|n| *n >= min)
                .ok_or_else(|| bad(n.to_string())),
            Count::Fraction(f) => Err(bad(f.to_string())),
        }
    }
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct HorizonSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    periods: Option<Count>,
    #[serde(skip_serializing_if = "Option::is_none")]
    transient: Option<Count>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SolverSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    method: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    tol: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    step: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct PhysicalSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    m1_kg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    k1_n_per_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pf_n: Option<f64>,
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceSpec {
    #[serde(skip_serializing_if = "Option::is_none")]
    measured: Option<Vec<String>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    noise_m_per_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    quantum_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    latency_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    jitter_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    seed: Option<Count>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max_force_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    dead_band_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    lag_s: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    max_travel_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    command_timeout_s: Option<f64>,
}

impl DeviceSpec {
    /// The table of `d`, every key written out.
    fn of(d: &DeviceModel) -> DeviceSpec {
        DeviceSpec {
            measured: Some(d.measured.names().iter().map(|n| n.to_string()).collect()),
            noise_m: Some(d.noise_m),
            noise_m_per_s: Some(d.noise_m_per_s),
            quantum_m: Some(d.quantum_m),
            latency_s: Some(d.latency_s),
            jitter_s: Some(d.jitter_s),
            seed: Some(Count::Whole(i64::from(d.seed))),
            max_force_n: Some(d.max_force_n),
            dead_band_n: Some(d.dead_band_n),
            lag_s: Some(d.lag_s),
            max_travel_m: Some(d.max_travel_m),
            command_timeout_s: Some(d.command_timeout_s),
        }
    }

    /// The table's values over `d`.
    fn over(self, d: DeviceModel) -> Result<DeviceModel, Invalid> {
        let measured = match &self.measured {
            None => d.measured,
            Some(names) => Measured::from_names(names)
                .map_err(|n| Invalid::new("device.measured", Fault::UnknownQuantity(n)))?,
        };
        Ok(DeviceModel {
            measured,
            noise_m: self.noise_m.unwrap_or(d.noise_m),
            noise_m_per_s: self.noise_m_per_s.unwrap_or(d.noise_m_per_s),
            quantum_m: self.quantum_m.unwrap_or(d.quantum_m),
            latency_s: self.latency_s.unwrap_or(d.latency_s),
            jitter_s: self.jitter_s.unwrap_or(d.jitter_s),
            seed: self
                .seed
                .map(|c| c.check("device.seed", 0))
                .transpose()?
                .unwrap_or(d.seed),
            max_force_n: self.max_force_n.unwrap_or(d.max_force_n),
            dead_band_n: self.dead_band_n.unwrap_or(d.dead_band_n),
            lag_s: self.lag_s.unwrap_or(d.lag_s),
            max_travel_m: self.max_travel_m.unwrap_or(d.max_travel_m),
            command_timeout_s: self.command_timeout_s.unwrap_or(d.command_timeout_s),
        })
    }
}

#[derive(Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    description: Option<String>,
    #[serde(default)]
    capsule: CapsuleSpec,
    #[serde(default)]
    friction: FrictionSpec,
    #[serde(default)]
    drive: DriveSpec,
    #[serde(default)]
    control: ControlSpec,
    #[serde(default)]
    initial: InitialSpec,
    #[serde(default)]
    horizon: HorizonSpec,
    #[serde(default)]
    solver: SolverSpec,
    #[serde(default)]
    physical: PhysicalSpec,
    /// The nodes' table: accepted here, read by `capsule_args::node_table`.
    #[serde(default, skip_serializing)]
    #[allow(dead_code)]
    node: toml::Table,
    #[serde(skip_serializing_if = "Option::is_none")]
    device: Option<DeviceSpec>,
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
    /// Parse and validate a scene from the bytes of a file; `file` names the source in errors.
    pub fn from_toml_bytes(bytes: &[u8], file: &str) -> Result<Self, SceneError> {
        let text = std::str::from_utf8(bytes).map_err(|_| SceneError {
            file: file.to_string(),
            key: "(file)".to_string(),
            reason: Fault::NotText,
        })?;
        Scene::from_toml_str(text, file)
    }

    /// Parse and validate a scene; `file` names the source in errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, SceneError> {
        let raw = parse(text).map_err(|e| e.in_file(file))?;
        let scene = resolve(raw, file).map_err(|e| e.in_file(file))?;
        scene.validate().map_err(|e| e.in_file(file))?;
        Ok(scene)
    }

    /// The scene as a complete scene file (every key of its tables written out; the nodes'
    /// `[node]` table is not the scene's); reading it back gives the same scene.
    pub fn to_toml(&self) -> String {
        let m = &self.model;
        let mut friction = FrictionSpec {
            law: Some(m.friction.name().to_string()),
            ..FrictionSpec::default()
        };
        for (c, v) in m.friction.constants() {
            if let Some(slot) = friction.slot(c.key) {
                *slot = Some(v);
            }
        }
        let file = RawScene {
            name: Some(self.name.clone()),
            description: Some(self.description.clone()),
            capsule: CapsuleSpec {
                gamma: Some(m.capsule.gamma),
                beta: Some(m.capsule.beta),
                delta: Some(m.capsule.delta),
                xi: Some(m.capsule.xi),
            },
            friction,
            drive: DriveSpec {
                alpha: Some(self.drive.alpha),
                omega: Some(self.drive.omega),
            },
            control: ControlSpec {
                kp: Some(self.control.kp),
            },
            initial: InitialSpec {
                state: Some(self.initial.to_array().to_vec()),
            },
            horizon: HorizonSpec {
                periods: Some(Count::Whole(self.horizon.periods.into())),
                transient: Some(Count::Whole(self.horizon.transient.into())),
            },
            solver: SolverSpec {
                method: Some(self.solver.method.name().to_string()),
                tol: Some(self.solver.tol),
                step: Some(self.solver.step),
            },
            physical: PhysicalSpec {
                m1_kg: Some(self.physical.m1_kg),
                k1_n_per_m: Some(self.physical.k1_n_per_m),
                pf_n: Some(self.physical.pf_n),
            },
            node: toml::Table::new(),
            device: self.device.as_ref().map(DeviceSpec::of),
        };
        // every field is a plain number, string or array: serializing cannot fail
        toml::to_string(&file).unwrap_or_default()
    }

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

    /// Check every value; the first bad one is refused with its key and the reason.
    pub fn validate(&self) -> Result<(), Invalid> {
        let c = &self.model.capsule;
        let mut checks: Vec<(&str, f64, Rule)> = vec![
            ("capsule.gamma", c.gamma, Rule::Positive),
            ("capsule.beta", c.beta, Rule::NonNegative),
            ("capsule.delta", c.delta, Rule::NonNegative),
            ("capsule.xi", c.xi, Rule::NonNegative),
            ("drive.alpha", self.drive.alpha, Rule::NonNegative),
            ("drive.omega", self.drive.omega, Rule::Positive),
            ("control.kp", self.control.kp, Rule::Finite),
            ("initial.state[0] (x1)", self.initial.x1, Rule::Finite),
            ("initial.state[1] (y1)", self.initial.y1, Rule::Finite),
            ("initial.state[2] (x2)", self.initial.x2, Rule::Finite),
            ("initial.state[3] (y2)", self.initial.y2, Rule::Finite),
        ];
        let friction = self.model.friction.constants();
        let keys: Vec<String> = friction
            .iter()
            .map(|(c, _)| format!("friction.{}", c.key))
            .collect();
        for ((c, v), key) in friction.iter().zip(&keys) {
            let rule = if c.positive {
                Rule::Positive
            } else {
                Rule::NonNegative
            };
            checks.push((key, *v, rule));
        }
        match self.solver.method {
            Method::Adaptive => checks.push(("solver.tol", self.solver.tol, Rule::Tolerance)),
            Method::Fixed => checks.push(("solver.step", self.solver.step, Rule::Positive)),
            Method::Exact => {}
        }
        for (key, v, rule) in checks {
            rule.check(key, v)?;
        }
        self.physical.validate()?;
        if let Some(d) = &self.device {
            for (key, v, positive) in d.numbers() {
                let rule = if positive {
                    Rule::Positive
                } else {
                    Rule::NonNegative
                };
                rule.check(&format!("device.{key}"), v)?;
            }
        }
        let h = self.horizon;
        if h.periods == 0 {
            return Err(Invalid::new(
                "horizon.periods",
                Fault::NotACount {
                    got: "0".into(),
                    min: 1,
                    max: u32::MAX,
                },
            ));
        }
        if h.transient >= h.periods {
            return Err(Invalid::new(
                "horizon.transient",
                Fault::TransientNotBelowPeriods {
                    transient: h.transient,
                    periods: h.periods,
                },
            ));
        }
        if self.solver.method == Method::Exact && !self.model.friction.is_piecewise_linear() {
            return Err(Invalid::new(
                "solver.method",
                Fault::ExactNeedsPiecewiseLinear(self.model.friction.name()),
            ));
        }
        Ok(())
    }
}

/// TOML text to the file's shape: syntax errors with their line, shape errors with their key.
fn parse(text: &str) -> Result<RawScene, Invalid> {
    read_toml(text)
}

/// Reads a scene text into `T` (the scene's tables, or another reader's, such as the nodes'
/// `[node]`): a syntax error first, then a key the format does not have or a value of the wrong
/// type, with the dotted path of the key and the line.
pub fn read_toml<T: serde::de::DeserializeOwned>(text: &str) -> Result<T, Invalid> {
    let line = |span: Option<std::ops::Range<usize>>| {
        span.map(|r| text[..r.start.min(text.len())].matches('\n').count() + 1)
    };
    // Syntax first (a key given twice is a syntax error of TOML), then the shape with the path
    // of the offending key.
    text.parse::<toml::Table>().map_err(|e| {
        Invalid::new(
            "(syntax)",
            Fault::Syntax {
                message: e.message().trim().to_string(),
                line: line(e.span()),
            },
        )
    })?;
    serde_path_to_error::deserialize(toml::Deserializer::new(text)).map_err(
        |e: serde_path_to_error::Error<toml::de::Error>| {
            let path = e.path().to_string();
            let inner = e.inner();
            // serde names the reader's own types: a user wrote a table
            let mut message = inner.message().trim().to_string();
            // (the readers' table types are all named `...Spec`, the file's `Raw...`)
            while let Some(at) = message.find("struct ") {
                let name_len = message[at + 7..]
                    .find(|c: char| !c.is_alphanumeric() && c != '_')
                    .unwrap_or(message.len() - at - 7);
                let name = &message[at + 7..at + 7 + name_len];
                if !(name.ends_with("Spec") || name.starts_with("Raw")) {
                    break;
                }
                message.replace_range(at..at + 7 + name_len, "a table");
            }
            Invalid::new(
                if path == "." {
                    "(top level)".to_string()
                } else {
                    path
                },
                Fault::Shape {
                    message,
                    line: line(inner.span()),
                },
            )
        },
    )
}

/// The file's values over the defaults.
fn resolve(mut raw: RawScene, file: &str) -> Result<Scene, Invalid> {
    let d = Scene::default();
    let c = &raw.capsule;
    let capsule = Capsule {
        gamma: c.gamma.unwrap_or(d.model.capsule.gamma),
        beta: c.beta.unwrap_or(d.model.capsule.beta),
        delta: c.delta.unwrap_or(d.model.capsule.delta),
        xi: c.xi.unwrap_or(d.model.capsule.xi),
    };
    let model = Model {
        capsule,
        friction: friction_from(&mut raw.friction)?,
    };
    let mut solver = SolverConfig::most_accurate_for(&model);
    if let Some(m) = &raw.solver.method {
        solver.method = Method::by_name(m)
            .ok_or_else(|| Invalid::new("solver.method", Fault::UnknownMethod(m.to_string())))?;
    }
    solver.tol = raw.solver.tol.unwrap_or(solver.tol);
    solver.step = raw.solver.step.unwrap_or(solver.step);
    let initial = match &raw.initial.state {
        None => d.initial,
        Some(v) => State::from_array(
            <[f64; 4]>::try_from(v.as_slice())
                .map_err(|_| Invalid::new("initial.state", Fault::StateLength(v.len())))?,
        ),
    };
    let periods = raw
        .horizon
        .periods
        .map(|p| p.check("horizon.periods", 1))
        .transpose()?;
    let transient = raw
        .horizon
        .transient
        .map(|t| t.check("horizon.transient", 0))
        .transpose()?;
    let horizon = match (periods, transient) {
        (Some(periods), Some(transient)) => Horizon { periods, transient },
        (Some(periods), None) => d.horizon.with_periods(periods),
        (None, Some(transient)) => Horizon {
            transient,
            ..d.horizon
        },
        (None, None) => d.horizon,
    };
    let p = &raw.physical;
    let physical = PhysicalScale {
        m1_kg: p.m1_kg.unwrap_or(d.physical.m1_kg),
        k1_n_per_m: p.k1_n_per_m.unwrap_or(d.physical.k1_n_per_m),
        pf_n: p.pf_n.unwrap_or(d.physical.pf_n),
    };
    let device = raw
        .device
        .take()
        .map(|spec| spec.over(DeviceModel::typical(&physical)))
        .transpose()?;
    Ok(Scene {
        name: raw.name.unwrap_or_else(|| file.to_string()),
        description: raw.description.unwrap_or_default(),
        model,
        drive: Drive {
            alpha: raw.drive.alpha.unwrap_or(d.drive.alpha),
            omega: raw.drive.omega.unwrap_or(d.drive.omega),
        },
        control: Control {
            kp: raw.control.kp.unwrap_or(d.control.kp),
        },
        initial,
        horizon,
        solver,
        physical,
        device,
    })
}

/// What a scene's number must be.
#[derive(Debug, Clone, Copy)]
pub enum Rule {
    /// Finite.
    Finite,
    /// Finite and > 0.
    Positive,
    /// Finite and >= 0.
    NonNegative,
    /// In (0, 1).
    Tolerance,
    /// In `[min, max]`.
    Within((f64, f64)),
}

impl Rule {
    /// `v`, the value of `key`, is refused with the key and why, or passes.
    pub fn check(self, key: &str, v: f64) -> Result<(), Invalid> {
        let fault = if !v.is_finite() {
            Fault::NotFinite(v)
        } else {
            match self {
                Rule::Finite => return Ok(()),
                Rule::Positive if v > 0.0 => return Ok(()),
                Rule::Positive => Fault::NotPositive(v),
                Rule::NonNegative if v >= 0.0 => return Ok(()),
                Rule::NonNegative => Fault::Negative(v),
                Rule::Tolerance if v > 0.0 && v < 1.0 => return Ok(()),
                Rule::Tolerance => Fault::NotInOpenUnit(v),
                Rule::Within((min, max)) if (min..=max).contains(&v) => return Ok(()),
                Rule::Within((min, max)) => Fault::OutOfRange { got: v, min, max },
            }
        };
        Err(Invalid::new(key, fault))
    }
}

/// The law and its constants; a constant the law uses and the file leaves out is the paper's.
fn friction_from(spec: &mut FrictionSpec) -> Result<Friction, Invalid> {
    let law = spec.law.as_deref().unwrap_or(Friction::COULOMB.name());
    let mut friction = Friction::by_name(law)
        .ok_or_else(|| Invalid::new("friction.law", Fault::UnknownLaw(law.to_string())))?;
    for c in &FRICTION_CONSTANTS {
        if let Some(v) = spec.slot(c.key).and_then(|v| *v) {
            if !friction.set_constant(c.key, v) {
                return Err(Invalid::new(
                    format!("friction.{}", c.key),
                    Fault::NotUsedByLaw(friction.name()),
                ));
            }
        }
    }
    Ok(friction)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
        [capsule]
        gamma = 0.235
        beta = 3.05
        delta = 0.02
        xi = 0.05
        [friction]
        law = "coulomb"
        [drive]
        alpha = 1.6
        omega = 1.1
    "#;

    #[test]
    fn a_minimal_scene_gets_the_defaults() {
        let s = Scene::from_toml_str(GOOD, "good.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            s.horizon,
            Horizon {
                periods: 300,
                transient: 200
            }
        );
        assert_eq!(s.solver.method, Method::Exact);
        assert_eq!(s.initial, State::default());
        assert_eq!(s.name, "good.toml");
    }

    #[test]
    fn an_empty_scene_is_the_default_scene() {
        let s = Scene::from_toml_str("", "empty.toml").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            s,
            Scene {
                name: "empty.toml".into(),
                ..Scene::default()
            }
        );
    }

    #[test]
    fn a_partial_table_takes_the_defaults_for_the_rest() {
        let s = Scene::from_toml_str("[capsule]\ngamma = 0.5\n[horizon]\nperiods = 30\n", "p")
            .unwrap_or_else(|e| panic!("{e}"));
        let d = Scene::default();
        assert_eq!(s.model.capsule.gamma, 0.5);
        assert_eq!(s.model.capsule.beta, d.model.capsule.beta);
        assert_eq!(
            s.horizon,
            Horizon {
                periods: 30,
                transient: 20
            }
        );
    }

    #[test]
    fn every_law_of_the_table_reads_back_with_its_constants_and_refuses_others() {
        for c in &FRICTION_CONSTANTS {
            assert!(FrictionSpec::default().slot(c.key).is_some(), "{}", c.key);
        }
        for law in Friction::LAWS {
            assert_eq!(Friction::by_name(law.name()), Some(law));
            let mut s = Scene::default();
            s.model.friction = law;
            s.solver = SolverConfig::most_accurate_for(&s.model);
            let back = Scene::from_toml_str(&s.to_toml(), "t.toml").map_err(|e| e.to_string());
            assert_eq!(back.map(|b| b.model.friction), Ok(law));
            let used: Vec<&str> = law.constants().iter().map(|(c, _)| c.key).collect();
            for c in &FRICTION_CONSTANTS {
                let text = format!("[friction]\nlaw = \"{}\"\n{} = 0.5\n", law.name(), c.key);
                let got = Scene::from_toml_str(&text, "t.toml").map(|s| s.model.friction);
                if used.contains(&c.key) {
                    let mut want = law;
                    assert!(want.set_constant(c.key, 0.5));
                    assert_eq!(got.map_err(|e| e.to_string()), Ok(want));
                } else {
                    let e = got.err().map(|e| e.to_string()).unwrap_or_default();
                    assert!(e.contains(&format!("friction.{}", c.key)), "{e}");
                }
            }
        }
        let e = Scene::from_toml_str("[friction]\nlaw = \"dry\"\n", "t.toml").err();
        let e = e.map(|e| e.to_string()).unwrap_or_default();
        assert!(
            e.contains("coulomb, viscous, stribeck, seven-parameter or gaussian-stribeck"),
            "{e}"
        );
    }

    #[test]
    fn printed_scenes_read_back_the_same() {
        let mut s = Scene::from_toml_str(GOOD, "good.toml").unwrap_or_else(|e| panic!("{e}"));
        s.model.friction = Friction::SevenParameter(crate::friction::SevenParameter {
            mu_v: 0.2,
            v_s: 0.3,
            tau_d: 0.04,
            k_s: 1e4,
        });
        s.solver.method = Method::Adaptive;
        s.initial = State::from_array([0.1, -0.2, 0.3, 1e-7]);
        let back = Scene::from_toml_str(&s.to_toml(), "x").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back, s);
    }

    #[test]
    fn errors_name_file_key_and_reason() {
        let bad = GOOD.replace("gamma = 0.235", "gamma = -1.0");
        let e = Scene::from_toml_str(&bad, "bad.toml")
            .err()
            .map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some("bad.toml: capsule.gamma: must be > 0 (got -1)")
        );
        let e = Scene::from_toml_str("[capsule]\ngamma = \"big\"\n", "t.toml").err();
        assert_eq!(e.map(|e| e.key), Some("capsule.gamma".to_string()));
        let e = Scene::from_toml_str("[drive]\nalpha = 1\nalpha = 2\n", "d.toml").err();
        assert_eq!(e.map(|e| e.key), Some("(syntax)".to_string()));
        let e = Scene::from_toml_bytes(b"\xff\xfe\x00", "g.bin").err();
        assert_eq!(e.map(|e| e.reason), Some(Fault::NotText));
    }

    #[test]
    fn conversions_follow_the_papers_nondimensionalisation() {
        // Omega0 = sqrt(k1/m1), t = tau / Omega0, X = x P_f / k1, V = y Omega0 P_f / k1
        let s = PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        };
        assert!((s.omega0() - 50.0).abs() < 1e-12);
        assert!((s.length_m() - 0.02).abs() < 1e-15);
        assert!((s.velocity_m_per_s() - 1.0).abs() < 1e-12);
        assert!((s.time_s() - 0.02).abs() < 1e-15);
    }

    #[test]
    fn physical_scale_round_trips() {
        let p = PhysicalScale::default();
        assert!((p.omega0() - 63.245553203367585).abs() < 1e-12);
        assert!((p.length_m() - 5e-4).abs() < 1e-18);
        assert!((p.velocity_m_per_s() - p.length_m() / p.time_s()).abs() < 1e-15);
        assert!(PhysicalScale { m1_kg: -1.0, ..p }.validate().is_err());
        assert!(PhysicalScale {
            pf_n: f64::NAN,
            ..p
        }
        .validate()
        .is_err());
    }

    #[test]
    fn a_device_table_fills_from_the_typical_device_and_reads_back() {
        let s = Scene::from_toml_str(
            "[device]\nmeasured = [\"displacement\"]\nlag_s = 0.002\nseed = 7\n",
            "d.toml",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let d = s.device.unwrap_or_else(|| panic!("no device"));
        let typical = DeviceModel::typical(&s.physical);
        assert_eq!(d.measured.names(), ["displacement"]);
        assert_eq!((d.lag_s, d.seed), (0.002, 7));
        assert_eq!(d.noise_m, typical.noise_m);
        let back = Scene::from_toml_str(&s.to_toml(), "x").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(back, s);
        assert_eq!(Scene::default().device, None);
        let e = |text: &str| {
            Scene::from_toml_str(text, "d.toml")
                .err()
                .map(|e| e.to_string())
                .unwrap_or_default()
        };
        assert_eq!(
            e("[device]\nlatency_s = -1.0\n"),
            "d.toml: device.latency_s: must be >= 0 (got -1)"
        );
        assert!(e("[device]\nmeasured = [\"speed\"]\n")
            .contains("device.measured: unknown quantity `speed`"));
        assert!(e("[device]\nseed = 1.5\n").contains("device.seed"));
        assert!(e("[device]\nmax_force_n = 0.0\n").contains("device.max_force_n: must be > 0"));
    }
}
