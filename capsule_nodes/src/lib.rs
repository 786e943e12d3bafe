//! The capsule's ROS 2 nodes (plant, controller, recorder, Foxglove bridge, and the client
//! tools), on the plumbing of `capsule_ros_base`.
//!
//! - [`command_feedback`]: whether the plant takes the controller's commands
//! - [`plant_identity`]: which plant the controller serves (restarts, a second plant)
//! - [`joint_commands`]: JointState commands as topic_based_ros2_control sends them
//! - [`command_gate`]: the plant's force limit and stamp horizon for commands
//! - [`client`]: a client of the graph (mode requests, demo measurement)
//! - [`controller`]: the controller node on DDS; [`controller_core`]: its decisions without
//!   DDS; [`controller_diagnostics`]: its `/diagnostics`; [`controller_params`]: its ROS
//!   parameters; [`controller_settings`]: its settings table
//! - [`node_settings`]: a node's settings table as its flags and ROS parameters
//! - [`plant`]: the plant node (lifecycle, pacing, hold, watchdog) around any
//!   [`capsule_hardware::CapsuleHardware`]; [`emergency_stop`]: its emergency-stop service and
//!   latched state
//! - [`recorder`]: the recorder node (every topic to one MCAP file)
//! - [`views`]: standard-type views of the plant (joint_states, /tf, robot_description, /diagnostics)
//! - [`foxglove_bridge`]: the graph live on a Foxglove WebSocket on loopback (`capsule_foxglove`)

#![warn(missing_docs)]

pub mod client;
pub mod command_feedback;
pub mod command_gate;
pub mod controller;
pub mod controller_core;
pub mod controller_diagnostics;
pub mod controller_params;
pub mod controller_settings;
pub mod emergency_stop;
pub mod foxglove_bridge;
pub mod intra_process;
pub mod joint_commands;
pub mod node_settings;
pub mod plant;
pub mod plant_identity;
pub mod plant_params;
pub mod recorder;
pub mod views;

// the plant's hardware interface, in a crate of its own (no DDS, no runtime); named here so
// the plant's modules say `crate::hardware`
use capsule_hardware as hardware;
