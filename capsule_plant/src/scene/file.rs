//! The file as written, every table and key optional, and what it means: its values over the
//! defaults of `Scene::default` ([`RawScene::resolve`]) and a scene written out in the same
//! shape ([`RawScene::of`]). The table types are named `...Spec` and the file `RawScene`: the
//! TOML reader names them "a table" in its messages.

use super::error::{Fault, Invalid};
use super::types::{Control, Drive, Horizon, Scene};
use crate::device::{DeviceModel, Measured};
use crate::model::{Capsule, Friction, Model, State, FRICTION_CONSTANTS};
use crate::physical::PhysicalScale;
use crate::solver::{Method, SolverConfig};
use serde::{Deserialize, Serialize};

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
pub(super) struct FrictionSpec {
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
    pub(super) fn slot(&mut self, key: &str) -> Option<&mut Option<f64>> {
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
pub(super) enum Count {
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
    pub(super) fn check(self, key: &str, min: u32) -> Result<u32, Invalid> {
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
    pub(super) fn of(d: &DeviceModel) -> DeviceSpec {
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
    pub(super) fn over(self, d: DeviceModel) -> Result<DeviceModel, Invalid> {
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
pub(super) struct RawScene {
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

impl RawScene {
    /// The file's values over the defaults; `file` is the name of a scene without one.
    pub(super) fn resolve(mut self, file: &str) -> Result<Scene, Invalid> {
        let d = Scene::default();
        let c = &self.capsule;
        let capsule = Capsule {
            gamma: c.gamma.unwrap_or(d.model.capsule.gamma),
            beta: c.beta.unwrap_or(d.model.capsule.beta),
            delta: c.delta.unwrap_or(d.model.capsule.delta),
            xi: c.xi.unwrap_or(d.model.capsule.xi),
        };
        let model = Model {
            capsule,
            friction: friction_from(&mut self.friction)?,
        };
        let mut solver = SolverConfig::most_accurate_for(&model);
        if let Some(m) = &self.solver.method {
            solver.method = Method::by_name(m).ok_or_else(|| {
                Invalid::new("solver.method", Fault::UnknownMethod(m.to_string()))
            })?;
        }
        solver.tol = self.solver.tol.unwrap_or(solver.tol);
        solver.step = self.solver.step.unwrap_or(solver.step);
        let initial = match &self.initial.state {
            None => d.initial,
            Some(v) => State::from_array(
                <[f64; 4]>::try_from(v.as_slice())
                    .map_err(|_| Invalid::new("initial.state", Fault::StateLength(v.len())))?,
            ),
        };
        let periods = self
            .horizon
            .periods
            .map(|p| p.check("horizon.periods", 1))
            .transpose()?;
        let transient = self
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
        let p = &self.physical;
        let physical = PhysicalScale {
            m1_kg: p.m1_kg.unwrap_or(d.physical.m1_kg),
            k1_n_per_m: p.k1_n_per_m.unwrap_or(d.physical.k1_n_per_m),
            pf_n: p.pf_n.unwrap_or(d.physical.pf_n),
        };
        let device = self
            .device
            .take()
            .map(|spec| spec.over(DeviceModel::typical(&physical)))
            .transpose()?;
        Ok(Scene {
            name: self.name.unwrap_or_else(|| file.to_string()),
            description: self.description.unwrap_or_default(),
            model,
            drive: Drive {
                alpha: self.drive.alpha.unwrap_or(d.drive.alpha),
                omega: self.drive.omega.unwrap_or(d.drive.omega),
            },
            control: Control {
                kp: self.control.kp.unwrap_or(d.control.kp),
            },
            initial,
            horizon,
            solver,
            physical,
            device,
        })
    }

    /// The file of `scene`, every key written out (the nodes' `[node]` table is not the
    /// scene's).
    pub(super) fn of(scene: &Scene) -> RawScene {
        let m = &scene.model;
        let mut friction = FrictionSpec {
            law: Some(m.friction.name().to_string()),
            ..FrictionSpec::default()
        };
        for (c, v) in m.friction.constants() {
            if let Some(slot) = friction.slot(c.key) {
                *slot = Some(v);
            }
        }
        RawScene {
            name: Some(scene.name.clone()),
            description: Some(scene.description.clone()),
            capsule: CapsuleSpec {
                gamma: Some(m.capsule.gamma),
                beta: Some(m.capsule.beta),
                delta: Some(m.capsule.delta),
                xi: Some(m.capsule.xi),
            },
            friction,
            drive: DriveSpec {
                alpha: Some(scene.drive.alpha),
                omega: Some(scene.drive.omega),
            },
            control: ControlSpec {
                kp: Some(scene.control.kp),
            },
            initial: InitialSpec {
                state: Some(scene.initial.to_array().to_vec()),
            },
            horizon: HorizonSpec {
                periods: Some(Count::Whole(scene.horizon.periods.into())),
                transient: Some(Count::Whole(scene.horizon.transient.into())),
            },
            solver: SolverSpec {
                method: Some(scene.solver.method.name().to_string()),
                tol: Some(scene.solver.tol),
                step: Some(scene.solver.step),
            },
            physical: PhysicalSpec {
                m1_kg: Some(scene.physical.m1_kg),
                k1_n_per_m: Some(scene.physical.k1_n_per_m),
                pf_n: Some(scene.physical.pf_n),
            },
            node: toml::Table::new(),
            device: scene.device.as_ref().map(DeviceSpec::of),
        }
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
