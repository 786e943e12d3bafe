//! ROS 2 plumbing shared by the nodes: the ROS environment conventions (domain, discovery
//! range, RMW service mapping), node names and remapping, QoS, and the DDS participant. The
//! names themselves are [`capsule_msgs::names`].

use std::{collections::BTreeMap, net::Ipv4Addr, time::Duration};

use crate::error::{bail, BoxError, Context as _, NodeError, Result};
use clap::{Args, ValueEnum};
use ros2_client::{
    qos::{Durability, History, WhenFull},
    Context, Message, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue,
    QosProfile, ServiceMapping, ServiceTypeName,
};
use serde::{de::DeserializeOwned, Deserialize, Serialize};

use crate::{
    affinity::{self, CpuList},
    graph::Graph,
    security::{Security, SecurityEnv},
    service::Service,
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

    /// Expands `~/x` (private), `x` (relative) and `/x` (absolute) to a full name, no remap.
    pub fn expand(&self, name: &str) -> String {
        let ns = self.namespace.trim_end_matches('/');
        if let Some(rest) = name.strip_prefix("~/") {
            format!("{ns}/{}/{rest}", self.node_name)
        } else if name.starts_with('/') {
            name.to_string()
        } else {
            format!("{ns}/{name}")
        }
    }

    /// The full name a topic or service gets: expanded, then remapped.
    pub fn resolve_name(&self, name: &str) -> String {
        let full = self.expand(name);
        self.remaps.get(&full).cloned().unwrap_or(full)
    }

    /// The resolved name as a ros2-client [`Name`].
    pub fn ros_name(&self, name: &str) -> Result<Name> {
        let full = self.resolve_name(name);
        Name::parse(&full).with_context(|| format!("bad ROS name {full:?}"))
    }

    /// The topic `name` (resolved with namespace and remapping) of `type_name` on `node`.
    pub fn topic(
        &self,
        node: &Node,
        name: &str,
        type_name: MessageTypeName,
        qos: &QosProfile,
    ) -> Result<rustdds::Topic> {
        node.create_topic(&self.ros_name(name)?, type_name, qos)
            .with_context(|| format!("topic {name}"))
    }

    /// A server of the service `name` (resolved as [`RosOptions::ros_name`]) in the chosen
    /// mapping, with the services' QoS; its answers wait for the client's reply reader, whose
    /// matches `graph` follows ([`crate::service`]).
    pub fn server<Q, R>(
        &self,
        node: &mut Node,
        graph: &Graph,
        name: &str,
        type_name: &ServiceTypeName,
    ) -> Result<Service<Q, R>>
    where
        Q: Message + Clone + Send + Sync + 'static,
        R: Message + Send + Sync + 'static,
    {
        let server = node
            .create_server(
                self.mapping.into(),
                &self.ros_name(name)?,
                type_name,
                qos::service(),
                qos::service(),
            )
            .with_context(|| format!("service {name}"))?;
        Ok(Service::new(
            server,
            graph.clone(),
            &self.resolve_name(name),
        ))
    }

    /// Creates the DDS participant (loopback only when the range says so; secured with the
    /// enclave if [`Security::Enclave`]) and the ROS context.
    pub fn context(&self) -> Result<Context> {
        let participant = match &self.security {
            Security::Off => self.participant(None)?,
            Security::Unsecured { why } => {
                tracing::warn!("ROS_SECURITY_ENABLE=true but running UNSECURED: {why}");
                self.participant(None)?
            }
            Security::Enclave { name, dir, enforce } => match self.participant(Some(dir)) {
                Ok(p) => p,
                Err(e) if *enforce => return Err(e),
                Err(e) => {
                    tracing::warn!(
                        "enclave {name}: {}; running UNSECURED (ROS_SECURITY_STRATEGY is not Enforce)",
                        crate::error::chain(&e)
                    );
                    self.participant(None)?
                }
            },
        };
        Context::from_domain_participant(participant).context("cannot create the ROS 2 context")
    }

    /// The DDS participant, with the builtin security plugins configured from `enclave`, on a
    /// participant id whose user-traffic port it holds (see [`crate::ports`]): when another
    /// process took that port, the id's discovery port is held while the participant is built
    /// again, so RustDDS takes the next id.
    fn participant(&self, enclave: Option<&std::path::Path>) -> Result<rustdds::DomainParticipant> {
        let mut held = Vec::new();
        loop {
            let participant = self.build_participant(enclave)?;
            let id = participant.participant_id();
            let port = crate::ports::user_port(self.domain_id, id);
            if crate::ports::holds_udp_port(port) != Some(false) || held.len() >= MAX_PORT_RETRIES {
                return Ok(participant);
            }
            tracing::debug!("participant id {id}: another process took its user port {port}; building it again on the next id");
            drop(participant);
            held.push(hold_port(crate::ports::discovery_port(self.domain_id, id)));
        }
    }

    /// The DDS participant as RustDDS builds it.
    fn build_participant(
        &self,
        enclave: Option<&std::path::Path>,
    ) -> Result<rustdds::DomainParticipant> {
        let mut builder = rustdds::DomainParticipantBuilder::new(self.domain_id);
        if self.range == DiscoveryRange::Localhost {
            builder = builder.with_only_networks([Ipv4Addr::LOCALHOST]);
        }
        if let Some(dir) = enclave {
            builder = crate::security::configure(builder, dir)?;
        }
        builder.build().map_err(|e| {
            let what = format!(
                "cannot create a DDS participant in domain {}",
                self.domain_id
            );
            match enclave {
                Some(dir) => {
                    // RustDDS names the step that refused; say which file, if we can tell
                    let file = crate::security::diagnose(dir)
                        .map(|why| format!(" ({why})"))
                        .unwrap_or_default();
                    crate::error::NodeError::Failed {
                        what: format!(
                            "{what}: DDS Security refused the enclave {}{file}",
                            dir.display()
                        ),
                        source: e.into(),
                    }
                }
                None => crate::error::NodeError::Failed {
                    what,
                    source: e.into(),
                },
            }
        })
    }

    fn bare_node(&self, context: &Context) -> Result<Node> {
        let name = NodeName::new(&self.namespace, &self.node_name)
            .with_context(|| format!("bad node name {}/{}", self.namespace, self.node_name))?;
        let options = NodeOptions::new()
            .enable_rosout(true)
            .declare_parameter("use_sim_time", ParameterValue::Boolean(self.use_sim_time));
        context
            .new_node(name, options)
            .context("cannot create the ROS node")
    }

    /// Creates a node for a command-line tool, with ros2-client's spinner (graph, parameter
    /// services, sim time).
    pub fn node(&self, context: &Context) -> Result<Node> {
        let mut node = self.bare_node(context)?;
        let spinner = node.spinner().context("cannot create the node spinner")?;
        tokio::spawn(async move {
            if let Err(e) = spinner.spin().await {
                tracing::error!("ROS spinner stopped: {e:?}");
            }
        });
        Ok(node)
    }

    /// Creates a node for a sample-rate loop (plant, controller, recorder): no spinner (it
    /// would receive every /clock sample), the graph followed by [`Graph`] instead.
    pub fn loop_node(&self, context: &Context) -> Result<(Node, Graph)> {
        let graph = Graph::follow(context.domain_participant());
        Ok((self.bare_node(context)?, graph))
    }

    /// One line for the log: where this node talks.
    pub fn describe(&self) -> String {
        format!(
            "node {}/{} domain {} discovery {:?} service mapping {:?}, {}{}",
            self.namespace.trim_end_matches('/'),
            self.node_name,
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

/// A subscription to `topic` with `qos`; a failure names the topic.
pub fn subscribe<M: 'static>(
    node: &mut Node,
    topic: &rustdds::Topic,
    qos: &QosProfile,
) -> Result<ros2_client::Subscription<M>> {
    use rustdds::TopicDescription as _;
    node.create_subscription(topic, Some(qos.clone()))
        .with_context(|| format!("subscription to {}", topic.name()))
}

/// A message carried as is; lets capsule_msgs' plain serde types travel as ros2-client
/// [`Message`]s without capsule_msgs depending on ROS.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Wire<T>(pub T);

impl<T: Serialize + DeserializeOwned> Message for Wire<T> {}

/// ROS type names of the capsule interfaces, as ros2-client takes them (from
/// [`capsule_msgs::names::type_names`]).
pub mod types {
    use super::*;
    use capsule_msgs::names::type_names::{self as n, split};
    fn message(full: &str) -> MessageTypeName {
        let (package, name) = split(full);
        MessageTypeName::new(package, name)
    }
    fn service(full: &str) -> ServiceTypeName {
        let (package, name) = split(full);
        ServiceTypeName::new(package, name)
    }
    /// `capsule_msgs/msg/CapsuleState`.
    pub fn state() -> MessageTypeName {
        message(n::STATE)
    }
    /// `capsule_msgs/msg/ActuatorForce`.
    pub fn force() -> MessageTypeName {
        message(n::FORCE)
    }
    /// `capsule_msgs/msg/ControllerStatus`.
    pub fn status() -> MessageTypeName {
        message(n::STATUS)
    }
    /// `sensor_msgs/msg/JointState` (joint_states and the JointState commands).
    pub fn joint_state() -> MessageTypeName {
        message(n::JOINT_STATE)
    }
    /// `rosgraph_msgs/msg/Clock`.
    pub fn clock() -> MessageTypeName {
        message(n::CLOCK)
    }
    /// `capsule_msgs/srv/SetMode`.
    pub fn set_mode() -> ServiceTypeName {
        service(n::SET_MODE)
    }
    /// `diagnostic_msgs/msg/DiagnosticArray` (`/diagnostics`).
    pub fn diagnostics() -> MessageTypeName {
        message(n::DIAGNOSTIC_ARRAY)
    }
    /// `std_msgs/msg/Bool` (the emergency-stop state).
    pub fn bool() -> MessageTypeName {
        message(n::BOOL)
    }
    /// `std_srvs/srv/SetBool` (the emergency stop).
    pub fn set_bool() -> ServiceTypeName {
        service(n::SET_BOOL)
    }
}

/// How many participant ids [`RosOptions::context`] skips when another process holds their
/// user-traffic port before it keeps what it got.
const MAX_PORT_RETRIES: usize = 8;

/// Binds `port` (so a participant built meanwhile takes the next id), retrying for up to 0.5 s
/// while a participant just dropped still releases it; `None` if it cannot.
fn hold_port(port: u16) -> Option<std::net::UdpSocket> {
    for _ in 0..50 {
        if let Ok(socket) = std::net::UdpSocket::bind((std::net::Ipv4Addr::UNSPECIFIED, port)) {
            return Some(socket);
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    None
}

/// QoS of the capsule topics.
pub mod qos {
    use super::*;
    /// A reliable, volatile, keep-last-`depth` writer's profile whose full window waits at most
    /// `wait_ms`.
    fn reliable(wait_ms: u64, depth: usize) -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(wait_ms)))
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth })
    }
    /// State, force and status: reliable (so both reliable and best-effort rclcpp
    /// subscribers match), volatile, keep last 16; a full window waits at most 5 ms.
    pub fn data() -> QosProfile {
        reliable(5, 16)
    }
    /// Readers of state and force: best effort, keep last 16. A best-effort reader matches
    /// reliable and best-effort writers alike, and against our reliable writers it spares the
    /// acknowledgement traffic (a quarter of each node's CPU at 1 kHz, and latency); rclpy
    /// reliable subscribers still get reliable delivery from the same writers. A lost sample is
    /// re-sent by the lock-step plant and superseded by the next one in real time.
    pub fn data_reader() -> QosProfile {
        QosProfile::subscription_default().history(History::KeepLast { depth: 16 })
    }
    /// /clock readers: best effort keep-last 1, like rclcpp's and rclpy's time source.
    pub fn clock_reader() -> QosProfile {
        QosProfile::subscription_default()
    }
    /// /clock: reliable keep-last 1 (matches rclcpp's best-effort clock subscription too).
    pub fn clock() -> QosProfile {
        reliable(5, 1)
    }
    /// Services: reliable, volatile, keep last 10 (rmw's services default).
    pub fn service() -> QosProfile {
        reliable(100, 10)
    }
    /// The controller's service events (`set_mode/_service_event`): reliable, transient local,
    /// keep last 64, writer and readers alike. rcl's are volatile; here a recorder whose
    /// discovery of the event writer ends late (seconds with DDS Security) still gets the
    /// requests made before, and volatile readers (rosbag2, rclcpp) match it all the same.
    pub fn service_events() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 64 })
    }
    /// Latched state (robot_description, the emergency stop): reliable, transient local, keep
    /// last 1, so a reader that joins later gets the last value.
    pub fn latched() -> QosProfile {
        QosProfile::publisher_default()
            .reliability_reliable(WhenFull::Wait(Duration::from_millis(100)))
            .durability(Durability::TransientLocal)
            .history(History::KeepLast { depth: 1 })
    }
}

