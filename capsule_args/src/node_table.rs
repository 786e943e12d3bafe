//! The scene file's `[node]` table: how the plant node runs the scene (its sample rate, its
//! command timeout). Its keys, defaults and ranges are the plant's settings table's
//! ([`crate::plant_settings`]: the settings with a `node.` scene key). The physics' scene
//! reader ([`Scene`](capsule_plant::scene::Scene)) passes the table over;
//! [`crate::scene_file::SceneFile`] reads it here, so every binary refuses a bad value the same
//! way, with the file, the key and the reason.

use std::collections::BTreeMap;

use capsule_plant::scene::{read_toml, SceneError};
use serde::Deserialize;

use crate::plant_settings::{COMMAND_TIMEOUT_S, LOCKSTEP_GIVE_UP_S, PLANT, RATE_HZ};
use crate::settings::Setting;

/// How the plant node runs the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeTable {
    /// State publication (and control) rate \[Hz\].
    pub rate_hz: f64,
    /// After this long without a command the plant applies zero force \[s\].
    pub command_timeout_s: f64,
    /// Lock-step: after this long without an answer the run ends \[s\].
    pub lockstep_give_up_s: f64,
}

impl Default for NodeTable {
    fn default() -> Self {
        NodeTable {
            rate_hz: RATE_HZ.default.unwrap_or(f64::NAN),
            command_timeout_s: COMMAND_TIMEOUT_S.default.unwrap_or(f64::NAN),
            lockstep_give_up_s: LOCKSTEP_GIVE_UP_S.default.unwrap_or(f64::NAN),
        }
    }
}

/// The file as this reader sees it: the `[node]` table; the other tables are the scene's.
#[derive(Deserialize)]
struct RawFile {
    #[serde(default)]
    node: NodeKeys,
}

/// The `[node]` table's numbers by key (which keys it may have, the settings table says).
#[derive(Default)]
struct NodeKeys(BTreeMap<String, f64>);

impl<'de> Deserialize<'de> for NodeKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Keys;
        impl<'de> serde::de::Visitor<'de> for Keys {
            type Value = NodeKeys;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a table")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<NodeKeys, A::Error> {
                let mut keys = BTreeMap::new();
                while let Some(key) = m.next_key::<String>()? {
                    if node_setting(&key).is_none() {
                        let known: Vec<String> =
                            node_settings().map(|(k, _)| format!("`{k}`")).collect();
                        return Err(serde::de::Error::custom(format!(
                            "unknown field `{key}`, expected {}",
                            known.join(" or ")
                        )));
                    }
                    let value: f64 = m.next_value()?;
                    keys.insert(key, value);
                }
                Ok(NodeKeys(keys))
            }
        }
        d.deserialize_map(Keys)
    }
}

/// The plant's settings the `[node]` table gives, by their key in it.
fn node_settings() -> impl Iterator<Item = (&'static str, &'static Setting)> {
    PLANT
        .iter()
        .filter_map(|s| Some((s.scene?.strip_prefix("node.")?, s)))
}

impl NodeTable {
    /// The value of the scene key `key` (`node.rate_hz`): what the file says, else the
    /// default; `None` for a key that is not the `[node]` table's.
    pub fn value(&self, key: &str) -> Option<f64> {
        if key == RATE_HZ.scene? {
            Some(self.rate_hz)
        } else if key == COMMAND_TIMEOUT_S.scene? {
            Some(self.command_timeout_s)
        } else if key == LOCKSTEP_GIVE_UP_S.scene? {
            Some(self.lockstep_give_up_s)
        } else {
            None
        }
    }
}

fn node_setting(key: &str) -> Option<&'static Setting> {
    node_settings().find(|(k, _)| *k == key).map(|(_, s)| s)
}

impl NodeTable {
    /// The `[node]` table of a scene text over the defaults, checked; `file` names the source in
    /// errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<NodeTable, SceneError> {
        let raw: RawFile = read_toml(text).map_err(|e| e.in_file(file))?;
        for (key, s) in node_settings() {
            if let Some(v) = raw.node.0.get(key) {
                s.scene_rule()
                    .check(&format!("node.{key}"), *v)
                    .map_err(|e| e.in_file(file))?;
            }
        }
        let d = NodeTable::default();
        let get = |s: &Setting, default: f64| {
            let key = s.scene.and_then(|k| k.strip_prefix("node."));
            key.and_then(|k| raw.node.0.get(k))
                .copied()
                .unwrap_or(default)
        };
        Ok(NodeTable {
            rate_hz: get(&RATE_HZ, d.rate_hz),
            command_timeout_s: get(&COMMAND_TIMEOUT_S, d.command_timeout_s),
            lockstep_give_up_s: get(&LOCKSTEP_GIVE_UP_S, d.lockstep_give_up_s),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_node_table_over_the_defaults_and_its_refusals() {
        let read = |t: &str| NodeTable::from_toml_str(t, "f.toml");
        assert_eq!(read("[capsule]\ngamma = 2.0\n"), Ok(NodeTable::default()));
        assert_eq!(NodeTable::default().rate_hz, 1000.0);
        let n = read("[node]\nrate_hz = 500.0\n").unwrap_or_default();
        assert_eq!((n.rate_hz, n.command_timeout_s), (500.0, 0.1));
        assert_eq!(n.lockstep_give_up_s, 30.0);
        let n = read("[node]\nlockstep_give_up_s = 2.5\n").unwrap_or_default();
        assert_eq!(n.value("node.lockstep_give_up_s"), Some(2.5));
        assert_eq!(
            (n.value("node.rate_hz"), n.value("drive.alpha")),
            (Some(500.0), None)
        );
        for (text, key, words) in [
            (
                "[node]\nrate_hz = 1e-300\n",
                "node.rate_hz",
                "must be in [1e-3, 1e6]",
            ),
            (
                "[node]\ncommand_timeout_s = 1e9\n",
                "node.command_timeout_s",
                "must be in [1e-6, 1e6]",
            ),
            (
                "[node]\nlockstep_give_up_s = 0\n",
                "node.lockstep_give_up_s",
                "must be in [1e-3, 1e6]",
            ),
            (
                "[node]\nrate_hz = \"fast\"\n",
                "node.rate_hz",
                "invalid type",
            ),
            ("[node]\nrate = 5.0\n", "node", "unknown field `rate`"),
            ("node = 5\n", "node", "expected a table"),
        ] {
            let e = read(text).err().map(|e| e.to_string()).unwrap_or_default();
            assert!(e.starts_with(&format!("f.toml: {key}")), "{text:?}: {e}");
            assert!(e.contains(words), "{text:?}: {e}");
        }
    }
}
