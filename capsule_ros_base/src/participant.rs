//! The DDS participant and the ROS node: loopback only when the discovery range says so,
//! secured with the node's enclave (SROS2), on a participant id whose user-traffic port it holds
//! ([`crate::ports`]); a node for a command-line tool (ros2-client's spinner) or for a
//! sample-rate loop (no spinner: [`Graph`] follows the matches).

use std::{net::Ipv4Addr, time::Duration};

use ros2_client::dds::{Context, Node};
use ros2_client::{NodeName, NodeOptions, ParameterValue};

use crate::error::{Context as _, Result};
use crate::{
    graph::Graph, ros_options::DiscoveryRange, ros_options::RosOptions, security::Security,
};

impl RosOptions {
    /// Creates the DDS participant (loopback only when the range says so; secured with the
    /// enclave if [`Security::Enclave`]) and the ROS context.
    pub fn context(&self) -> Result<Context> {
        // every node not yet ported to Zenoh comes here for its DDS participant: refused by name
        self.middleware.refuse_on_zenoh(&self.node_name)?;
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
