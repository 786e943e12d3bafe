//! The plant node: a simulated capsule behind the same topics a real capsule driver would use.
//!
//! [`PlantCore`] is the node's logic without DDS (unit-tested here against a stand-in model):
//! sampling at a fixed rate, the zero-order hold of the last accepted command, command
//! validation (non-finite refused and counted, older-than-accepted refused: a late command
//! never rewinds time), the stale-command watchdog (zero force after the timeout, said in the
//! log and in `CapsuleState.command_stale`), SI conversion through the scene's physical scale
//! ([`PhysicalScale`](capsule_plant::scene::PhysicalScale)), and
//! loop statistics (command latency, steps without an answer). [`run`] wires it to ROS in one of
//! two pacings:
//!
//! - **real time**: sample `k` is published at `start + k / rate` (steady clock, on one
//!   thread that sleeps, takes the commands received meanwhile and steps); whatever command is
//!   held at the next sample drives the next step;
//! - **lock-step**: sample `k` is published and the plant waits for the command that answers
//!   seq `k` (re-sending the sample every `retransmit` until it comes), then integrates one step
//!   with it. The run is then a function of the scene and the controller only: reproducible bit
//!   for bit, as fast as the loop allows. No step is taken without its answer: when the
//!   controller is gone (it left the graph, or no answer came for `lockstep_give_up_s`) the run
//!   ends with an error (`silence`; `--lockstep-on-silence zero-force` asks for the old zero-force
//!   step after the command timeout instead).
//!
//! Time on the wire is simulation time (starting at 0), also published on `/clock` while anyone
//! subscribes to it (a write without readers still costs DDS's thread a wake-up per sample).
//!
//! The node in parts: `plant_core` (the logic, unit-tested against a mock hardware), `stats`
//! (loop statistics and the summary), `options`, `recording` (in-plant MCAP), `endpoints` (the
//! DDS endpoints), `node` ([`run`]: build, wait for the graph, run the loop, finish),
//! `loop_control` (what reaches the loop's thread), `simulator_loop` (the simulator's two
//! loops), `device_loop` (the loop of a device, which paces itself), `silence` (what an unanswered lock-step
//! sample leads to), [`lifecycle`] (the managed node's state
//! machine), `lifecycle_services` (its services) and `zenoh_loop` (the plant on Zenoh, feature
//! `zenoh`).

mod device_loop;
mod endpoints;
pub mod lifecycle;
mod lifecycle_services;
mod loop_control;
mod node;
mod options;
mod plant_core;
mod recording;
mod silence;
mod simulator_loop;
mod stats;
#[cfg(feature = "zenoh")]
mod zenoh_loop;

pub use capsule_hardware::SourceHealth;
pub use node::{run, run_in};
pub use options::{OnSilence, Pacing, PlantOptions};
pub use plant_core::{CommandOutcome, PlantCore};
pub use recording::{InPlantRecordOptions, InPlantRecording};
pub use stats::{summary_json, DdsCopyStats, LoopStats};
