//! Scene files: a capsule, its friction, the drive and control, the start, the horizon, the solver.
//!
//! A scene is TOML. Required tables: `[capsule]`, `[friction]`, `[drive]`; the rest have the
//! defaults shown. Unknown keys, missing or non-finite values and out-of-range values are refused
//! with the file, the key and the reason. Parsing takes text, not a path: reading the file is the
//! caller's business.
//!
//! ```toml
//! name = "Section 5.1 control point"
//! [capsule]
//! gamma = 0.235   # m2 / m1          > 0
//! beta = 3.05     # k2 / k1          >= 0 (0: no secondary spring)
//! delta = 0.02    # gap              >= 0
//! xi = 0.05       # damping ratio    >= 0
//! [friction]
//! law = "coulomb" # or "viscous" (mu_v), "stribeck" (v_s), "seven-parameter" (mu_v, v_s, tau_d, k_s)
//! [drive]
//! alpha = 1.6     # amplitude        >= 0
//! omega = 1.1     # frequency        > 0
//! [control]
//! kp = 0.0        # position feedback gain
//! [initial]
//! state = [0.0, 0.0, 0.0, 0.0]   # x1, y1, x2, y2
//! [horizon]
//! periods = 300
//! transient = 200
//! [solver]
//! method = "exact" # default: the most accurate for the law (exact, else adaptive)
//! tol = 1e-10      # adaptive
//! step = 1e-3      # fixed
//! [physical]       # the SI scale used by the ROS nodes
//! m1_kg = 0.05
//! k1_n_per_m = 200.0
//! pf_n = 0.1
//! [node]
//! rate_hz = 1000.0
//! command_timeout_s = 0.1
//! ```

use crate::model::{Capsule, Friction, Model, State};
use crate::solver::{Method, SolverConfig};
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// A scene refused: which file, which key, why.
#[derive(Debug, Error, Clone, PartialEq)]
#[error("{file}: {key}: {reason}")]
pub struct SceneError {
    /// The file (or other source name) the scene came from.
    pub file: String,
    /// The key, as a dotted path (`capsule.gamma`), or `(syntax)` for a parse error.
    pub key: String,
    /// Why.
    pub reason: String,
}

/// The drive on the inner mass: `alpha cos(omega tau)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Control {
    /// Gain `k_p` of `u = k_p |x2 - x1|`; 0 means no feedback.
    #[serde(default)]
    pub kp: f64,
}

/// Simulated span: `periods` drive periods, of which the first `transient` are not measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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

/// The physical scale that turns the non-dimensional model into SI units (paper sec. 2.1):
/// `Omega_0 = sqrt(k1 / m1)`, length `P_f / k1`, time `1 / Omega_0`, force `P_f`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
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
}

/// Settings of the ROS plant node.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeSettings {
    /// State publication (and control) rate in Hz.
    pub rate_hz: f64,
    /// After this long without a command the plant applies zero force.
    pub command_timeout_s: f64,
}

