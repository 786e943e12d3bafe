//! The Zenoh session and node as rmw_zenoh_cpp makes them, on ros2-client's Zenoh backend:
//!
//! - the session's configuration ([`session_config`]): `ZENOH_SESSION_CONFIG_URI`'s file, else
//!   rmw_zenoh_cpp's default session (a peer that connects to the router on
//!   [`ZENOH_ROUTER`], listens on loopback only, no multicast scouting), then
//!   `ZENOH_CONFIG_OVERRIDE`'s `key=value;...` on top;
//! - the domain id leads every key expression (rmw_zenoh's isolation of domains);
//! - the REP-2016 type hash of every type we use, computed by capsule_msgs from the interface
//!   files, announced in key expressions and liveliness tokens ([`announce_type_hashes`];
//!   ros2-client alone knows a short table, docs/upstream/ros2-client-type-hash.md).

use ros2_client::{NodeName, NodeOptions};

use crate::error::{bail, invalid, Context as _, Result};
use crate::middleware::{Middleware, ZenohEnv, ZENOH_ROUTER};
use crate::ros_options::RosOptions;

/// rmw_zenoh_cpp's default session (`DEFAULT_RMW_ZENOH_SESSION_CONFIG.json5`), as Zenoh
/// configuration keys and JSON5 values; its `localhost` named as 127.0.0.1.
fn default_session() -> [(&'static str, String); 5] {
    [
        ("mode", "\"peer\"".into()),
        ("connect/endpoints", format!("[\"{ZENOH_ROUTER}\"]")),
        ("listen/endpoints", "[\"tcp/127.0.0.1:0\"]".into()),
        ("scouting/multicast/enabled", "false".into()),
        ("timestamping/enabled", "true".into()),
    ]
}

/// The session's configuration from `env`; a file that cannot be read or an override that
/// does not apply is an error naming the variable.
pub fn session_config(env: &ZenohEnv) -> Result<zenoh::Config> {
    let mut config = match &env.session_config_uri {
        Some(path) => zenoh::Config::from_file(path)
            .map_err(|e| invalid!("ZENOH_SESSION_CONFIG_URI={}: {e}", path.display()))?,
        None => {
            let mut config = zenoh::Config::default();
            for (key, value) in default_session() {
                config
                    .insert_json5(key, &value)
                    .map_err(|e| invalid!("the default Zenoh session's {key}={value}: {e}"))?;
            }
            config
        }
    };
    if let Some(overrides) = &env.config_override {
        apply_overrides(&mut config, overrides)?;
    }
    Ok(config)
}

/// Applies `ZENOH_CONFIG_OVERRIDE`'s `key=value;...` (values JSON5) to `config`, as rmw_zenoh
/// reads it for its sessions and its router; an entry that is not `key=value` or does not
/// apply is an error naming it.
pub fn apply_overrides(config: &mut zenoh::Config, overrides: &str) -> Result<()> {
    for entry in overrides
        .split(';')
        .map(str::trim)
        .filter(|e| !e.is_empty())
    {
        let Some((key, value)) = entry.split_once('=') else {
            bail!("ZENOH_CONFIG_OVERRIDE: {entry:?} is not key=value");
        };
        config
            .insert_json5(key.trim(), value.trim())
            .map_err(|e| invalid!("ZENOH_CONFIG_OVERRIDE: {entry:?}: {e}"))?;
    }
    Ok(())
}

/// Makes ros2-client announce capsule_msgs' hashes (computed from the interface files at
/// build time) for our types and the standard ones we use; once per process.
pub fn announce_type_hashes() {
    // false when already set: by us, earlier in this process
    let _ = ros2_client::zenoh::set_type_hash_lookup(capsule_msgs::hashes::of);
}

impl RosOptions {
    /// Opens the Zenoh session (see the [module](self) documentation) as this node's ROS
    /// context.
    pub fn zenoh_context(&self) -> Result<ros2_client::zenoh::Context> {
        let Middleware::Zenoh(env) = &self.middleware else {
            bail!("{}: a Zenoh context on DDS", self.node_name);
        };
        announce_type_hashes();
        let options = ros2_client::zenoh::ContextOptions::new()
            .domain_id(self.domain_id)
            .zenoh_config(session_config(env)?);
        ros2_client::zenoh::Context::with_options(options).context("cannot open the Zenoh session")
    }

    /// The node in `context`, announced (liveliness) as rmw_zenoh_cpp announces its nodes;
    /// without ros2-client's parameter services (they would serve none of the node's
    /// parameters: on Zenoh the parameters are not served yet, and the node says so).
    pub fn zenoh_node(
        &self,
        context: &ros2_client::zenoh::Context,
    ) -> Result<ros2_client::zenoh::Node> {
        let name = NodeName::new(&self.namespace, &self.node_name)
            .with_context(|| format!("bad node name {}/{}", self.namespace, self.node_name))?;
        context
            .new_node(
                name,
                NodeOptions::new()
                    .enable_rosout(true)
                    .start_parameter_services(false),
            )
            .context("cannot create the ROS node on Zenoh")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn get(config: &zenoh::Config, key: &str) -> String {
        config
            .get_json(key)
            .unwrap_or_else(|e| format!("{key}: {e}"))
    }

    #[test]
    fn the_default_session_is_rmw_zenohs_on_loopback_and_overrides_apply() -> Result<()> {
        let config = session_config(&ZenohEnv::default())?;
        assert_eq!(
            get(&config, "connect/endpoints"),
            "[\"tcp/127.0.0.1:7447\"]"
        );
        assert_eq!(get(&config, "listen/endpoints"), "[\"tcp/127.0.0.1:0\"]");
        assert_eq!(get(&config, "scouting/multicast/enabled"), "false");
        let env = ZenohEnv {
            config_override: Some(
                "mode=\"client\"; connect/endpoints=[\"tcp/127.0.0.1:7500\"]".into(),
            ),
            ..ZenohEnv::default()
        };
        let config = session_config(&env)?;
        assert_eq!(get(&config, "mode"), "\"client\"");
        assert_eq!(
            get(&config, "connect/endpoints"),
            "[\"tcp/127.0.0.1:7500\"]"
        );
        Ok(())
    }

    #[test]
    fn bad_zenoh_variables_are_named() {
        let bad = |env: ZenohEnv| session_config(&env).map(|_| ()).unwrap_err().to_string();
        let e = bad(ZenohEnv {
            config_override: Some("mode".into()),
            ..ZenohEnv::default()
        });
        assert!(e.contains("ZENOH_CONFIG_OVERRIDE"), "{e}");
        let e = bad(ZenohEnv {
            config_override: Some("no/such/key=1".into()),
            ..ZenohEnv::default()
        });
        assert!(e.contains("ZENOH_CONFIG_OVERRIDE"), "{e}");
        let e = bad(ZenohEnv {
            session_config_uri: Some("/nonexistent/zenoh.json5".into()),
            ..ZenohEnv::default()
        });
        assert!(e.contains("ZENOH_SESSION_CONFIG_URI"), "{e}");
    }
}
