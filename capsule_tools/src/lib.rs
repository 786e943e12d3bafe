//! The capsule's client tools beside the nodes.
//!
//! - [`foxglove_bridge`]: the graph live on a Foxglove WebSocket on loopback (`capsule_foxglove`)
//! - [`client`]: a client of the graph (mode requests, demo measurement; `capsule_ros`)
//! - [`move_client`]: a client of the controller's Move action (`capsule_ros move`)

#![warn(missing_docs)]

pub mod client;
pub mod foxglove_bridge;
pub mod move_client;
