//! The capsule's controller node, on the plumbing of `capsule_ros_base` and what the nodes
//! share (`capsule_plant_node`).
//!
//! - [`controller`]: the controller node on DDS, in the phases of its life;
//!   `controller_endpoints`: its DDS side; `controller_handlers`: what it does with each input;
//!   [`controller_core`]: its decisions without DDS; [`controller_diagnostics`]: its `/diagnostics`; [`controller_params`]: its ROS
//!   parameters; [`controller_settings`]: its settings table
//! - [`controller_actions`]: its actions (Move, SwitchAttractor) on DDS
//! - `controller_options`: how it is set up besides its ROS settings
//! - `controller_zenoh` (feature `zenoh`): its core interface on Zenoh
//! - [`command_feedback`]: whether the plant takes the controller's commands
//! - [`plant_identity`]: which plant the controller serves (restarts, a second plant)
//! - [`plant_lifecycle`]: the plant's lifecycle state, followed

#![warn(missing_docs)]

pub mod command_feedback;
pub mod controller;
pub mod controller_actions;
pub mod controller_core;
pub mod controller_diagnostics;
mod controller_endpoints;
mod controller_handlers;
mod controller_options;
pub mod controller_params;
pub mod controller_settings;
#[cfg(feature = "zenoh")]
mod controller_zenoh;
pub mod plant_identity;
pub mod plant_lifecycle;
