//! How the plant node runs: pacing and options.

use super::InPlantRecordOptions;
use std::time::Duration;

/// What a lock-step plant does with a sample nobody answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum OnSilence {
    /// Re-send and wait; end the run with an error when the controller is gone.
    #[default]
    Wait,
    /// After the command timeout, step at zero force (the run then depends on wall time).
    ZeroForce,
}

/// How the plant paces its steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Pacing {
    /// One sample per `1/rate` of wall time.
    Realtime,
    /// Each step waits for the command answering the last sample.
    Lockstep,
}

/// How the plant node runs.
#[derive(Debug, Clone)]
pub struct PlantOptions {
    /// Pacing.
    pub pacing: Pacing,
    /// Stop at this sim time \[s\] (`None`: run until a signal).
    pub until_s: Option<f64>,
    /// Lock-step: re-send an unanswered sample this often.
    pub retransmit: Duration,
    /// Lock-step: how long to wait for the very first command (and for the subscribers).
    pub startup_timeout: Duration,
    /// Lock-step: what an unanswered sample leads to (see [`OnSilence`]).
    pub on_silence: OnSilence,
    /// Lock-step, [`OnSilence::Wait`]: after this long without an answer the controller is
    /// taken as gone and the run ends with an error \[s\].
    pub lockstep_give_up_s: f64,
    /// Publish the first sample only once this many subscribers matched the state topic.
    pub wait_subscribers: usize,
    /// Publish /clock with every this many samples (1: every sample).
    pub clock_every: u64,
    /// Record the graph in this process (see `InPlantRecording`).
    pub record: Option<InPlantRecordOptions>,
    /// The ROS parameters served (see [`crate::plant_params`]).
    pub params: capsule_ros_base::params::ParamTable,
    /// Also take commands as JointState on [`capsule_msgs::names::topics::JOINT_COMMANDS`] (real-time pacing; see
    /// [`crate::joint_commands`]).
    pub joint_commands: bool,
    /// Configure and activate at once (otherwise unconfigured until the lifecycle's
    /// `change_state` asks).
    pub autostart: bool,
    /// Lock-step: start paused until `~/pause` resumes ([`crate::pause`]).
    pub start_paused: bool,
}
