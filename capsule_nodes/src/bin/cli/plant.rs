//! The plant node's command line and what it builds (the node's ROS settings, its core around
//! the source, its options): `capsule_plant`'s, and the plant's in `capsule_container`.

use capsule_msgs::names::nodes;
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{bail, Result};
use capsule_args::plant_settings::{
    AUTOSTART, CHECK, CONTROLLER_NODE, DRY_RUN, FLUSH_MS, LOCKSTEP_ON_SILENCE, MAX_FORCE_N,
    MAX_TRAVEL_M, PACING, RECORD_DIR, RECORD_OUTPUT, RETRANSMIT_MS, SCENE, SOURCE,
    STARTUP_TIMEOUT_S, START_PAUSED, SUMMARY_JSON, UNTIL_S, WAIT_SUBSCRIBERS,
};
use capsule_args::{scene_file::SceneFile, settings::Setting, storage::StorageArgs};
use capsule_hardware::{
    serial_driver::{DeviceDriver, DriverOptions, Source},
    sim::SimulatedPlant,
    CapsuleHardware,
};
use capsule_plant::{Method, Simulator};
use capsule_plant_node::{
    plant::{InPlantRecordOptions, Pacing, PlantCore, PlantOptions},
    plant_params::{self, PlantFlags},
    recorder,
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
    // every flag of the node but the storage and ROS ones is a row of its settings table
    // (capsule_args::plant_settings): its help, range, default and parameter from the row
    #[command(flatten)]
    settings: PlantFlags,
    /// In-process recording: compression and splitting
    #[command(flatten)]
    storage: StorageArgs,
    #[command(flatten)]
    pub ros: RosArgs,
}

/// The plant node's core around the source chosen with `--source`.
pub type Plant = PlantCore<Box<dyn CapsuleHardware>>;

impl Cli {
    /// The source as `--check` prints it.
    pub fn source_label(&self) -> String {
        match self.source() {
            Ok(Source::Sim) => "simulated".to_string(),
            Ok(Source::Serial { path, baud }) => format!(
                "serial {} at {baud} baud{}",
                path.display(),
                if self.settings.switch(&DRY_RUN) {
                    " (dry run)"
                } else {
                    ""
                }
            ),
            Err(e) => e.to_string(),
        }
    }

    /// `--check`: check, say what would run, and exit.
    pub fn check(&self) -> bool {
        self.settings.switch(&CHECK)
    }

    /// `--summary-json`.
    pub fn summary_json(&self) -> Option<String> {
        self.settings.text(&SUMMARY_JSON)
    }

    /// `--scene`.
    fn scene(&self) -> String {
        self.settings.text(&SCENE).unwrap_or_default()
    }

    /// `--source`, parsed.
    fn source(&self) -> Result<Source> {
        let text = self.settings.text(&SOURCE).unwrap_or_default();
        text.parse()
            .map_err(|e| anyhow::anyhow!("--source {text:?}: {e}"))
    }

    /// A path flag's value.
    fn path(&self, s: &Setting) -> Option<PathBuf> {
        self.settings.text(s).map(PathBuf::from)
    }

    /// A duration flag's value in milliseconds.
    fn millis(&self, s: &Setting) -> Duration {
        Duration::from_millis(self.settings.count(s))
    }
}

/// Most fixed-method steps the plant takes per published sample: beyond, one sample would take
/// longer than a realtime loop can afford (and a loop stuck in one sample would not see Ctrl-C).
const MAX_FIXED_STEPS_PER_SAMPLE: f64 = 1e6;

fn record_options(cli: &Cli, scene: &SceneFile) -> Result<Option<InPlantRecordOptions>> {
    let (dir, file) = match (cli.path(&RECORD_DIR), cli.path(&RECORD_OUTPUT)) {
        (None, None) => return Ok(None),
        (Some(_), Some(_)) => {
            bail!("--record-dir and --record-output: give one (a folder or a file)")
        }
        both => both,
    };
    let scene = scene.record();
    let output = recorder::output_path(
        dir.as_deref().unwrap_or(std::path::Path::new("runs")),
        file.as_deref(),
        Some(&scene),
    )?;
    Ok(Some(InPlantRecordOptions {
        output,
        scene: Some(scene),
        controller_node: cli.settings.text(&CONTROLLER_NODE).unwrap_or_default(),
        flush_period: cli.millis(&FLUSH_MS),
        bag: cli.storage.options(),
    }))
}

