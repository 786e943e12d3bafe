//! The controller node's settings table (see [`crate::settings`]): each setting with its flag,
//! scene key, range, default and whether `ros2 param set` may change it on the running node.
//! Its flags and ROS parameters are made from it in `capsule_controller_node`.

use capsule_controller::{mode::ModeConfig, switch::SwitchConfig};

use crate::scale_settings as scale;
use crate::settings::{Kind, Setting};

/// Any finite number a gain or a physical constant given as a flag may reach in magnitude.
const MAX: f64 = crate::ranges::MAX_MAGNITUDE;

/// The scene to take the physical scale, drive and gain from.
pub const SCENE: Setting = Setting::new(
    "scene",
    "Scene TOML to take the physical scale, drive and gain from ([physical], [drive], \
     [control]); the whole scene is validated, as capsule_plant and `capsule simulate` do",
    Kind::Text,
)
.flag_only();
/// The status and watchdog period.
pub const STATUS_PERIOD_MS: Setting = Setting::new(
    "status_period_ms",
    "Status and watchdog period [ms]",
    Kind::Count {
        min: 1,
        max: crate::ranges::MAX_MILLIS,
    },
)
.flag_only()
.default(100.0);
/// /diagnostics.
pub const DIAGNOSTICS: Setting = Setting::new(
    "diagnostics",
    "publish /diagnostics (diagnostic_msgs/DiagnosticArray, 1 Hz: mode, gain, commands sent, \
     states ignored, plant seen, OK / WARN / ERROR)",
    Kind::Switch,
)
.flag_only()
.inverted();
/// The actions' service introspection (parsed by the node:
/// `capsule_ros_base::action::Introspection`).
pub const ACTION_INTROSPECTION: Setting = Setting::new(
    "action_introspection",
    "What the actions' services publish on their _service_event topics, as rcl's service \
     introspection: contents (goals and results: what a recording of the actions holds), \
     metadata (who asked when, no payload) or off",
    Kind::Choice(&["contents", "metadata", "off"]),
)
.flag_only();

/// Mode (set as a set_mode request taking effect now).
pub const MODE: Setting = Setting::new(
    "mode",
    "Controller mode: off, forward, backward, chaos-control or custom (any case, - or _; as \
     a set_mode request taking effect now) [default: custom with the scene's control.kp if it \
     is not 0, else off]",
    Kind::Text,
)
.flag()
.writable();
/// The gain in effect.
pub const GAIN: Setting = Setting::new(
    "gain",
    "Feedback gain k_p (non-dim; as in a set_mode request for the mode: FORWARD / BACKWARD \
     take the sign of the mode, 0 means the mode's default)",
    Kind::Finite,
)
.rule("|k_p| at most gain_limit")
.flag()
.writable();
/// |k_p| of FORWARD / BACKWARD when a request gives 0.
pub const DIRECTION_GAIN: Setting = Setting::new(
    "direction_gain",
    "|k_p| of FORWARD / BACKWARD when a request gives 0",
    Kind::Number { min: 0.0, max: MAX },
)
.rule("at most gain_limit")
.flag()
.writable()
.default(ModeConfig::DEFAULT.direction_gain);
/// k_p of CHAOS_CONTROL when a request gives 0.
pub const CHAOS_GAIN: Setting = Setting::new(
    "chaos_gain",
    "k_p of CHAOS_CONTROL when a request gives 0",
    Kind::Number {
        min: -MAX,
        max: MAX,
    },
)
.rule("|k_p| at most gain_limit")
.flag()
.writable()
.default(ModeConfig::DEFAULT.chaos_gain);
/// Largest |k_p|.
pub const GAIN_LIMIT: Setting = Setting::new(
    "gain_limit",
    "Largest |k_p| any mode accepts",
    Kind::Number { min: 0.0, max: MAX },
)
.flag()
.writable()
.default(ModeConfig::DEFAULT.gain_limit);
/// Drive amplitude (the scene's rule for `drive.alpha`: at most the plant's default force
/// limit, beyond which a drive would only ever be saturated).
pub const ALPHA: Setting = Setting::of_scene(
    "alpha",
    "Drive amplitude alpha = P_d / P_f (non-dim)",
    "drive.alpha",
)
.flag()
.writable();
/// Drive frequency (the scene's rule for `drive.omega`).
pub const OMEGA: Setting = Setting::of_scene(
    "omega",
    "Drive frequency omega = Omega / Omega0 (non-dim)",
    "drive.omega",
)
.flag()
.writable();
/// Seconds without state before the controller stops commanding.
pub const STATE_TIMEOUT_S: Setting = Setting::new(
    "state_timeout_s",
    "Seconds (steady clock) without a state sample before the controller stops commanding",
    Kind::Number {
        min: 1e-6,
        max: 1e6,
    },
)
.flag()
.default(0.5);
/// The orbit watch's recurrence tolerance: above zero, below the switch's reduction tolerance
/// (0.25), which must stay below the distance between the points of a real cycle.
pub const ORBIT_TOLERANCE: Setting = Setting::new(
    "orbit_tolerance",
    "Recurrence tolerance of the orbit watch on the Poincare section (non-dim; orbit_period and \
     the attractor switch): the simulator's exact states need 0.02; a prototype's noisy \
     positions about three times the velocity estimate's error (docs/hardware.md, `capsule \
     simulate --device` reports it)",
    Kind::Number {
        min: 1e-6,
        max: 0.2,
    },
)
.flag()
.default(SwitchConfig::DEFAULT.tol);
/// Physical scale: inner mass (from the scene's `[physical]` table, or its flag).
pub const M1_KG: Setting = scale::M1_KG.flag();
/// Physical scale: primary stiffness.
pub const K1_N_PER_M: Setting = scale::K1_N_PER_M.flag();
/// Physical scale: friction threshold.
pub const PF_N: Setting = scale::PF_N.flag();
/// Sim time from /clock (`--use-sim-time`, a ROS flag, or `-p use_sim_time:=true`).
pub const USE_SIM_TIME: Setting = Setting::new(
    "use_sim_time",
    "Take time from /clock (set at start: --use-sim-time or -p use_sim_time:=true)",
    Kind::Switch,
);

/// The controller's settings, in the order `--help` shows their flags.
pub const CONTROLLER: [Setting; 18] = [
    SCENE,
    crate::settings::CHECK,
    MODE,
    GAIN,
    DIRECTION_GAIN,
    CHAOS_GAIN,
    GAIN_LIMIT,
    ALPHA,
    OMEGA,
    STATE_TIMEOUT_S,
    ORBIT_TOLERANCE,
    M1_KG,
    K1_N_PER_M,
    PF_N,
    USE_SIM_TIME,
    STATUS_PERIOD_MS,
    DIAGNOSTICS,
    ACTION_INTROSPECTION,
];

/// The gain settings alone: what `capsule replay --check-controller` takes to re-drive the
/// controller as it was configured.
pub const GAINS: [Setting; 3] = [DIRECTION_GAIN, CHAOS_GAIN, GAIN_LIMIT];
