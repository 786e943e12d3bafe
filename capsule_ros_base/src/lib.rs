//! The ROS 2 plumbing every capsule node shares, on ros2-client and RustDDS; the nodes themselves
//! are in `capsule_nodes`.
//!
//! - [`ros_options`]: the ROS options every node takes, its flags over the environment
//!   conventions; [`naming`]: names expanded and remapped; [`participant`]: the (loopback-only)
//!   DDS participant and the node; [`endpoints`]: topics, subscriptions, servers; [`qos`]: their
//!   QoS; [`types`]: the interfaces' type names
//! - [`node_main`]: a node binary's `main` (logging, `--check`, the runtime, the exit status);
//!   [`signals`]: SIGINT and SIGTERM
//! - [`ros_args`]: the `--ros-args` habits (parameters, params files, names, remaps, enclave)
//! - [`security`]: SROS2's `ROS_SECURITY_*` conventions and enclaves (DDS Security)
//! - [`graph`], [`clock`]: matched endpoints and ROS time for the loop nodes (instead of
//!   ros2-client's spinner)
//! - [`node_life`]: a loop node's life in phases (build, wait for the graph, run the loop,
//!   finish), the skeleton the plant and the controller share
//! - [`conflicts`]: a second plant or controller, or a foreign type, on our topics
//! - [`params`], [`param_services`]: ROS parameters (a table and its rcl_interfaces services)
//! - [`ports`]: the participant's RTPS ports, and the guard against losing its user port
//! - [`affinity`]: pinning a node's threads to chosen CPUs (`--cpu-affinity`)
//! - [`service`]: service servers whose answers wait for the client's reply reader;
//!   [`node_on`]: a server or a publisher on either middleware, for logic written once
//! - [`action`], [`action_goals`]: action servers as rcl_action serves them (status topic,
//!   `get_result`, cancel policy); `action_zenoh` (feature `zenoh`): the same on Zenoh
//! - [`middleware`]: DDS or Zenoh, as `RMW_IMPLEMENTATION` chooses; `zenoh_session` (feature
//!   `zenoh`): the Zenoh session as rmw_zenoh_cpp opens its own, and the type hashes it announces
//! - [`error`]: the nodes' error, [`error::NodeError`]

#![warn(missing_docs)]

pub mod action;
pub mod action_goals;
#[cfg(feature = "zenoh")]
pub mod action_zenoh;
pub mod affinity;
pub mod clock;
pub mod conflicts;
pub mod endpoints;
pub mod error;
pub mod graph;
pub mod middleware;
pub mod naming;
pub mod node_life;
pub mod node_main;
pub mod node_on;
pub mod param_services;
pub mod params;
pub mod participant;
pub mod ports;
pub mod qos;
pub mod ros_args;
pub mod ros_options;
pub mod security;
pub mod service;
pub mod signals;
pub mod types;
#[cfg(feature = "zenoh")]
pub mod zenoh_session;
