//! The controller node's settings table ([`capsule_args::controller_settings`], beside the
//! plant's) as flags ([`ControllerFlags`]; its ROS parameters are built from it by
//! [`crate::controller_params::start_table`]), and the start's check between settings.

use capsule_args::controller_settings::{
    CHAOS_GAIN, CONTROLLER, DIRECTION_GAIN, GAINS, GAIN_LIMIT,
};
use capsule_args::settings::Setting;
use capsule_controller::mode::ModeConfig;
use capsule_plant::number_text::short;
use capsule_ros_base::error::Result;
use capsule_ros_base::params::ParamTable;

use capsule_plant_node::node_settings::{SettingFlags, SettingsTable};

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
    const SETTINGS: &'static [Setting] = &GAINS;
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