pub fn build(
    cli: &Cli,
    overrides: &[ros_args::Override],
) -> Result<(RosOptions, Plant, PlantOptions)> {
    let flags = &cli.settings;
    let file = SceneFile::read(std::path::Path::new(&cli.scene()))?;
    let scene = &file.scene;
    let source = cli.source()?;
    if source == Source::Sim && (flags.switch(&DRY_RUN) || flags.given(MAX_TRAVEL_M.name).is_some())
    {
        bail!("--dry-run and --max-travel-m are for --source serial:PATH (a simulated capsule has no device to spare)");
    }
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::PLANT)?;
    // the settings table's precedence: default, the scene's [node], flag; then -p /
    // --params-file over the parameters
    let fixed = plant_params::Fixed::of(flags, &file);
    let mut params = plant_params::start_table(flags, &file).map_err(anyhow::Error::msg)?;
    ros_args::apply_overrides(&mut params, overrides, capsule_ros_base::params::no_rules)?;
    let run = plant_params::overridable(&params, &fixed).map_err(anyhow::Error::msg)?;
    let pacing: Pacing = flags.choice(&PACING).map_err(anyhow::Error::msg)?;
    if run.joint_commands && pacing == Pacing::Lockstep {
        bail!("--joint-commands (or -p joint_commands:=true) with --pacing lockstep: a JointState command answers no particular sample (topic_based_ros2_control sends at its own rate); use --pacing realtime");
    }
    let start_paused = flags.switch(&START_PAUSED);
    if start_paused && (pacing != Pacing::Lockstep || source != Source::Sim) {
        bail!("--start-paused holds a simulated plant in lock-step (--source sim --pacing lockstep): a real-time plant keeps wall time, and a device its own");
    }
    check_fixed_steps(cli, scene, run.rate_hz)?;
    let max_force_n = flags.number(&MAX_FORCE_N).unwrap_or(
        capsule_plant_node::command_gate::DEFAULT_MAX_FORCE_PF * scene.physical.force_n(),
    );
    let hardware = hardware(cli, &source, scene, run.rate_hz, max_force_n)?;
    let core = PlantCore::new(hardware, scene.physical, run.rate_hz, run.command_timeout_s)
        .with_max_force_n(max_force_n);
    let opts = PlantOptions {
        pacing,
        until_s: flags.number(&UNTIL_S),
        retransmit: cli.millis(&RETRANSMIT_MS),
        startup_timeout: Duration::from_secs_f64(
            flags.number(&STARTUP_TIMEOUT_S).unwrap_or_default(),
        ),
        on_silence: flags
            .choice(&LOCKSTEP_ON_SILENCE)
            .map_err(anyhow::Error::msg)?,
        lockstep_give_up_s: run.lockstep_give_up_s,
        wait_subscribers: usize::try_from(flags.count(&WAIT_SUBSCRIBERS)).unwrap_or(usize::MAX),
        clock_every: run.clock_every,
        record: record_options(cli, &file)?,
        params,
        joint_commands: run.joint_commands,
        autostart: flags.switch(&AUTOSTART),
        start_paused,
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
            cli.scene(),
            scene.solver.step
        );
    }
    Ok(())
}

/// The hardware `--source` names: the scene's simulator (checked here, built again at each
/// configure) or the device on the line.
fn hardware(
    cli: &Cli,
    source: &Source,
    scene: &capsule_plant::scene::Scene,
    rate_hz: f64,
    max_force_n: f64,
) -> Result<Box<dyn CapsuleHardware>> {
    Ok(match source {
        Source::Sim => {
            let (model, s0, solver) = (scene.model(), scene.initial_state(), scene.solver());
            let name = cli.scene();
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
            max_travel_m: cli.settings.number(&MAX_TRAVEL_M).unwrap_or(f64::INFINITY),
            gap_m: scene.model.capsule.delta * scene.physical.length_m(),
            dry_run: cli.settings.switch(&DRY_RUN),
        })),
    })
}
