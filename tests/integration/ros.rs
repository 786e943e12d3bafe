//! The ROS 2 layer end to end: the node binaries, the launcher and a Cyclone DDS Python peer.
//!
//! Every test that starts a DDS process runs it inside its own loopback-only network namespace
//! (`tests/peers/netns_run.sh`: bounded in time, namespace deleted and processes killed at the
//! end, also on failure), so nothing here can reach a real network. Needs root, iproute2, the
//! node binaries (`cargo build --workspace` first) and, for the Python peer, `cyclonedds`:
//! `.ci/ros-setup.sh` installs what is missing.

mod harness;

mod actions;
mod colcon;
mod composed;
mod device;
mod example_controller;
mod example_plant;
mod fastdds;
mod fault_matrix;
mod faults;
mod foxglove;
mod identify;
mod interop;
mod joint_commands;
mod lifecycle;
mod lockstep;
mod params;
mod replies;
mod security;
mod switch;
mod views;
#[cfg(feature = "zenoh")]
mod zenoh;
