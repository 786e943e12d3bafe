//! The ROS options every capsule node takes: its flags ([`RosArgs`]) over the ROS environment
//! conventions ([`RosEnv`]: domain, discovery range, RMW service mapping, SROS2), resolved once
//! into a node's [`RosOptions`]. What they become: names ([`crate::naming`]), the participant
//! and the node ([`crate::participant`]), endpoints ([`crate::endpoints`]).

use std::collections::BTreeMap;

use crate::error::{bail, Context as _, Result};
use clap::{Args, ValueEnum};
use ros2_client::dds::ServiceMapping;
use ros2_client::{Name, NodeName};

use crate::{
    affinity::{self, CpuList},
    middleware::{Middleware, ZenohEnv},
    security::{Security, SecurityEnv},
};

/// How far DDS discovery reaches (the ROS 2 `ROS_AUTOMATIC_DISCOVERY_RANGE` idea).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum DiscoveryRange {
    /// Loopback only: the participant uses 127.0.0.1 and nothing else.
    Localhost,
    /// Every interface that can multicast (RustDDS's default).
    Subnet,
}

/// Which request/reply mapping services use on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Mapping {
    /// rmw_cyclonedds_cpp's mapping.
    Cyclone,
    /// The RPC-over-DDS "enhanced" mapping that rmw_fastrtps_cpp uses.
    Enhanced,
    /// The RPC-over-DDS "basic" mapping.
    Basic,
}

impl From<Mapping> for ServiceMapping {
    fn from(m: Mapping) -> Self {
        match m {
            Mapping::Cyclone => ServiceMapping::Cyclone,
            Mapping::Enhanced => ServiceMapping::Enhanced,
            Mapping::Basic => ServiceMapping::Basic,
        }
    }
}

/// The ROS options every capsule node takes (flags override the environment).
#[derive(Debug, Clone, Args)]
pub struct RosArgs {
    /// DDS domain [default: $ROS_DOMAIN_ID, else 0]
    #[arg(long, value_parser = clap::value_parser!(u16).range(0..=232))]
    pub domain_id: Option<u16>,
    /// Discovery range [default: localhost if $ROS_AUTOMATIC_DISCOVERY_RANGE is LOCALHOST or OFF
    /// or $ROS_LOCALHOST_ONLY=1, else subnet]
    #[arg(long, value_enum)]
    pub discovery_range: Option<DiscoveryRange>,
    /// Service request/reply mapping [default: from $RMW_IMPLEMENTATION: cyclone for
    /// rmw_cyclonedds_cpp, enhanced otherwise (rmw_fastrtps_cpp is the ROS 2 default)]
    #[arg(long, value_enum)]
    pub service_mapping: Option<Mapping>,
    /// Node name [default: the node's own]
    #[arg(long)]
    pub node_name: Option<String>,
    /// Node namespace; relative topic names resolve under it
    #[arg(long, default_value = "/")]
    pub namespace: String,
    /// Remap a topic or service name, FROM:=TO (repeatable), as `ros2 run ... -r FROM:=TO`
    #[arg(short = 'r', long = "remap", value_name = "FROM:=TO")]
    pub remap: Vec<String>,
    /// Take time from /clock (the ROS `use_sim_time` parameter)
    #[arg(long)]
    pub use_sim_time: bool,
    /// Run the node's threads (its own and DDS's) only on these CPUs, e.g. 0 or 0,2 or 1-3 (as
    /// `taskset -c`); nodes of one loop sharing a CPU wake each other more cheaply
    #[arg(long, value_name = "LIST")]
    pub cpu_affinity: Option<CpuList>,
    /// SROS2 enclave of this node, e.g. /capsule/plant (as `--ros-args --enclave`); used when
    /// $ROS_SECURITY_ENABLE is true, $ROS_SECURITY_ENCLAVE_OVERRIDE wins (docs/ros.md, Security)
    #[arg(long, value_name = "ENCLAVE")]
    pub enclave: Option<String>,
}

/// The environment a node reads its defaults from (so tests can pass their own).
#[derive(Debug, Clone, Default)]
pub struct RosEnv {
    /// `ROS_DOMAIN_ID`.
    pub domain_id: Option<String>,
    /// `ROS_AUTOMATIC_DISCOVERY_RANGE`.
    pub discovery_range: Option<String>,
    /// `ROS_LOCALHOST_ONLY`.
    pub localhost_only: Option<String>,
    /// `RMW_IMPLEMENTATION`.
    pub rmw_implementation: Option<String>,
    /// SROS2's `ROS_SECURITY_*`.
    pub security: SecurityEnv,
    /// rmw_zenoh_cpp's `ZENOH_SESSION_CONFIG_URI` and `ZENOH_CONFIG_OVERRIDE`.
    pub zenoh: ZenohEnv,
}

