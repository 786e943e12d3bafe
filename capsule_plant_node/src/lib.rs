//! The capsule's plant node, and what the nodes share, on the plumbing of `capsule_ros_base`.
//!
//! - [`plant`]: the plant node (lifecycle, pacing, hold, watchdog) around any
//!   [`capsule_hardware::CapsuleHardware`]; [`emergency_stop`]: its emergency-stop service and
//!   latched state; [`pause`]: a lock-step plant's pause; [`flag_service`]: the `SetBool`
//!   service both are; [`plant_params`]: its ROS
//!   parameters
//! - [`joint_commands`]: JointState commands as topic_based_ros2_control sends them
//! - [`command_gate`]: the plant's force limit and stamp horizon for commands
//! - [`views`]: standard-type views of the plant (joint_states, /tf, robot_description,
//!   /diagnostics)
//! - [`node_settings`]: a node's settings table as its flags and ROS parameters (both nodes)
//! - [`intra_process`]: state and force between nodes composed in one process
//! - [`recorder`]: the recorder node (every topic to one MCAP file; the plant's in-plant
//!   recording writes through it); [`take_each`]: taking every sample a reader holds

#![warn(missing_docs)]

pub mod action_readers;
pub mod command_gate;
pub mod emergency_stop;
pub mod flag_service;
pub mod intra_process;
pub mod joint_commands;
pub mod node_settings;
pub mod pause;
pub mod plant;
pub mod plant_params;
pub mod recorder;
pub mod take_each;
pub mod views;

// the plant's hardware interface, in a crate of its own (no DDS, no runtime); named here so
// the plant's modules say `crate::hardware`
use capsule_hardware as hardware;