impl Default for NodeSettings {
    fn default() -> Self {
        NodeSettings {
            rate_hz: 1000.0,
            command_timeout_s: 0.1,
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FrictionSpec {
    law: String,
    mu_v: Option<f64>,
    v_s: Option<f64>,
    tau_d: Option<f64>,
    k_s: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InitialSpec {
    state: [f64; 4],
}

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct SolverSpec {
    method: Option<String>,
    tol: Option<f64>,
    step: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFile {
    name: Option<String>,
    description: Option<String>,
    capsule: Capsule,
    friction: FrictionSpec,
    drive: Drive,
    #[serde(default)]
    control: Control,
    initial: Option<InitialSpec>,
    #[serde(default)]
    horizon: Horizon,
    #[serde(default)]
    solver: SolverSpec,
    #[serde(default)]
    physical: PhysicalScale,
    #[serde(default)]
    node: NodeSettings,
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
    /// ROS node settings.
    pub node: NodeSettings,
}

/// The paper's section-3 parameter set with Coulomb friction, all-zero start, 300 periods.
impl Default for Scene {
    fn default() -> Self {
        let model = Model {
            capsule: Capsule {
                gamma: 5.0,
                beta: 15.0,
                delta: 0.02,
                xi: 0.01,
            },
            friction: Friction::Coulomb,
        };
        Scene {
            name: "default".into(),
            description: String::new(),
            model,
            drive: Drive {
                alpha: 1.0,
                omega: 0.95,
            },
            control: Control::default(),
            initial: State::default(),
            horizon: Horizon::default(),
            solver: SolverConfig::most_accurate_for(&model),
            physical: PhysicalScale::default(),
            node: NodeSettings::default(),
        }
    }
}

/// The paper's section-3 friction constants: `mu_v = 0.1, v_s = 0.1, tau_d = 0.05, k_s = 4e4`.
pub const PAPER_MU_V: f64 = 0.1;
/// Stribeck velocity of the paper's section 3.
pub const PAPER_V_S: f64 = 0.1;
/// Frictional-memory delay of the paper's section 3.
pub const PAPER_TAU_D: f64 = 0.05;
/// Pre-sliding stiffness of the paper's section 3.
pub const PAPER_K_S: f64 = 4e4;

impl Scene {
    /// Parse and validate a scene; `file` names the source in errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, SceneError> {
        let raw: SceneFile = toml::from_str(text).map_err(|e| SceneError {
            file: file.to_string(),
            key: "(syntax)".to_string(),
            reason: e.message().to_string() + &line_of(text, e.span()),
        })?;
        let err = |key: &str, reason: String| SceneError {
            file: file.to_string(),
            key: key.to_string(),
            reason,
        };
        let friction = friction_from(&raw.friction).map_err(|(k, r)| err(&k, r))?;
        let model = Model {
            capsule: raw.capsule,
            friction,
        };
        let mut solver = SolverConfig::most_accurate_for(&model);
        if let Some(m) = &raw.solver.method {
            solver.method = match m.as_str() {
                "exact" => Method::Exact,
                "adaptive" => Method::Adaptive,
                "fixed" => Method::Fixed,
                other => {
                    return Err(err(
                        "solver.method",
                        format!("unknown method `{other}` (exact, adaptive or fixed)"),
                    ))
                }
            };
        }
        if let Some(t) = raw.solver.tol {
            solver.tol = t;
        }
        if let Some(s) = raw.solver.step {
            solver.step = s;
        }
        let scene = Scene {
            name: raw.name.unwrap_or_else(|| file.to_string()),
            description: raw.description.unwrap_or_default(),
            model,
            drive: raw.drive,
            control: raw.control,
            initial: raw
                .initial
                .map_or(State::default(), |i| State::from_array(i.state)),
            horizon: raw.horizon,
            solver,
            physical: raw.physical,
            node: raw.node,
        };
        scene.validate().map_err(|(k, r)| err(&k, r))?;
        Ok(scene)
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

    /// Check every value; `Err((key, reason))` for the first bad one.
    pub fn validate(&self) -> Result<(), (String, String)> {
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
            ("physical.m1_kg", self.physical.m1_kg, Rule::Positive),
            (
                "physical.k1_n_per_m",
                self.physical.k1_n_per_m,
                Rule::Positive,
            ),
            ("physical.pf_n", self.physical.pf_n, Rule::Positive),
            ("node.rate_hz", self.node.rate_hz, Rule::Positive),
            (
                "node.command_timeout_s",
                self.node.command_timeout_s,
                Rule::Positive,
            ),
        ];
        match self.model.friction {
            Friction::Coulomb => {}
            Friction::Viscous { mu_v } => checks.push(("friction.mu_v", mu_v, Rule::NonNegative)),
            Friction::Stribeck { v_s } => checks.push(("friction.v_s", v_s, Rule::Positive)),
            Friction::SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            } => {
                checks.push(("friction.mu_v", mu_v, Rule::NonNegative));
                checks.push(("friction.v_s", v_s, Rule::Positive));
                checks.push(("friction.tau_d", tau_d, Rule::NonNegative));
                checks.push(("friction.k_s", k_s, Rule::Positive));
            }
        }
        match self.solver.method {
            Method::Adaptive => checks.push(("solver.tol", self.solver.tol, Rule::Tolerance)),
            Method::Fixed => checks.push(("solver.step", self.solver.step, Rule::Positive)),
            Method::Exact => {}
        }
        for (key, v, rule) in checks {
            rule.check(v)
                .map_err(|r| (key.to_string(), format!("{r} (got {v})")))?;
        }
        if self.horizon.periods == 0 {
            return Err(("horizon.periods".into(), "must be at least 1".into()));
        }
        if self.horizon.transient >= self.horizon.periods {
            return Err((
                "horizon.transient".into(),
                format!(
                    "must be less than horizon.periods = {} (got {})",
                    self.horizon.periods, self.horizon.transient
                ),
            ));
        }
        if self.solver.method == Method::Exact && !self.model.friction.is_piecewise_linear() {
            return Err((
                "solver.method".into(),
                format!(
                    "exact needs a piecewise-linear friction law (coulomb, viscous), not {}",
                    self.model.friction.name()
                ),
            ));
        }
        Ok(())
    }
}

#[derive(Debug, Clone, Copy)]
enum Rule {
    Finite,
    Positive,
    NonNegative,
    Tolerance,
}

impl Rule {
    fn check(self, v: f64) -> Result<(), &'static str> {
        if !v.is_finite() {
            return Err("must be a finite number");
        }
        match self {
            Rule::Finite => Ok(()),
            Rule::Positive if v > 0.0 => Ok(()),
            Rule::Positive => Err("must be > 0"),
            Rule::NonNegative if v >= 0.0 => Ok(()),
            Rule::NonNegative => Err("must be >= 0"),
            Rule::Tolerance if v > 0.0 && v < 1.0 => Ok(()),
            Rule::Tolerance => Err("must be in (0, 1)"),
        }
    }
}

fn friction_from(spec: &FrictionSpec) -> Result<Friction, (String, String)> {
    let need = |name: &str, v: Option<f64>| {
        v.ok_or_else(|| {
            (
                format!("friction.{name}"),
                format!("required by law `{}`", spec.law),
            )
        })
    };
    let refuse = |name: &str, v: Option<f64>| match v {
        Some(_) => Err((
            format!("friction.{name}"),
            format!("not used by law `{}`: remove it", spec.law),
        )),
        None => Ok(()),
    };
    Ok(match spec.law.as_str() {
        "coulomb" => {
            refuse("mu_v", spec.mu_v)?;
            refuse("v_s", spec.v_s)?;
            refuse("tau_d", spec.tau_d)?;
            refuse("k_s", spec.k_s)?;
            Friction::Coulomb
        }
        "viscous" => {
            refuse("v_s", spec.v_s)?;
            refuse("tau_d", spec.tau_d)?;
            refuse("k_s", spec.k_s)?;
            Friction::Viscous {
                mu_v: need("mu_v", spec.mu_v)?,
            }
        }
        "stribeck" => {
            refuse("mu_v", spec.mu_v)?;
            refuse("tau_d", spec.tau_d)?;
            refuse("k_s", spec.k_s)?;
            Friction::Stribeck {
                v_s: need("v_s", spec.v_s)?,
            }
        }
        "seven-parameter" => Friction::SevenParameter {
            mu_v: need("mu_v", spec.mu_v)?,
            v_s: need("v_s", spec.v_s)?,
            tau_d: need("tau_d", spec.tau_d)?,
            k_s: need("k_s", spec.k_s)?,
        },
        other => {
            return Err((
                "friction.law".into(),
                format!("unknown law `{other}` (coulomb, viscous, stribeck or seven-parameter)"),
            ))
        }
    })
}

fn line_of(text: &str, span: Option<std::ops::Range<usize>>) -> String {
    match span {
        Some(r) => {
            let line = text[..r.start.min(text.len())].matches('\n').count() + 1;
            format!(" (line {line})")
        }
        None => String::new(),
    }
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
    fn errors_name_file_key_and_reason() {
        let bad = GOOD.replace("gamma = 0.235", "gamma = -1.0");
        let e = Scene::from_toml_str(&bad, "bad.toml")
            .err()
            .map(|e| e.to_string());
        assert_eq!(
            e.as_deref(),
            Some("bad.toml: capsule.gamma: must be > 0 (got -1)")
        );
    }

    #[test]
    fn physical_scale_round_trips() {
        let p = PhysicalScale::default();
        assert!((p.omega0() - 63.245553203367585).abs() < 1e-12);
        assert!((p.length_m() - 5e-4).abs() < 1e-18);
        assert!((p.velocity_m_per_s() - p.length_m() / p.time_s()).abs() < 1e-15);
    }
}
