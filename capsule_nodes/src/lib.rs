//! The capsule's ROS 2 layer: the plant and controller nodes (ros2-client on RustDDS).
//!
//! - [`affinity`]: pinning a node's threads to chosen CPUs (`--cpu-affinity`)
//! - [`ros`]: environment conventions, names and remapping, QoS, the (loopback-only) participant
//! - [`graph`]: matched endpoints and ROS time for the loop nodes (instead of ros2-client's spinner)
//! - [`scale`]: SI <-> non-dimensional conversion, scene values the controller needs
//! - [`client`]: a client of the graph (mode requests, demo measurement)
//! - [`controller`]: the controller node
//! - [`plant`]: the plant node (pacing, hold, watchdog) around any [`plant::PlantSim`]
//! - [`recorder`]: the recorder node (every topic to one MCAP file)
//! - [`sim`]: [`plant::PlantSim`] for the exact simulator of `capsule_plant`

#![warn(missing_docs)]

pub mod affinity;
pub mod client;
pub mod controller;
pub mod graph;
pub mod plant;
pub mod recorder;
pub mod ros;
pub mod scale;
pub mod sim;
