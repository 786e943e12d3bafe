//! The plant node's command line and what it builds (the node's ROS settings, its core around
//! the source, its options): `capsule_plant`'s, and the plant's in `capsule_container`.

use capsule_msgs::names::nodes;
use std::time::Duration;

use anyhow::{bail, Result};
use capsule_args::{ranges, scene_file::SceneFile, storage::StorageArgs};
use capsule_hardware::{
    serial_driver::{DeviceDriver, DriverOptions, Source},
    sim::SimulatedPlant,
    CapsuleHardware,
};
use capsule_plant::{Method, Simulator};
use capsule_plant_node::{
    plant::{InPlantRecordOptions, OnSilence, Pacing, PlantCore, PlantOptions},
    plant_params::{self, PlantFlags},
    recorder, views,
};
use capsule_ros_base::{
    ros_args,
    ros_options::{RosArgs, RosEnv, RosOptions},
};
use clap::Parser;

/// Simulates the capsule of a scene exactly (or drives a real one on a serial line) and serves
/// it as a capsule driver: state on capsule/state at the scene's rate (SI units through the
/// scene's [physical] scale), force commands from capsule/actuator_force (held between samples;
/// non-finite or late ones refused; zero force once they go stale), and sim time on /clock.
#[derive(Debug, Parser)]
#[command(name = "capsule_plant", version, allow_negative_numbers = true)]
pub struct Cli {
    /// Scene TOML (model, friction, initial state, physical scale, node rate and timeout)
    #[arg(long)]
    scene: String,
    /// Where the capsule is: sim (the scene's capsule simulated exactly) or serial:PATH[,BAUD]
    /// (a device speaking the capsule device protocol, docs/hardware.md; default 921600 baud;
    /// `capsule emulate-device` is one on a pseudo-terminal)
    #[arg(long, default_value = "sim", value_name = "sim|serial:PATH[,BAUD]")]
    source: Source,
    /// Serial source: zero the force while |x1 - x2| exceeds this [m], (0, 1e6] (the device's
    /// own travel limit, if smaller, stands) [default: no limit of the node's]
    #[arg(long, value_parser = ranges::positive(ranges::MAX_SECONDS))]
    max_travel_m: Option<f64>,
    /// Serial source: log the force commands instead of sending them (zero force goes out)
    #[arg(long)]
    dry_run: bool,
    /// realtime: one sample per 1/rate of wall time; lockstep: each step waits for the
    /// controller's answer (reproducible, as fast as the loop allows)
    #[arg(long, value_enum, default_value = "realtime")]
    pub pacing: Pacing,
    /// Actuator force limit [N], (0, 1e12]: larger commands are applied saturated at it,
    /// counted and logged [default: 100 P_f of the scene's [physical] scale]
    #[arg(long, value_parser = ranges::positive(1e12))]
    max_force_n: Option<f64>,
    /// Stop at this sim time [s], (0, 1e9] (default: run until Ctrl-C / SIGTERM)
    #[arg(long, value_parser = ranges::positive(1e9))]
    pub until_s: Option<f64>,
    /// Lock-step: re-send an unanswered sample every this many ms, 1 to 60000
    #[arg(long, default_value_t = 20, value_parser = ranges::millis())]
    retransmit_ms: u64,
    /// Lock-step: seconds to wait for the first command and for --wait-subscribers, (0, 1e6]
    #[arg(long, default_value_t = 30.0, value_parser = ranges::positive(ranges::MAX_SECONDS))]
    startup_timeout_s: f64,
    /// Lock-step: what an unanswered sample leads to. wait: re-send it while sim time stands
    /// still, and end the run with an error once the controller is gone (it left the graph, or
    /// no answer for --lockstep-give-up-s); zero-force: after --command-timeout-s step at zero
    /// force (the run then depends on the wall clock: a loaded host or a lossy network changes it)
    #[arg(long, value_enum, default_value = "wait")]
    lockstep_on_silence: OnSilence,
    /// Publish the first sample once this many subscribers matched the state topic, 0 to 1000
    #[arg(long, default_value_t = 0, value_parser = ranges::count_usize(0, ranges::MAX_SUBSCRIBERS as usize))]
    wait_subscribers: usize,
    /// Record the graph in this process to DIR/capsule_<scene>_<UTC time>.mcap (what the plant
    /// publishes and receives, the controller's status and mode changes): the same file as
    /// capsule_recorder writes, at a fraction of its CPU at high rates
    #[arg(long, value_name = "DIR")]
    record_dir: Option<std::path::PathBuf>,
    /// Record in-process to exactly this file (must not exist)
    #[arg(long, value_name = "FILE", conflicts_with = "record_dir")]
    record_output: Option<std::path::PathBuf>,
    /// Controller node whose status and service events the in-process recording takes
    #[arg(long, default_value = nodes::CONTROLLER)]
    controller_node: String,
    /// In-process recording: close the open chunk at least this often [ms], 1 to 60000
    #[arg(long, default_value_t = 250, value_parser = ranges::millis())]
    flush_ms: u64,
    /// In-process recording: compression and splitting
    #[command(flatten)]
    storage: StorageArgs,
    /// Write a JSON summary (loop statistics, last sample) to this file at the end
    #[arg(long)]
    pub summary_json: Option<String>,
    /// Check the scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    pub check: bool,
    // the plant's settings table (capsule_args::plant_settings): --rate-hz, --command-timeout-s,
    // --lockstep-give-up-s, --clock-every, --joint-commands
    #[command(flatten)]
    settings: PlantFlags,
    /// Configure and activate at once (true, the default: the node runs as it starts), or
    /// start unconfigured and wait for the lifecycle (`ros2 lifecycle set /capsule_plant
    /// configure`, then `activate`), as rclcpp_lifecycle's managed nodes do
    #[arg(long, default_value_t = true, num_args = 0..=1, default_missing_value = "true",
          value_name = "BOOL", action = clap::ArgAction::Set)]
    autostart: bool,
    #[command(flatten)]
    views: views::ViewArgs,
    #[command(flatten)]
    pub ros: RosArgs,
}

