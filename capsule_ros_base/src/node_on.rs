//! A node on either middleware, for the endpoints whose logic is the same on both: a service
//! server ([`Service`], whose requests and answers read the same on DDS and Zenoh) and a
//! publisher ([`AnyPublisher`]). The one seam where the middleware differs; what the endpoints
//! serve is written once, above it.

use ros2_client::dds::Node;
use ros2_client::{Message, MessageTypeName, QosProfile, ServiceTypeName};
use serde::Serialize;

use crate::error::{Context as _, Result};
use crate::{graph::Graph, ros_options::RosOptions, service::Service};

/// The node endpoints are made on: DDS (with the graph its answers wait on) or Zenoh.
pub enum NodeOn<'a> {
    /// A DDS node and its graph.
    Dds(&'a mut Node, &'a Graph),
    /// A Zenoh node.
    #[cfg(feature = "zenoh")]
    Zenoh(&'a ros2_client::zenoh::Node),
}

/// A publisher on either middleware.
pub enum AnyPublisher<M: Serialize> {
    /// On DDS (boxed: a DDS publisher is twice a Zenoh one).
    Dds(Box<ros2_client::dds::Publisher<M>>),
    /// On Zenoh.
    #[cfg(feature = "zenoh")]
    Zenoh(ros2_client::zenoh::Publisher<M>),
}

impl NodeOn<'_> {
    /// A server of the service `name` (resolved as [`RosOptions::ros_name`]) of `type_name`.
    pub fn server<Q, R>(
        &mut self,
        settings: &RosOptions,
        name: &str,
        type_name: &ServiceTypeName,
    ) -> Result<Service<Q, R>>
    where
        Q: Message + Clone + Send + Sync + 'static,
        R: Message + Send + Sync + 'static,
    {
        match self {
            NodeOn::Dds(node, graph) => settings.server(node, graph, name, type_name),
            #[cfg(feature = "zenoh")]
            NodeOn::Zenoh(node) => settings.zenoh_server(node, name, type_name),
        }
    }

    /// A publisher of the topic `name` (resolved as [`RosOptions::ros_name`]) of `type_name`
    /// with `qos`.
    pub fn publisher<M: Serialize>(
        &mut self,
        settings: &RosOptions,
        name: &str,
        type_name: MessageTypeName,
        qos: &QosProfile,
    ) -> Result<AnyPublisher<M>> {
        Ok(match self {
            NodeOn::Dds(node, _) => {
                let topic = settings.topic(node, name, type_name, qos)?;
                AnyPublisher::Dds(Box::new(
                    node.create_publisher(&topic, None)
                        .with_context(|| format!("{name} publisher"))?,
                ))
            }
            #[cfg(feature = "zenoh")]
            NodeOn::Zenoh(node) => {
                let topic = node.create_topic(&settings.ros_name(name)?, type_name, qos);
                AnyPublisher::Zenoh(
                    node.create_publisher(&topic, None)
                        .with_context(|| format!("{name} publisher on Zenoh"))?,
                )
            }
        })
    }
}

impl<M: Serialize + std::fmt::Debug> AnyPublisher<M> {
    /// Sends `msg` now; the error says why not.
    pub fn publish(&self, msg: M) -> std::result::Result<(), String> {
        match self {
            AnyPublisher::Dds(p) => p.publish(msg).map_err(|e| format!("{e:?}")),
            #[cfg(feature = "zenoh")]
            AnyPublisher::Zenoh(p) => p.publish(msg).map_err(|e| format!("{e:?}")),
        }
    }

    /// Sends `msg`, waiting without blocking the thread; the error says why not.
    pub async fn async_publish(&self, msg: M) -> std::result::Result<(), String> {
        match self {
            AnyPublisher::Dds(p) => p.async_publish(msg).await.map_err(|e| format!("{e:?}")),
            #[cfg(feature = "zenoh")]
            AnyPublisher::Zenoh(p) => p.async_publish(msg).await.map_err(|e| format!("{e:?}")),
        }
    }
}