/// Sets up tracing to stderr (`RUST_LOG` filters; default `info` with RustDDS's shutdown noise off).
pub fn init_logging() {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new("info,rustdds=off,ros2_client=error")
    });
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_ansi(ansi)
        .with_writer(std::io::stderr)
        .try_init();
}

/// Runs a node's future on a single-threaded tokio runtime (the thread that calls this), its
/// threads (and DDS's, started from them) pinned to `cpus` if given. One runtime thread: a
/// sample that DDS's thread hands over wakes that thread directly, where a multi-threaded
/// runtime wakes whichever worker is idle, often on the other CPU (docs/ros.md, lock-step).
pub fn block_on<T, E, F>(cpus: Option<&CpuList>, fut: F) -> Result<T, E>
where
    E: From<NodeError>,
    F: std::future::Future<Output = Result<T, E>>,
{
    if let Some(list) = cpus {
        affinity::pin_process(list).with_context(|| format!("--cpu-affinity {list}"))?;
    }
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .context("cannot start the tokio runtime")?
        .block_on(fut)
}

/// Prints an error chain as one line (`NAME: error: what: why: ...`) and maps it to exit
/// status 2.
pub fn exit_code<E: Into<BoxError>>(name: &str, result: Result<(), E>) -> std::process::ExitCode {
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            let e: BoxError = e.into();
            eprintln!("{name}: error: {}", crate::error::chain(&*e));
            std::process::ExitCode::from(2)
        }
    }
}