/// The plant node's core around the source chosen with `--source`.
pub type Plant = PlantCore<Box<dyn CapsuleHardware>>;

impl Cli {
    /// The source as `--check` prints it.
    pub fn source_label(&self) -> String {
        match &self.source {
            Source::Sim => "simulated".to_string(),
            Source::Serial { path, baud } => format!(
                "serial {} at {baud} baud{}",
                path.display(),
                if self.dry_run { " (dry run)" } else { "" }
            ),
        }
    }
}

/// Most fixed-method steps the plant takes per published sample: beyond, one sample would take
/// longer than a realtime loop can afford (and a loop stuck in one sample would not see Ctrl-C).
const MAX_FIXED_STEPS_PER_SAMPLE: f64 = 1e6;

fn record_options(cli: &Cli, scene: &SceneFile) -> Result<Option<InPlantRecordOptions>> {
    if cli.record_dir.is_none() && cli.record_output.is_none() {
        return Ok(None);
    }
    let scene = scene.record();
    let output = recorder::output_path(
        cli.record_dir
            .as_deref()
            .unwrap_or(std::path::Path::new("runs")),
        cli.record_output.as_deref(),
        Some(&scene),
    )?;
    Ok(Some(InPlantRecordOptions {
        output,
        scene: Some(scene),
        controller_node: cli.controller_node.clone(),
        flush_period: Duration::from_millis(cli.flush_ms),
        bag: cli.storage.options(),
    }))
}

