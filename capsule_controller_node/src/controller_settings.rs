//! The controller node's settings table (see [`capsule_args::settings`]): each setting with
//! its flag, scene key, range, default and whether `ros2 param set` may change it on the
//! running node. Its flags are [`ControllerFlags`]; its ROS parameters are built from it by
//! [`crate::controller_params::start_table`].

use capsule_args::settings::{Kind, Setting};
use capsule_controller::{mode::ModeConfig, switch::SwitchConfig};
use capsule_plant::number_text::short;
use capsule_ros_base::error::Result;
use capsule_ros_base::params::{names as shared, ParamTable};

use capsule_plant_node::node_settings::{SettingFlags, SettingsTable};

/// Any finite number a gain or a physical constant given as a flag may reach in magnitude.
const MAX: f64 = capsule_args::ranges::MAX_MAGNITUDE;

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
/// A physical scale constant: from the scene's `[physical]` table, or its flag.
const fn scale(name: &'static str, help: &'static str, key: &'static str) -> Setting {
    Setting::of_scene(name, help, key).flag()
}
/// Physical scale: inner mass.
pub const M1_KG: Setting = scale(
    shared::M1_KG,
    "Physical scale: inner mass m1 [kg]",
    "physical.m1_kg",
);
/// Physical scale: primary stiffness.
pub const K1_N_PER_M: Setting = scale(
    shared::K1_N_PER_M,
    "Physical scale: primary stiffness k1 [N/m]",
    "physical.k1_n_per_m",
);
/// Physical scale: friction threshold.
pub const PF_N: Setting = scale(
    shared::PF_N,
    "Physical scale: friction threshold P_f [N]",
    "physical.pf_n",
);
/// Sim time from /clock (`--use-sim-time`, a ROS flag, or `-p use_sim_time:=true`).
pub const USE_SIM_TIME: Setting = Setting::new(
    shared::USE_SIM_TIME,
    "Take time from /clock (set at start: --use-sim-time or -p use_sim_time:=true)",
    Kind::Switch,
);

/// The controller's settings, in the order `--help` shows their flags.
pub const CONTROLLER: [Setting; 13] = [
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
];

/// The controller's table.
#[derive(Debug, Clone)]
pub struct Controller;
impl SettingsTable for Controller {
    const SETTINGS: &'static [Setting] = &CONTROLLER;
}

/// The controller's flags made from its table.
pub type ControllerFlags = SettingFlags<Controller>;

/// The gain settings alone: what `capsule replay --check-controller` takes to re-drive the
/// controller as it was configured.
#[derive(Debug, Clone)]
pub struct Gains;
impl SettingsTable for Gains {
    const SETTINGS: &'static [Setting] = &[DIRECTION_GAIN, CHAOS_GAIN, GAIN_LIMIT];
    const PRECEDENCE_IN_HELP: bool = false;
}

/// The gain flags (the controller's, for `capsule replay`).
pub type GainFlags = SettingFlags<Gains>;

/// The mode configuration `table` holds, checked at start: that the defaults lie within the
/// limit (a rule between settings) is refused naming the flags.
pub fn start_config(table: &ParamTable) -> Result<ModeConfig> {
    let config = ModeConfig {
        direction_gain: table.double(DIRECTION_GAIN.name),
        chaos_gain: table.double(CHAOS_GAIN.name),
        gain_limit: table.double(GAIN_LIMIT.name),
    };
    config.validate().map_err(|e| {
        capsule_ros_base::error::invalid!(
            "--{} {}: {} (--gain-limit {})",
            e.name.replace('_', "-"),
            short(e.value),
            e.reason,
            short(config.gain_limit)
        )
    })?;
    Ok(config)
}

/// The validated configuration of the gain flags `flags` (defaults where not given).
pub fn gain_config(flags: &GainFlags) -> Result<ModeConfig> {
    let table = flags
        .start_table("", |_| None, |_| None)
        .map_err(|e| capsule_ros_base::error::invalid!("{e}"))?;
    start_config(&table)
}
