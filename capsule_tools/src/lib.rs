//! The capsule's client tools beside the nodes.
//!
//! - [`foxglove_bridge`]: the graph live on a Foxglove WebSocket on loopback (`capsule_foxglove`)
//! - [`client`]: a client of the graph (mode requests, demo measurement; `capsule_ros`)

#![warn(missing_docs)]

pub mod client;
pub mod foxglove_bridge;