impl RosEnv {
    /// Reads the process environment.
    pub fn from_process() -> Self {
        let get = |k| {
            std::env::var(k)
                .ok()
                .filter(|v: &String| !v.trim().is_empty())
        };
        RosEnv {
            domain_id: get("ROS_DOMAIN_ID"),
            discovery_range: get("ROS_AUTOMATIC_DISCOVERY_RANGE"),
            localhost_only: get("ROS_LOCALHOST_ONLY"),
            rmw_implementation: get("RMW_IMPLEMENTATION"),
            security: SecurityEnv::from_process(),
            zenoh: ZenohEnv::from_vars(|k| std::env::var(k).ok()),
        }
    }
}

/// Resolved ROS settings of one node.
#[derive(Debug, Clone)]
pub struct RosOptions {
    /// DDS domain.
    pub domain_id: u16,
    /// Discovery range.
    pub range: DiscoveryRange,
    /// Service mapping.
    pub mapping: Mapping,
    /// Node name (base).
    pub node_name: String,
    /// Namespace (absolute).
    pub namespace: String,
    /// Remaps, resolved FROM -> resolved TO.
    pub remaps: BTreeMap<String, String>,
    /// Use /clock.
    pub use_sim_time: bool,
    /// CPUs to pin the node's threads to (checked against the allowed ones).
    pub cpu_affinity: Option<CpuList>,
    /// DDS Security: the enclave, or why not.
    pub security: Security,
    /// DDS or Zenoh (`RMW_IMPLEMENTATION`).
    pub middleware: Middleware,
}

impl RosOptions {
    /// Merges flags over the environment; errors name the flag or variable at fault.
    pub fn resolve(args: &RosArgs, env: &RosEnv, default_node: &str) -> Result<Self> {
        let domain_id = match (args.domain_id, &env.domain_id) {
            (Some(d), _) => d,
            (None, Some(v)) => match v.trim().parse::<u16>() {
                Ok(d) if d <= 232 => d,
                _ => bail!("ROS_DOMAIN_ID={v:?} is not a domain id (0..=232)"),
            },
            (None, None) => 0,
        };
        let range = match args.discovery_range {
            Some(r) => r,
            None => {
                let auto = env
                    .discovery_range
                    .as_deref()
                    .map(|s| s.trim().to_ascii_uppercase());
                match auto.as_deref() {
                    Some("LOCALHOST") | Some("OFF") => DiscoveryRange::Localhost,
                    Some("SUBNET") | Some("SYSTEM_DEFAULT") => DiscoveryRange::Subnet,
                    Some(other) => bail!(
                        "ROS_AUTOMATIC_DISCOVERY_RANGE={other:?}: expected LOCALHOST, SUBNET, OFF or SYSTEM_DEFAULT"
                    ),
                    None if env.localhost_only.as_deref().map(str::trim) == Some("1") => {
                        DiscoveryRange::Localhost
                    }
                    None => DiscoveryRange::Subnet,
                }
            }
        };
        let mapping = match args.service_mapping {
            Some(m) => m,
            None => match env.rmw_implementation.as_deref().map(str::trim) {
                Some(r) if r.starts_with("rmw_cyclonedds") => Mapping::Cyclone,
                _ => Mapping::Enhanced,
            },
        };
        let node_name = args
            .node_name
            .clone()
            .unwrap_or_else(|| default_node.to_string());
        if NodeName::new("/", &node_name).is_err() {
            bail!("--node-name {node_name:?} is not a valid ROS node name");
        }
        let namespace = normalize_namespace(&args.namespace)?;
        let mut settings = RosOptions {
            domain_id,
            range,
            mapping,
            node_name,
            namespace,
            remaps: BTreeMap::new(),
            use_sim_time: args.use_sim_time,
            cpu_affinity: args.cpu_affinity.clone(),
            security: Security::resolve(&env.security, args.enclave.as_deref())?,
            middleware: Middleware::resolve(
                env.rmw_implementation.as_deref(),
                &env.zenoh,
                &env.security,
            )?,
        };
        if let Some(list) = &settings.cpu_affinity {
            affinity::check(list, &affinity::allowed()?)
                .with_context(|| format!("--cpu-affinity {list}"))?;
        }
        for r in &args.remap {
            let Some((from, to)) = r.split_once(":=") else {
                bail!("--remap {r:?}: expected FROM:=TO");
            };
            let from = settings.expand(from.trim());
            let to = settings.expand(to.trim());
            for n in [&from, &to] {
                if Name::parse(n).is_err() {
                    bail!("--remap {r:?}: {n:?} is not a valid ROS name");
                }
            }
            settings.remaps.insert(from, to);
        }
        Ok(settings)
    }