pub fn build(
    cli: &Cli,
    overrides: &[ros_args::Override],
) -> Result<(RosOptions, Plant, PlantOptions)> {
    let file = SceneFile::read(std::path::Path::new(&cli.scene))?;
    let scene = &file.scene;
    if cli.source == Source::Sim && (cli.dry_run || cli.max_travel_m.is_some()) {
        bail!("--dry-run and --max-travel-m are for --source serial:PATH (a simulated capsule has no device to spare)");
    }
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::PLANT)?;
    // the settings table's precedence: default, the scene's [node], flag; then -p /
    // --params-file over the parameters
    let fixed = plant_params::Fixed {
        scene: cli.scene.clone(),
        pacing: format!("{:?}", cli.pacing).to_ascii_lowercase(),
        scale: (
            scene.physical.m1_kg,
            scene.physical.k1_n_per_m,
            scene.physical.pf_n,
        ),
    };
    let params =
        plant_params::start_table(&cli.settings, &file, &fixed).map_err(anyhow::Error::msg)?;
    let mut params = cli.views.declare(params);
    ros_args::apply_overrides(&mut params, overrides, capsule_ros_base::params::no_rules)?;
    let run = plant_params::overridable(&params, &fixed).map_err(anyhow::Error::msg)?;
    if run.joint_commands && cli.pacing == Pacing::Lockstep {
        bail!("--joint-commands (or -p joint_commands:=true) with --pacing lockstep: a JointState command answers no particular sample (topic_based_ros2_control sends at its own rate); use --pacing realtime");
    }
    check_fixed_steps(cli, scene, run.rate_hz)?;
    let max_force_n = cli.max_force_n.unwrap_or(
        capsule_plant_node::command_gate::DEFAULT_MAX_FORCE_PF * scene.physical.force_n(),
    );
    let source = source(cli, scene, run.rate_hz, max_force_n)?;
    let core = PlantCore::new(source, scene.physical, run.rate_hz, run.command_timeout_s)
        .with_max_force_n(max_force_n);
    let opts = PlantOptions {
        pacing: cli.pacing,
        until_s: cli.until_s,
        retransmit: Duration::from_millis(cli.retransmit_ms),
        startup_timeout: Duration::from_secs_f64(cli.startup_timeout_s),
        on_silence: cli.lockstep_on_silence,
        lockstep_give_up_s: run.lockstep_give_up_s,
        wait_subscribers: cli.wait_subscribers,
        clock_every: run.clock_every,
        record: record_options(cli, &file)?,
        params,
        joint_commands: run.joint_commands,
        autostart: cli.autostart,
    };
    Ok((settings, core, opts))
}

/// Refuses a fixed-step scene that would take more steps per sample than a loop affords.
fn check_fixed_steps(cli: &Cli, scene: &capsule_plant::scene::Scene, rate: f64) -> Result<()> {
    if scene.solver.method != Method::Fixed {
        return Ok(());
    }
    let per_sample = 1.0 / rate / scene.physical.time_s() / scene.solver.step;
    if per_sample > MAX_FIXED_STEPS_PER_SAMPLE {
        bail!(
            "{}: solver.step = {:e}: {per_sample:.3e} fixed steps per sample at {rate} Hz, more \
             than the plant's limit of {MAX_FIXED_STEPS_PER_SAMPLE:e}: raise the step or the rate",
            cli.scene,
            scene.solver.step
        );
    }
    Ok(())
}

/// The hardware `--source` names: the scene's simulator (checked here, built again at each
/// configure) or the device on the line.
fn source(
    cli: &Cli,
    scene: &capsule_plant::scene::Scene,
    rate_hz: f64,
    max_force_n: f64,
) -> Result<Box<dyn CapsuleHardware>> {
    Ok(match &cli.source {
        Source::Sim => {
            let (model, s0, solver) = (scene.model(), scene.initial_state(), scene.solver());
            let name = cli.scene.clone();
            let build = move || {
                Simulator::new(model, s0, 0.0, solver)
                    .map_err(|e| format!("{name}: cannot set up the simulation: {e}"))
            };
            build().map_err(anyhow::Error::msg)?;
            Box::new(SimulatedPlant::new(
                Box::new(build),
                scene.physical,
                rate_hz,
            ))
        }
        Source::Serial { path, baud } => Box::new(DeviceDriver::new(DriverOptions {
            path: path.clone(),
            baud: *baud,
            rate_hz,
            max_force_n,
            max_travel_m: cli.max_travel_m.unwrap_or(f64::INFINITY),
            gap_m: scene.model.capsule.delta * scene.physical.length_m(),
            dry_run: cli.dry_run,
        })),
    })
}
