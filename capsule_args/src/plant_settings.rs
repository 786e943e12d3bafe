//! The plant node's settings table (see [`crate::settings`]): what it starts with, each with
//! its flag, scene key, range and ROS parameter. All read-only once running (a running
//! simulation does not change its scene, rate or pacing); `-p` / `--params-file` set the
//! numeric ones at start.

use crate::ranges;
use crate::scale_settings as scale;
use crate::settings::{Kind, Setting};

/// Scene file (`--scene`, declared by the binary: it is required).
pub const SCENE: Setting = Setting::new(
    "scene",
    "Scene file (model, friction, initial state, scale)",
    Kind::Text,
);
/// Pacing (`--pacing`, declared by the binary: its choices).
pub const PACING: Setting = Setting::new(
    "pacing",
    "realtime (one sample per 1/rate of wall time) or lockstep (each step waits for its command)",
    Kind::Text,
);
/// Sample rate ([`ranges::RATE_HZ`]).
pub const RATE_HZ: Setting = Setting::new(
    "rate_hz",
    "Sample rate (and control rate) [Hz]",
    Kind::Number {
        min: ranges::RATE_HZ.0,
        max: ranges::RATE_HZ.1,
    },
)
.flag()
.scene("node.rate_hz")
.default(1000.0);
/// After this long without a command the plant applies zero force.
pub const COMMAND_TIMEOUT_S: Setting = Setting::new(
    "command_timeout_s",
    "Seconds without a fresh command before zero force",
    Kind::Number {
        min: 1e-6,
        max: 1e6,
    },
)
.flag()
.scene("node.command_timeout_s")
.default(0.1);
/// Lock-step: after this long without an answer the controller is gone and the run ends.
pub const LOCKSTEP_GIVE_UP_S: Setting = Setting::new(
    "lockstep_give_up_s",
    "Lock-step: seconds of wall time without an answer to the current sample after which the \
     controller is taken as gone and the run ends with an error (no step is ever taken \
     without its answer, unless --lockstep-on-silence zero-force)",
    Kind::Number {
        min: 1e-3,
        max: 1e6,
    },
)
.flag()
.scene("node.lockstep_give_up_s")
.default(30.0);
/// /clock with every N-th sample.
pub const CLOCK_EVERY: Setting = Setting::new(
    "clock_every",
    "Publish /clock with every N-th sample (1 = every sample; larger saves CPU at high rates \
     at the cost of a coarser sim clock for use_sim_time nodes). /clock is sent only while it \
     has a subscriber; a recording always holds it",
    Kind::Count {
        min: 1,
        max: 1_000_000,
    },
)
.flag()
.default(1.0);
/// JointState commands on capsule/joint_commands.
pub const JOINT_COMMANDS: Setting = Setting::new(
    "joint_commands",
    "Also take commands as sensor_msgs/JointState on capsule/joint_commands (the effort of \
     inner_mass_joint is the actuator force [N], the joint found by name), as \
     topic_based_ros2_control sends them; checked as force commands are. Real-time pacing only",
    Kind::Switch,
)
.flag();

/// Sim time: the plant is the clock, so never from /clock (declared, as every node declares
/// it, and always false).
pub const USE_SIM_TIME: Setting = Setting::new(
    "use_sim_time",
    "the plant is the clock: its time is sim time by construction",
    Kind::Switch,
)
.rule("false");

/// The plant's settings, in the order `--help` shows their flags; the physical scale from the
/// scene only (no flag: the scene's capsule and its scale go together).
pub const PLANT: [Setting; 11] = [
    SCENE,
    PACING,
    RATE_HZ,
    COMMAND_TIMEOUT_S,
    LOCKSTEP_GIVE_UP_S,
    CLOCK_EVERY,
    JOINT_COMMANDS,
    USE_SIM_TIME,
    scale::M1_KG,
    scale::K1_N_PER_M,
    scale::PF_N,
];
