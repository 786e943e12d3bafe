//! `capsule_controller`: the ROS 2 controller node of the vibro-impact capsule.

use capsule_msgs::names::nodes;
use capsule_plant::scene::PhysicalScale;
use std::time::Duration;

use anyhow::{bail, Context as _, Result};
use capsule_args::{ranges, scene_file::SceneFile};
use capsule_controller::mode::Mode;
use capsule_controller::switch::SwitchConfig;
use capsule_nodes::{
    controller::{self, ControllerCore, ControllerOptions, GainArgs},
    controller_params,
};
use capsule_ros_base::{
    ros::{self, RosArgs, RosEnv, RosOptions},
    ros_args,
};
use clap::Parser;

/// Drives the capsule's inner mass with the paper's harmonic force plus position feedback
/// u = k_p |x2 - x1| (Liu et al. 2014, eq. 2), from the state on capsule/state to commands on
/// capsule/actuator_force; serves ~/set_mode and publishes ~/status. It knows nothing of the
/// simulator: give it the scene (for the physical scale, drive and gain) or the values as flags.
#[derive(Debug, Parser)]
#[command(name = "capsule_controller", version, allow_negative_numbers = true)]
struct Cli {
    /// Scene TOML to take the physical scale, drive and gain from ([physical], [drive], [control]);
    /// the whole scene is validated, as capsule_plant and `capsule simulate` do
    #[arg(long)]
    scene: Option<String>,
    /// Inner mass m1 [kg], (0, 1e12] (overrides the scene)
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    m1_kg: Option<f64>,
    /// Primary stiffness k1 [N/m], (0, 1e12] (overrides the scene)
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    k1_n_per_m: Option<f64>,
    /// Friction threshold P_f [N], (0, 1e12] (overrides the scene)
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    pf_n: Option<f64>,
    /// Drive amplitude alpha = P_d/P_f, [0, 100] (the plant's default force limit; overrides the
    /// scene)
    #[arg(long, value_parser = ranges::non_negative(capsule_nodes::command_gate::DEFAULT_MAX_FORCE_PF))]
    alpha: Option<f64>,
    /// Drive frequency omega = Omega/Omega0, (0, 1e12] (overrides the scene)
    #[arg(long, value_parser = ranges::positive(ranges::MAX_MAGNITUDE))]
    omega: Option<f64>,
    /// Initial mode: off, forward, backward, chaos-control, custom [default: custom with the
    /// scene's k_p if it is not 0, else off]
    #[arg(long)]
    mode: Option<String>,
    /// Initial gain (as in a SetMode request for --mode), [-1e12, 1e12]
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true, value_parser = ranges::finite())]
    gain: f64,
    #[command(flatten)]
    gains: GainArgs,
    /// Seconds (steady clock) without a state sample before the controller stops commanding,
    /// (0, 1e6]
    #[arg(long, default_value_t = 0.5, value_parser = ranges::positive(ranges::MAX_SECONDS))]
    state_timeout_s: f64,
    /// Recurrence tolerance of the orbit watch on the Poincare section (non-dim), 1e-6 to 0.2:
    /// the simulator's exact states need 0.02; a prototype's noisy positions about three times
    /// the velocity estimate's error (docs/hardware.md, `capsule simulate --device` reports it)
    #[arg(long, default_value_t = SwitchConfig::DEFAULT.tol, value_parser = ranges::within(1e-6, 0.2))]
    orbit_tolerance: f64,
    /// Check the scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    check: bool,
    /// Status and watchdog period [ms], 1 to 60000
    #[arg(long, default_value_t = 100, value_parser = ranges::millis())]
    status_period_ms: u64,
    /// Do not publish /diagnostics (diagnostic_msgs/DiagnosticArray, 1 Hz: mode, gain,
    /// commands sent, states ignored, plant seen, OK / WARN / ERROR)
    #[arg(long)]
    no_diagnostics: bool,
    #[command(flatten)]
    ros: RosArgs,
}

fn build(cli: &Cli, overrides: &[ros_args::Override]) -> Result<(RosOptions, ControllerOptions)> {
    // what the controller takes from a scene: the physical scale, the drive and the gain
    let view = match cli.scene.as_deref() {
        Some(path) => Some(SceneFile::read(std::path::Path::new(path))?.scene),
        None => None,
    };
    let pick = |flag: Option<f64>, from_scene: Option<f64>, name: &str| -> Result<f64> {
        flag.or(from_scene)
            .with_context(|| format!("--{name} is needed (or a --scene that has it)"))
    };
    // every value is in range: the flags' parsers and the scene's validation checked it
    let scale = PhysicalScale {
        m1_kg: pick(cli.m1_kg, view.as_ref().map(|v| v.physical.m1_kg), "m1-kg")?,
        k1_n_per_m: pick(
            cli.k1_n_per_m,
            view.as_ref().map(|v| v.physical.k1_n_per_m),
            "k1-n-per-m",
        )?,
        pf_n: pick(cli.pf_n, view.as_ref().map(|v| v.physical.pf_n), "pf-n")?,
    };
    let alpha = pick(cli.alpha, view.as_ref().map(|v| v.drive.alpha), "alpha")?;
    let omega = pick(cli.omega, view.as_ref().map(|v| v.drive.omega), "omega")?;
    // a drive beyond the plant's default force limit would only ever be saturated (a scene's
    // alpha; the flag's range says the same)
    let limit = capsule_nodes::command_gate::DEFAULT_MAX_FORCE_PF;
    if alpha.abs() > limit {
        bail!("--alpha {alpha:?}: must satisfy |alpha| <= {limit} (the plant's default force limit in units of P_f)");
    }
    let config = cli.gains.config()?;
    let scene_kp = view.as_ref().map(|v| v.control.kp).unwrap_or(0.0);
    let (mode, gain) = match cli.mode.as_deref() {
        Some(name) => {
            let mode = Mode::parse_name(name).with_context(|| {
                format!("--mode {name:?}: expected off, forward, backward, chaos-control or custom")
            })?;
            (mode, cli.gain)
        }
        None if scene_kp != 0.0 => (Mode::Custom, scene_kp),
        None => (Mode::Off, 0.0),
    };
    let (mode, kp) = config
        .select(mode.code(), gain)
        .map_err(|e| anyhow::anyhow!("--mode/--gain: {e}"))?;
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::CONTROLLER)?;
    let core = ControllerCore::new(scale, alpha, omega, mode, kp, config, cli.state_timeout_s)
        .with_orbit_tolerance(cli.orbit_tolerance);
    // ROS parameters: the flags' values, then -p / --params-file over them
    let mut params = controller_params::table(&core, settings.use_sim_time, cli.state_timeout_s);
    ros_args::apply_overrides(&mut params, overrides, controller_params::rules)?;
    let core = controller_params::core_from(&params);
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

fn main() -> std::process::ExitCode {
    ros::init_logging();
    let (cli, overrides) = match ros_args::parse_node_cli::<Cli>(nodes::CONTROLLER, |c| &mut c.ros)
    {
        Ok(parsed) => parsed,
        Err(e) => return ros::exit_code("capsule_controller", Err(e)),
    };
    let would =
        |opts: &ControllerOptions| format!(", {} k_p = {}", opts.core.mode(), opts.core.law().kp);
    ros::node_main(
        "capsule_controller",
        cli.check,
        build(&cli, &overrides),
        would,
        |settings, opts| {
            let cpus = settings.cpu_affinity.clone();
            Ok(ros::block_on(
                cpus.as_ref(),
                controller::run(settings, opts),
            )?)
        },
    )
}
