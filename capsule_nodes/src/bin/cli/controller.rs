//! The controller node's command line and what it builds (the node's ROS settings, its
//! options): `capsule_controller`'s, and the controller's in `capsule_container`.

use capsule_msgs::names::nodes;
use std::time::Duration;

use anyhow::Result;
use capsule_args::{ranges, scene_file::SceneFile};
use capsule_controller_node::{
    controller::ControllerOptions, controller_params, controller_settings::ControllerFlags,
};
use capsule_ros_base::{
    ros_args,
    ros_options::{RosArgs, RosEnv, RosOptions},
};
use clap::Parser;

/// Drives the capsule's inner mass with the paper's harmonic force plus position feedback
/// u = k_p |x2 - x1| (Liu et al. 2014, eq. 2), from the state on capsule/state to commands on
/// capsule/actuator_force; serves ~/set_mode and publishes ~/status. It knows nothing of the
/// simulator: give it the scene (for the physical scale, drive and gain) or the values as flags.
#[derive(Debug, Parser)]
#[command(name = "capsule_controller", version, allow_negative_numbers = true)]
pub struct Cli {
    /// Scene TOML to take the physical scale, drive and gain from ([physical], [drive], [control]);
    /// the whole scene is validated, as capsule_plant and `capsule simulate` do
    #[arg(long)]
    scene: Option<String>,
    /// The controller's settings (capsule_controller_node::controller_settings)
    #[command(flatten)]
    settings: ControllerFlags,
    /// Check the scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    pub check: bool,
    /// Status and watchdog period [ms], 1 to 60000
    #[arg(long, default_value_t = 100, value_parser = ranges::millis())]
    status_period_ms: u64,
    /// Do not publish /diagnostics (diagnostic_msgs/DiagnosticArray, 1 Hz: mode, gain,
    /// commands sent, states ignored, plant seen, OK / WARN / ERROR)
    #[arg(long)]
    no_diagnostics: bool,
    #[command(flatten)]
    pub ros: RosArgs,
}

pub fn build(
    cli: &Cli,
    overrides: &[ros_args::Override],
) -> Result<(RosOptions, ControllerOptions)> {
    // what the controller takes from a scene: the physical scale, the drive and the gain
    let file = match cli.scene.as_deref() {
        Some(path) => Some(SceneFile::read(std::path::Path::new(path))?),
        None => None,
    };
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::CONTROLLER)?;
    // the settings table's precedence: default, scene, flag; then -p / --params-file
    let (params, core) = controller_params::start(
        &cli.settings,
        file.as_ref(),
        cli.scene.as_deref().unwrap_or_default(),
        settings.use_sim_time,
        overrides,
    )?;
    Ok((
        settings,
        ControllerOptions {
            core,
            status_period: Duration::from_millis(cli.status_period_ms),
            params,
            diagnostics: !cli.no_diagnostics,
        },
    ))
}
