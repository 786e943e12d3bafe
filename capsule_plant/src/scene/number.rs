//! A scene's numbers by key, written as in the file (`capsule.gamma`, `friction.mu_v`,
//! `physical.pf_n`): read ([`Scene::number`]) and set ([`Scene::set_number`]), for tools that
//! name a key on the command line (`capsule identify --free`). One match of key to field, here.

use super::types::Scene;
use thiserror::Error;

/// Why a key names no number of a scene.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
pub enum KeyError {
    /// No scene has this key.
    #[error("`{0}` is not a scene key (numbers: capsule.gamma|beta|delta|xi, drive.alpha|omega, control.kp, friction.<constant>, physical.m1_kg|k1_n_per_m|pf_n, solver.tol|step, device.<number>)")]
    Unknown(String),
    /// The key holds something other than a real number (a name, a law, a count, a list).
    #[error("`{0}` is not a number in a scene (it holds a name, a count or a list)")]
    NotANumber(String),
    /// A friction constant the scene's law does not use, or a device key without a `[device]`.
    #[error("`{key}` is not used by this scene ({why})")]
    NotUsed {
        /// The key.
        key: String,
        /// Why.
        why: String,
    },
}

/// Keys that exist but hold no real number.
const NOT_NUMBERS: [&str; 9] = [
    "name",
    "description",
    "friction.law",
    "initial.state",
    "horizon.periods",
    "horizon.transient",
    "solver.method",
    "device.measured",
    "device.seed",
];

impl Scene {
    /// The number at `key`, as written in a scene file.
    pub fn number(&self, key: &str) -> Result<f64, KeyError> {
        let mut copy = self.clone();
        copy.slot(key).map(|v| *v)
    }

    /// Sets the number at `key` (not validated: call [`Scene::validate`] after).
    pub fn set_number(&mut self, key: &str, value: f64) -> Result<(), KeyError> {
        *self.slot(key)? = value;
        Ok(())
    }

    fn slot(&mut self, key: &str) -> Result<&mut f64, KeyError> {
        if NOT_NUMBERS.contains(&key) {
            return Err(KeyError::NotANumber(key.into()));
        }
        let unknown = || KeyError::Unknown(key.into());
        let (table, name) = key.split_once('.').ok_or_else(unknown)?;
        let c = &mut self.model.capsule;
        let p = &mut self.physical;
        Ok(match (table, name) {
            ("capsule", "gamma") => &mut c.gamma,
            ("capsule", "beta") => &mut c.beta,
            ("capsule", "delta") => &mut c.delta,
            ("capsule", "xi") => &mut c.xi,
            ("drive", "alpha") => &mut self.drive.alpha,
            ("drive", "omega") => &mut self.drive.omega,
            ("control", "kp") => &mut self.control.kp,
            ("physical", "m1_kg") => &mut p.m1_kg,
            ("physical", "k1_n_per_m") => &mut p.k1_n_per_m,
            ("physical", "pf_n") => &mut p.pf_n,
            ("solver", "tol") => &mut self.solver.tol,
            ("solver", "step") => &mut self.solver.step,
            ("friction", constant) => {
                if !crate::model::FRICTION_CONSTANTS
                    .iter()
                    .any(|c| c.key == constant)
                {
                    return Err(unknown());
                }
                let law = self.model.friction.name();
                return self
                    .model
                    .friction
                    .constants_mut()
                    .into_iter()
                    .find(|(c, _)| c.key == constant)
                    .map(|(_, v)| v)
                    .ok_or_else(|| KeyError::NotUsed {
                        key: key.into(),
                        why: format!("the {law} law has no such constant"),
                    });
            }
            ("device", number) => {
                let Some(d) = self.device.as_mut() else {
                    return Err(KeyError::NotUsed {
                        key: key.into(),
                        why: "the scene has no [device] table".into(),
                    });
                };
                match number {
                    "noise_m" => &mut d.noise_m,
                    "noise_m_per_s" => &mut d.noise_m_per_s,
                    "quantum_m" => &mut d.quantum_m,
                    "latency_s" => &mut d.latency_s,
                    "jitter_s" => &mut d.jitter_s,
                    "max_force_n" => &mut d.max_force_n,
                    "dead_band_n" => &mut d.dead_band_n,
                    "lag_s" => &mut d.lag_s,
                    "max_travel_m" => &mut d.max_travel_m,
                    "command_timeout_s" => &mut d.command_timeout_s,
                    _ => return Err(unknown()),
                }
            }
            _ => return Err(unknown()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::DeviceModel;

    #[test]
    fn every_number_of_a_written_scene_is_read_and_set_by_its_key() {
        let mut s = Scene {
            device: Some(DeviceModel::typical(&Default::default())),
            ..Scene::default()
        };
        assert_eq!(s.number("capsule.gamma"), Ok(5.0));
        s.set_number("capsule.xi", 0.07).ok();
        assert_eq!(s.model.capsule.xi, 0.07);
        s.set_number("physical.pf_n", 0.2).ok();
        assert_eq!(s.physical.pf_n, 0.2);
        // every key with a rule (validate reads them by key) names a number
        for (k, _) in crate::scene::KEY_RULES {
            assert!(s.number(k).is_ok(), "{k}");
        }
        // every numeric key the device table writes is one here
        for (k, v, _) in DeviceModel::typical(&Default::default()).numbers() {
            assert_eq!(s.number(&format!("device.{k}")), Ok(v), "{k}");
        }
        // the file written from the scene holds every key read here at the same value
        let text = s.to_toml();
        let doc: toml::Table = text.parse().unwrap_or_default();
        for (table, v) in &doc {
            if let toml::Value::Table(t) = v {
                for (k, v) in t {
                    let key = format!("{table}.{k}");
                    if let Some(x) = v.as_float() {
                        assert_eq!(s.number(&key), Ok(x), "{key}");
                    }
                }
            }
        }
    }

    #[test]
    fn keys_that_are_no_number_or_unknown_or_unused_are_refused() {
        let s = Scene::default();
        assert!(matches!(
            s.number("friction.law"),
            Err(KeyError::NotANumber(_))
        ));
        assert!(matches!(
            s.number("horizon.periods"),
            Err(KeyError::NotANumber(_))
        ));
        assert!(matches!(
            s.number("capsule.mass"),
            Err(KeyError::Unknown(_))
        ));
        assert!(matches!(s.number("gamma"), Err(KeyError::Unknown(_))));
        assert!(matches!(
            s.number("friction.mu_v"),
            Err(KeyError::NotUsed { .. })
        ));
        assert!(matches!(
            s.number("device.lag_s"),
            Err(KeyError::NotUsed { .. })
        ));
    }
}
