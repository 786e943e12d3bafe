//! The controller node's command line and what it builds (the node's ROS settings, its
//! options): `capsule_controller`'s, and the controller's in `capsule_container`.

use capsule_msgs::names::nodes;
use std::time::Duration;

use anyhow::Result;
use capsule_args::controller_settings::{
    ACTION_INTROSPECTION, DIAGNOSTICS, SCENE, STATUS_PERIOD_MS,
};
use capsule_args::{scene_file::SceneFile, settings::CHECK};
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
    // every flag of the node but the ROS ones is a row of its settings table
    // (capsule_args::controller_settings)
    #[command(flatten)]
    settings: ControllerFlags,
    #[command(flatten)]
    pub ros: RosArgs,
}

impl Cli {
    /// `--check`: check, say what would run, and exit.
    pub fn check(&self) -> bool {
        self.settings.switch(&CHECK)
    }
}

pub fn build(
    cli: &Cli,
    overrides: &[ros_args::Override],
) -> Result<(RosOptions, ControllerOptions)> {
    // what the controller takes from a scene: the physical scale, the drive and the gain
    let flags = &cli.settings;
    let scene = flags.text(&SCENE);
    let file = match scene.as_deref() {
        Some(path) => Some(SceneFile::read(std::path::Path::new(path))?),
        None => None,
    };
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::CONTROLLER)?;
    // the settings table's precedence: default, scene, flag; then -p / --params-file
    let (params, core) = controller_params::start(
        flags,
        file.as_ref(),
        scene.as_deref().unwrap_or_default(),
        settings.use_sim_time,
        overrides,
    )?;
    let action_introspection = flags
        .text(&ACTION_INTROSPECTION)
        .unwrap_or_default()
        .parse()
        .map_err(anyhow::Error::msg)?;
    Ok((
        settings,
        ControllerOptions {
            core,
            status_period: Duration::from_millis(flags.count(&STATUS_PERIOD_MS)),
            params,
            diagnostics: flags.switch(&DIAGNOSTICS),
            action_introspection,
        },
    ))
}