    /// One line for the log: where this node talks.
    pub fn describe(&self) -> String {
        format!(
            "node {}/{} on {} domain {} discovery {:?} service mapping {:?}, {}{}",
            self.namespace.trim_end_matches('/'),
            self.node_name,
            self.middleware.describe(),
            self.domain_id,
            self.range,
            self.mapping,
            self.security.describe(),
            if self.use_sim_time {
                " use_sim_time"
            } else {
                ""
            }
        )
    }
}

fn normalize_namespace(ns: &str) -> Result<String> {
    let ns = ns.trim();
    let ns = if ns.starts_with('/') {
        ns.to_string()
    } else {
        format!("/{ns}")
    };
    if ns != "/" {
        let trimmed = ns.trim_end_matches('/');
        let (parent, base) = trimmed.rsplit_once('/').unwrap_or(("", trimmed));
        let parent = if parent.is_empty() { "/" } else { parent };
        if Name::new(parent, base).is_err() {
            bail!("--namespace {ns:?} is not a valid ROS namespace");
        }
        return Ok(trimmed.to_string());
    }
    Ok(ns)
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_msgs::names::topics;
    use clap::Parser;

    #[derive(Parser)]
    struct T {
        #[command(flatten)]
        ros: RosArgs,
    }

    fn settings(flags: &[&str], env: RosEnv) -> Result<RosOptions> {
        let mut argv = vec!["t"];
        argv.extend_from_slice(flags);
        let t = T::try_parse_from(argv).context("the test command line")?;
        RosOptions::resolve(&t.ros, &env, "capsule_controller")
    }

    #[test]
    fn environment_conventions_map_to_settings_and_flags_win() -> Result<()> {
        let s = settings(&[], RosEnv::default())?;
        assert_eq!(
            (s.domain_id, s.range, s.mapping),
            (0, DiscoveryRange::Subnet, Mapping::Enhanced)
        );
        let env = RosEnv {
            domain_id: Some("42".into()),
            discovery_range: Some("localhost".into()),
            rmw_implementation: Some("rmw_cyclonedds_cpp".into()),
            ..RosEnv::default()
        };
        let s = settings(&[], env.clone())?;
        assert_eq!(
            (s.domain_id, s.range, s.mapping),
            (42, DiscoveryRange::Localhost, Mapping::Cyclone)
        );
        let s = settings(&["--domain-id", "7", "--service-mapping", "enhanced"], env)?;
        assert_eq!((s.domain_id, s.mapping), (7, Mapping::Enhanced));
        let old = RosEnv {
            localhost_only: Some("1".into()),
            ..RosEnv::default()
        };
        assert_eq!(settings(&[], old)?.range, DiscoveryRange::Localhost);
        Ok(())
    }

    #[test]
    fn bad_environment_and_flags_are_named() {
        let env = RosEnv {
            domain_id: Some("x9".into()),
            ..RosEnv::default()
        };
        let e = settings(&[], env).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("ROS_DOMAIN_ID"), "{e}");
        let env = RosEnv {
            discovery_range: Some("GALAXY".into()),
            ..RosEnv::default()
        };
        let e = settings(&[], env).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("ROS_AUTOMATIC_DISCOVERY_RANGE"), "{e}");
        assert!(settings(&["--domain-id", "300"], RosEnv::default()).is_err());
        let e = settings(&["-r", "nothing"], RosEnv::default())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("--remap"), "{e}");
        let e = settings(&["--node-name", "bad name"], RosEnv::default())
            .map(|_| ())
            .unwrap_err()
            .to_string();
        assert!(e.contains("--node-name"), "{e}");
    }

    #[test]
    fn names_resolve_with_namespace_private_names_and_remaps() -> Result<()> {
        let s = settings(&[], RosEnv::default())?;
        assert_eq!(s.resolve_name(topics::STATE), "/capsule/state");
        assert_eq!(
            s.resolve_name(topics::SET_MODE),
            "/capsule_controller/set_mode"
        );
        assert_eq!(s.resolve_name(topics::CLOCK), "/clock");
        let s = settings(
            &[
                "--namespace",
                "robot1",
                "--node-name",
                "ctl",
                "-r",
                "capsule/state:=/sim/state",
            ],
            RosEnv::default(),
        )?;
        assert_eq!(s.resolve_name(topics::STATE), "/sim/state");
        assert_eq!(
            s.resolve_name(topics::FORCE),
            "/robot1/capsule/actuator_force"
        );
        assert_eq!(s.resolve_name(topics::STATUS), "/robot1/ctl/status");
        assert_eq!(s.resolve_name(topics::CLOCK), "/clock");
        Ok(())
    }
}
