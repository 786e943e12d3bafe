//! Which middleware a node speaks, as ROS 2's `RMW_IMPLEMENTATION` chooses it: DDS (RustDDS,
//! the default and every `rmw_*dds*` name) or Zenoh (`rmw_zenoh_cpp`: ros2-client's Zenoh
//! backend, in a session configured as rmw_zenoh_cpp configures its own, [`ZenohEnv`];
//! cargo feature `zenoh`, docs/perf/zenoh.md).
//!
//! What a node cannot do on Zenoh yet it refuses by name ([`Middleware::refuse_on_zenoh`]),
//! before any work: nothing goes silently missing. SROS2's DDS Security does not apply to Zenoh,
//! so `ROS_SECURITY_ENABLE=true` under Zenoh is refused too, never run unsecured.

use std::path::PathBuf;

use crate::error::{bail, Result};
use crate::security::SecurityEnv;

/// rmw_zenoh_cpp's default router, as `ros2 run rmw_zenoh_cpp rmw_zenohd` listens
/// (`tcp/localhost:7447`; IPv4 loopback named, so no name lookup and no IPv6).
pub const ZENOH_ROUTER: &str = "tcp/127.0.0.1:7447";

/// The variables rmw_zenoh_cpp reads for its session (so tests can pass their own).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ZenohEnv {
    /// `ZENOH_SESSION_CONFIG_URI`: a Zenoh JSON5 configuration file, instead of the default.
    pub session_config_uri: Option<PathBuf>,
    /// `ZENOH_CONFIG_OVERRIDE`: `key=value` pairs (values JSON5) separated by `;`, applied last.
    pub config_override: Option<String>,
}

impl ZenohEnv {
    /// Reads the variables through `get` (unset or blank: not set).
    pub fn from_vars(get: impl Fn(&str) -> Option<String>) -> Self {
        let get = |k| get(k).filter(|v: &String| !v.trim().is_empty());
        ZenohEnv {
            session_config_uri: get("ZENOH_SESSION_CONFIG_URI").map(PathBuf::from),
            config_override: get("ZENOH_CONFIG_OVERRIDE"),
        }
    }
}

/// The middleware a node speaks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Middleware {
    /// DDS through RustDDS (ROS 2's default).
    Dds,
    /// Zenoh as rmw_zenoh_cpp speaks it, its session configured from these variables.
    Zenoh(ZenohEnv),
}

impl Middleware {
    /// The middleware `RMW_IMPLEMENTATION` (`rmw`) names: Zenoh for `rmw_zenoh*`, DDS for
    /// anything else or nothing. Zenoh is refused in a build without it, and with
    /// `ROS_SECURITY_ENABLE=true` (SROS2 secures DDS only).
    pub fn resolve(rmw: Option<&str>, zenoh: &ZenohEnv, security: &SecurityEnv) -> Result<Self> {
        let Some(rmw) = rmw.map(str::trim).filter(|r| r.starts_with("rmw_zenoh")) else {
            return Ok(Middleware::Dds);
        };
        if !cfg!(feature = "zenoh") {
            bail!(
                "RMW_IMPLEMENTATION={rmw}: this build has no Zenoh (build capsule_nodes with \
                 `--features zenoh`, docs/ros.md, Zenoh)"
            );
        }
        if security.enable {
            bail!(
                "ROS_SECURITY_ENABLE=true with RMW_IMPLEMENTATION={rmw}: SROS2's DDS Security \
                 does not apply to Zenoh, and capsule does not configure Zenoh's own TLS and \
                 access control; refusing to run unsecured (unset ROS_SECURITY_ENABLE, or use DDS)"
            );
        }
        Ok(Middleware::Zenoh(zenoh.clone()))
    }

    /// Whether this is Zenoh.
    pub fn is_zenoh(&self) -> bool {
        matches!(self, Middleware::Zenoh(_))
    }

    /// Refuses `what` (a node, a service, a feature) on Zenoh: "`what` is not available on Zenoh
    /// yet".
    pub fn refuse_on_zenoh(&self, what: &str) -> Result<()> {
        if self.is_zenoh() {
            bail!(
                "{what} is not available on Zenoh yet (RMW_IMPLEMENTATION=rmw_zenoh_cpp); \
                 run it on DDS (unset RMW_IMPLEMENTATION)"
            );
        }
        Ok(())
    }

    /// The node's tokio runtime: one thread (a sample DDS hands over wakes the node's own
    /// thread, [`crate::node_main::block_on`]); on Zenoh a multi-threaded runtime with one
    /// worker, as zenoh requires (its blocking calls panic on a current-thread runtime).
    pub fn runtime(&self) -> tokio::runtime::Builder {
        match self {
            Middleware::Dds => tokio::runtime::Builder::new_current_thread(),
            Middleware::Zenoh(_) => {
                let mut builder = tokio::runtime::Builder::new_multi_thread();
                builder.worker_threads(1);
                builder
            }
        }
    }

    /// A word for the log and `--check`: `DDS`, `Zenoh`.
    pub fn describe(&self) -> &'static str {
        match self {
            Middleware::Dds => "DDS",
            Middleware::Zenoh(_) => "Zenoh",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rmw_implementation_chooses_and_dds_stays_the_default() -> Result<()> {
        let (zenoh, off) = (ZenohEnv::default(), SecurityEnv::default());
        assert_eq!(Middleware::resolve(None, &zenoh, &off)?, Middleware::Dds);
        for dds in ["rmw_fastrtps_cpp", "rmw_cyclonedds_cpp", "rmw_connextdds"] {
            assert_eq!(
                Middleware::resolve(Some(dds), &zenoh, &off)?,
                Middleware::Dds
            );
        }
        let chosen = Middleware::resolve(Some(" rmw_zenoh_cpp"), &zenoh, &off);
        if cfg!(feature = "zenoh") {
            assert!(chosen?.is_zenoh());
        } else {
            let e = chosen.map(|_| ()).unwrap_err().to_string();
            assert!(e.contains("--features zenoh"), "{e}");
        }
        Ok(())
    }

    #[test]
    fn security_is_refused_on_zenoh_never_dropped() {
        let on = SecurityEnv {
            enable: true,
            ..SecurityEnv::default()
        };
        let e = Middleware::resolve(Some("rmw_zenoh_cpp"), &ZenohEnv::default(), &on)
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("ROS_SECURITY_ENABLE") || e.contains("no Zenoh"),
            "{e}"
        );
        assert!(Middleware::resolve(Some("rmw_fastrtps_cpp"), &ZenohEnv::default(), &on).is_ok());
    }

    #[test]
    fn zenoh_variables_are_read_and_blank_is_unset() {
        let env = ZenohEnv::from_vars(|k| match k {
            "ZENOH_SESSION_CONFIG_URI" => Some("/etc/z.json5".into()),
            "ZENOH_CONFIG_OVERRIDE" => Some("  ".into()),
            _ => None,
        });
        assert_eq!(env.session_config_uri, Some(PathBuf::from("/etc/z.json5")));
        assert_eq!(env.config_override, None);
        let e = Middleware::Zenoh(env).refuse_on_zenoh("capsule_recorder");
        let e = e.map(|_| ()).unwrap_err().to_string();
        assert!(
            e.contains("capsule_recorder is not available on Zenoh yet"),
            "{e}"
        );
        assert!(Middleware::Dds.refuse_on_zenoh("capsule_recorder").is_ok());
    }
}
