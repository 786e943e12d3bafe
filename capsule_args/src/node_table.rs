//! The scene file's `[node]` table: how the plant node runs the scene (its sample rate, its
//! command timeout). The physics' scene reader ([`Scene`](capsule_plant::scene::Scene)) passes
//! the table over; [`crate::scene_file::SceneFile`] reads it here, so every binary refuses a bad
//! value the same way, with the file, the key and the reason.

use capsule_plant::scene::{read_toml, Rule, SceneError};
use serde::Deserialize;

/// Lowest and highest sample rate of the plant node \[Hz\]: one sample per 1000 s to 1 MHz (a
/// period that every clock and `Duration` holds).
pub const RATE_HZ: (f64, f64) = (1e-3, 1e6);
/// Shortest and longest command timeout of the plant node \[s\].
pub const TIMEOUT_S: (f64, f64) = (1e-6, 1e6);

/// How the plant node runs the scene.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeTable {
    /// State publication (and control) rate \[Hz\].
    pub rate_hz: f64,
    /// After this long without a command the plant applies zero force \[s\].
    pub command_timeout_s: f64,
}

impl Default for NodeTable {
    fn default() -> Self {
        NodeTable {
            rate_hz: 1000.0,
            command_timeout_s: 0.1,
        }
    }
}

/// The file as this reader sees it: the `[node]` table; the other tables are the scene's.
#[derive(Deserialize)]
struct RawFile {
    #[serde(default)]
    node: NodeSpec,
}

#[derive(Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct NodeSpec {
    rate_hz: Option<f64>,
    command_timeout_s: Option<f64>,
}

impl NodeTable {
    /// The `[node]` table of a scene text over the defaults, checked; `file` names the source in
    /// errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<NodeTable, SceneError> {
        let raw: RawFile = read_toml(text).map_err(|e| e.in_file(file))?;
        let d = NodeTable::default();
        let node = NodeTable {
            rate_hz: raw.node.rate_hz.unwrap_or(d.rate_hz),
            command_timeout_s: raw.node.command_timeout_s.unwrap_or(d.command_timeout_s),
        };
        Rule::Within(RATE_HZ)
            .check("node.rate_hz", node.rate_hz)
            .and_then(|()| {
                Rule::Within(TIMEOUT_S).check("node.command_timeout_s", node.command_timeout_s)
            })
            .map_err(|e| e.in_file(file))?;
        Ok(node)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_node_table_over_the_defaults_and_its_refusals() {
        let read = |t: &str| NodeTable::from_toml_str(t, "f.toml");
        assert_eq!(read("[capsule]\ngamma = 2.0\n"), Ok(NodeTable::default()));
        let n = read("[node]\nrate_hz = 500.0\n").unwrap_or_default();
        assert_eq!((n.rate_hz, n.command_timeout_s), (500.0, 0.1));
        for (text, key, words) in [
            ("[node]\nrate_hz = 1e-300\n", "node.rate_hz", "must be in"),
            (
                "[node]\ncommand_timeout_s = 1e9\n",
                "node.command_timeout_s",
                "must be in",
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
