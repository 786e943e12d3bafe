//! The capsule's ROS 2 layer: the plant and controller nodes (ros2-client on RustDDS).
//!
//! - [`affinity`]: pinning a node's threads to chosen CPUs (`--cpu-affinity`)
//! - [`ros`]: environment conventions, names and remapping, QoS, the (loopback-only) participant
//! - [`ros_args`]: the `--ros-args` habits (parameters, params files, names, remaps)
//! - [`graph`]: matched endpoints and ROS time for the loop nodes (instead of ros2-client's spinner)
//! - [`latency`]: loop latency percentiles in constant memory
//! - [`command_feedback`]: whether the plant takes the controller's commands
//! - [`plant_identity`]: which plant the controller serves (restarts, a second plant)
//! - [`conflicts`]: a second plant or controller, or a foreign type, on our topics
//! - [`joint_commands`]: JointState commands as topic_based_ros2_control sends them
//! - [`command_gate`]: the plant's force limit and stamp horizon for commands
//! - [`throttle`]: rate-limited logging of per-sample events
//! - [`client`]: a client of the graph (mode requests, demo measurement)
//! - [`controller`]: the controller node; [`controller_diagnostics`]: its `/diagnostics`
//! - [`params`], [`param_services`]: ROS parameters (a table and its rcl_interfaces services);
//!   [`controller_params`]: the controller's
//! - [`plant`]: the plant node (pacing, hold, watchdog) around any [`plant::PlantSim`]
//! - [`recorder`]: the recorder node (every topic to one MCAP file)
//! - [`views`]: standard-type views of the plant (joint_states, /tf, robot_description, /diagnostics)
//! - [`foxglove_bridge`]: the graph live on a Foxglove WebSocket on loopback (`capsule_foxglove`)
//! - [`error`]: the library's error, [`error::NodeError`]
//! - [`sim`]: [`plant::PlantSim`] for the simulator of `capsule_plant` (any method)

#![warn(missing_docs)]

pub mod affinity;
pub mod client;
pub mod command_feedback;
pub mod command_gate;
pub mod conflicts;
pub mod controller;
pub mod controller_diagnostics;
pub mod controller_params;
pub mod error;
pub mod foxglove_bridge;
pub mod graph;
pub mod joint_commands;
pub mod latency;
pub mod param_services;
pub mod params;
pub mod plant;
pub mod plant_identity;
pub mod plant_params;
pub mod recorder;
pub mod ros;
pub mod ros_args;
pub mod sim;
pub mod throttle;
pub mod views;