/// The `main` of a node binary: with `--check` (`check`), prints `NAME: ok: SETTINGS` and
/// what `would` says about the options, and exits; otherwise `run`s the node. Either way an
/// error (of `built` or the run) is printed by [`exit_code`].
pub fn node_main<O, E: Into<BoxError>>(
    name: &str,
    check: bool,
    built: Result<(RosOptions, O), E>,
    would: impl FnOnce(&O) -> String,
    run: impl FnOnce(RosOptions, O) -> Result<(), E>,
) -> std::process::ExitCode {
    let result = built.and_then(|(settings, opts)| {
        if check {
            println!("{name}: ok: {}{}", settings.describe(), would(&opts));
            return Ok(());
        }
        run(settings, opts)
    });
    exit_code(name, result)
}

/// [`node_main`] for a node that is one future: run on [`block_on`]'s runtime, pinned to the
/// node's `--cpu-affinity`.
pub fn async_node_main<O, E, F>(
    name: &str,
    check: bool,
    built: Result<(RosOptions, O), E>,
    would: impl FnOnce(&O) -> String,
    run: impl FnOnce(RosOptions, O) -> F,
) -> std::process::ExitCode
where
    E: Into<BoxError> + From<NodeError>,
    F: std::future::Future<Output = Result<()>>,
{
    node_main(name, check, built, would, |settings, opts| {
        let cpus = settings.cpu_affinity.clone();
        Ok(block_on(cpus.as_ref(), run(settings, opts))?)
    })
}

/// [`shutdown_signal`], logged (`SIGTERM: shutting down`): the end of a node's loop.
pub async fn shutdown() -> Result<()> {
    let sig = shutdown_signal().await?;
    tracing::info!("{sig}: shutting down");
    Ok(())
}

/// Resolves when the process gets Ctrl-C (SIGINT) or SIGTERM.
pub async fn shutdown_signal() -> Result<&'static str> {
    use tokio::signal::unix::{signal, SignalKind};
    let mut term = signal(SignalKind::terminate()).context("cannot install the SIGTERM handler")?;
    let mut int = signal(SignalKind::interrupt()).context("cannot install the SIGINT handler")?;
    tokio::select! {
        _ = term.recv() => Ok("SIGTERM"),
        _ = int.recv() => Ok("SIGINT"),
    }
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
