//! The plant node's settings table (see [`crate::settings`]): every flag it takes, each with
//! its scene key, range and ROS parameter where it has them. The parameters are all read-only
//! once running (a running simulation does not change its scene, rate or pacing); `-p` /
//! `--params-file` set the numeric ones at start. The flags that are not parameters say how
//! the node runs (where the capsule is, until when, what it records); the views' switches are
//! in [`crate::view_settings`].

use crate::ranges;
use crate::scale_settings as scale;
use crate::settings::{Kind, Setting};
use crate::view_settings as views;

/// Scene file.
pub const SCENE: Setting = Setting::new(
    "scene",
    "Scene file (model, friction, initial state, physical scale, node rate and timeout)",
    Kind::Text,
)
.flag()
.required();
/// Where the capsule is (parsed by the node: `capsule_hardware::serial_driver::Source`).
pub const SOURCE: Setting = Setting::new(
    "source",
    "Where the capsule is: sim (the scene's capsule simulated exactly) or serial:PATH[,BAUD] \
     (a device speaking the capsule device protocol, docs/hardware.md; default 921600 baud; \
     `capsule emulate-device` is one on a pseudo-terminal)",
    Kind::Text,
)
.flag_only()
.value_name("sim|serial:PATH[,BAUD]")
.default_text("sim");
/// Serial source: the node's own travel limit.
pub const MAX_TRAVEL_M: Setting = Setting::new(
    "max_travel_m",
    "Serial source: zero the force while |x1 - x2| exceeds this [m] (the device's own travel \
     limit, if smaller, stands; not given: no limit of the node's)",
    Kind::Positive {
        max: ranges::MAX_SECONDS,
    },
)
.flag_only();
/// Serial source: commands logged, not sent.
pub const DRY_RUN: Setting = Setting::new(
    "dry_run",
    "Serial source: log the force commands instead of sending them (zero force goes out)",
    Kind::Switch,
)
.flag_only();
/// Pacing (parsed by the node: `capsule_plant_node::plant::Pacing`).
pub const PACING: Setting = Setting::new(
    "pacing",
    "realtime: one sample per 1/rate of wall time; lockstep: each step waits for the \
     controller's answer (reproducible, as fast as the loop allows)",
    Kind::Choice(&["realtime", "lockstep"]),
)
.flag();
/// Actuator force limit.
pub const MAX_FORCE_N: Setting = Setting::new(
    "max_force_n",
    "Actuator force limit [N]: larger commands are applied saturated at it, counted and logged \
     (not given: 100 P_f of the scene's [physical] scale)",
    Kind::Positive { max: 1e12 },
)
.flag_only();
/// Stop at this sim time.
pub const UNTIL_S: Setting = Setting::new(
    "until_s",
    "Stop at this sim time [s] (not given: run until Ctrl-C / SIGTERM)",
    Kind::Positive { max: 1e9 },
)
.flag_only();
/// Lock-step: re-send period.
pub const RETRANSMIT_MS: Setting = Setting::new(
    "retransmit_ms",
    "Lock-step: re-send an unanswered sample every this many ms",
    Kind::Count {
        min: 1,
        max: ranges::MAX_MILLIS,
    },
)
.flag_only()
.default(20.0);
/// Lock-step: the wait for the first command and for `--wait-subscribers`.
pub const STARTUP_TIMEOUT_S: Setting = Setting::new(
    "startup_timeout_s",
    "Lock-step: seconds to wait for the first command and for --wait-subscribers",
    Kind::Positive {
        max: ranges::MAX_SECONDS,
    },
)
.flag_only()
.default(30.0);
/// Lock-step: what an unanswered sample leads to (parsed by the node:
/// `capsule_plant_node::plant::OnSilence`).
pub const LOCKSTEP_ON_SILENCE: Setting = Setting::new(
    "lockstep_on_silence",
    "Lock-step: what an unanswered sample leads to. wait: re-send it while sim time stands \
     still, and end the run with an error once the controller is gone (it left the graph, or \
     no answer for --lockstep-give-up-s); zero-force: after --command-timeout-s step at zero \
     force (the run then depends on the wall clock: a loaded host or a lossy network changes it)",
    Kind::Choice(&["wait", "zero-force"]),
)
.flag_only();
/// Subscribers to wait for before the first sample.
pub const WAIT_SUBSCRIBERS: Setting = Setting::new(
    "wait_subscribers",
    "Publish the first sample once this many subscribers matched the state topic",
    Kind::Count {
        min: 0,
        max: ranges::MAX_SUBSCRIBERS,
    },
)
.flag_only()
.default(0.0);
/// In-process recording into a folder.
pub const RECORD_DIR: Setting = Setting::new(
    "record_dir",
    "Record the graph in this process to DIR/capsule_<scene>_<UTC time>.mcap (what the plant \
     publishes and receives, the controller's status and mode changes): the same file as \
     capsule_recorder writes, at a fraction of its CPU at high rates",
    Kind::Text,
)
.flag_only()
.value_name("DIR");
/// In-process recording into a file.
pub const RECORD_OUTPUT: Setting = Setting::new(
    "record_output",
    "Record in-process to exactly this file (must not exist; not with --record-dir)",
    Kind::Text,
)
.flag_only()
.value_name("FILE");
/// The controller the in-process recording follows (`capsule_msgs::names::nodes::CONTROLLER`).
pub const CONTROLLER_NODE: Setting = Setting::new(
    "controller_node",
    "Controller node whose status and service events the in-process recording takes",
    Kind::Text,
)
.flag_only()
.default_text("capsule_controller");
/// In-process recording: chunk period.
pub const FLUSH_MS: Setting = Setting::new(
    "flush_ms",
    "In-process recording: close the open chunk at least this often [ms]",
    Kind::Count {
        min: 1,
        max: ranges::MAX_MILLIS,
    },
)
.flag_only()
.default(250.0);
/// The run's summary.
pub const SUMMARY_JSON: Setting = Setting::new(
    "summary_json",
    "Write a JSON summary (loop statistics, last sample) to this file at the end",
    Kind::Text,
)
.flag_only();
/// Check and exit.
pub const CHECK: Setting = crate::settings::CHECK;
/// Lifecycle: start active or unconfigured.
pub const AUTOSTART: Setting = Setting::new(
    "autostart",
    "Configure and activate at once (true, the default: the node runs as it starts), or start \
     unconfigured and wait for the lifecycle (`ros2 lifecycle set /capsule_plant configure`, \
     then `activate`), as rclcpp_lifecycle's managed nodes do",
    Kind::Switch,
)
.flag_only()
.default(1.0);
/// Lock-step: start paused (`capsule_plant_node::pause`).
pub const START_PAUSED: Setting = Setting::new(
    "start_paused",
    "Lock-step, simulated plant: start paused (active, answered, but no step: sim time stands \
     still) until `~/pause` (std_srvs/srv/SetBool) is called with false",
    Kind::Switch,
)
.flag_only();
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
pub const PLANT: [Setting; 33] = [
    SCENE,
    SOURCE,
    MAX_TRAVEL_M,
    DRY_RUN,
    PACING,
    MAX_FORCE_N,
    UNTIL_S,
    RETRANSMIT_MS,
    STARTUP_TIMEOUT_S,
    LOCKSTEP_ON_SILENCE,
    WAIT_SUBSCRIBERS,
    RECORD_DIR,
    RECORD_OUTPUT,
    CONTROLLER_NODE,
    FLUSH_MS,
    SUMMARY_JSON,
    CHECK,
    RATE_HZ,
    COMMAND_TIMEOUT_S,
    LOCKSTEP_GIVE_UP_S,
    CLOCK_EVERY,
    JOINT_COMMANDS,
    AUTOSTART,
    START_PAUSED,
    views::JOINT_STATES,
    views::TF,
    views::ROBOT_DESCRIPTION,
    views::DIAGNOSTICS,
    views::RATE_HZ,
    USE_SIM_TIME,
    scale::M1_KG,
    scale::K1_N_PER_M,
    scale::PF_N,
];
