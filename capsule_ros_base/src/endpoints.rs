//! A node's endpoints as the capsule nodes make them: topics and service servers by resolved
//! name ([`crate::naming`]), subscriptions that name their topic when refused, and [`Wire`], which
//! carries capsule_msgs' plain serde types as ros2-client messages.

use ros2_client::dds::Node;
use ros2_client::{Message, MessageTypeName, QosProfile, ServiceTypeName};
use serde::{de::DeserializeOwned, Deserialize, Serialize};

use crate::error::{Context as _, Result};
use crate::{graph::Graph, qos, ros_options::RosOptions, service::Service};

impl RosOptions {
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

    /// A server of the service `name` (resolved as [`RosOptions::ros_name`]) on the Zenoh
    /// `node`: a queryable under rmw_zenoh_cpp's key, announced with the type's hash; its
    /// answers go at once ([`crate::service`]).
    #[cfg(feature = "zenoh")]
    pub fn zenoh_server<Q, R>(
        &self,
        node: &ros2_client::zenoh::Node,
        name: &str,
        type_name: &ServiceTypeName,
    ) -> Result<Service<Q, R>>
    where
        Q: Message + Send + Sync + 'static,
        R: Message + Send + Sync + 'static,
    {
        let server = node
            .create_server(&self.ros_name(name)?, type_name)
            .with_context(|| format!("service {name} on Zenoh"))?;
        Ok(Service::on_zenoh(server, &self.resolve_name(name)))
    }
}

/// A subscription to `topic` with `qos`; a failure names the topic.
pub fn subscribe<M: 'static>(
    node: &mut Node,
    topic: &rustdds::Topic,
    qos: &QosProfile,
) -> Result<ros2_client::dds::Subscription<M>> {
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
