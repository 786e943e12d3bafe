//! `capsule_controller`: the ROS 2 controller node of the vibro-impact capsule.

use std::time::Duration;

use anyhow::{bail, Context as _, Result};
use capsule_controller::mode::Mode;
use capsule_nodes::{
    controller::{self, ControllerCore, ControllerOptions, GainArgs},
    ros::{self, RosArgs, RosEnv, RosSettings},
    scale::{ControlScene, Scale},
};
use clap::Parser;

/// Drives the capsule's inner mass with the paper's harmonic force plus position feedback
/// u = k_p |x2 - x1| (Liu et al. 2014, eq. 2), from the state on capsule/state to commands on
/// capsule/actuator_force; serves ~/set_mode and publishes ~/status. It knows nothing of the
/// simulator: give it the scene (for the physical scale, drive and gain) or the values as flags.
#[derive(Debug, Parser)]
#[command(name = "capsule_controller", version)]
struct Cli {
    /// Scene TOML to take the physical scale, drive and gain from ([physical], [drive], [control])
    #[arg(long)]
    scene: Option<String>,
    /// Inner mass m1 [kg] (overrides the scene)
    #[arg(long)]
    m1_kg: Option<f64>,
    /// Primary stiffness k1 [N/m] (overrides the scene)
    #[arg(long)]
    k1_n_per_m: Option<f64>,
    /// Friction threshold P_f [N] (overrides the scene)
    #[arg(long)]
    pf_n: Option<f64>,
    /// Drive amplitude alpha = P_d/P_f (overrides the scene)
    #[arg(long)]
    alpha: Option<f64>,
    /// Drive frequency omega = Omega/Omega0 (overrides the scene)
    #[arg(long)]
    omega: Option<f64>,
    /// Initial mode: off, forward, backward, chaos-control, custom [default: custom with the
    /// scene's k_p if it is not 0, else off]
    #[arg(long)]
    mode: Option<String>,
    /// Initial gain (as in a SetMode request for --mode)
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    gain: f64,
    #[command(flatten)]
    gains: GainArgs,
    /// Seconds (steady clock) without a state sample before the controller stops commanding
    #[arg(long, default_value_t = 0.5)]
    state_timeout_s: f64,
    /// Check the scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    check: bool,
    /// Status and watchdog period [ms]
    #[arg(long, default_value_t = 100)]
    status_period_ms: u64,
    #[command(flatten)]
    ros: RosArgs,
}

fn build(cli: &Cli) -> Result<(RosSettings, ControllerOptions)> {
    let scene = cli
        .scene
        .as_deref()
        .map(ControlScene::from_file)
        .transpose()?;
    let pick = |flag: Option<f64>, from_scene: Option<f64>, name: &str| -> Result<f64> {
        flag.or(from_scene)
            .with_context(|| format!("--{name} is needed (or a --scene that has it)"))
    };
    let scale = Scale {
        m1_kg: pick(cli.m1_kg, scene.map(|s| s.scale.m1_kg), "m1-kg")?,
        k1_n_per_m: pick(
            cli.k1_n_per_m,
            scene.map(|s| s.scale.k1_n_per_m),
            "k1-n-per-m",
        )?,
        pf_n: pick(cli.pf_n, scene.map(|s| s.scale.pf_n), "pf-n")?,
    };
    scale.validate()?;
    let alpha = pick(cli.alpha, scene.map(|s| s.alpha), "alpha")?;
    let omega = pick(cli.omega, scene.map(|s| s.omega), "omega")?;
    if !alpha.is_finite() {
        bail!("--alpha {alpha}: not finite");
    }
    if !(omega.is_finite() && omega > 0.0) {
        bail!("--omega {omega}: must be finite and > 0");
    }
    let config = cli.gains.config()?;
    let scene_kp = scene.map(|s| s.kp).unwrap_or(0.0);
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
    if !(cli.state_timeout_s.is_finite() && cli.state_timeout_s > 0.0) {
        bail!(
            "--state-timeout-s {}: must be finite and > 0",
            cli.state_timeout_s
        );
    }
    if cli.status_period_ms == 0 {
        bail!("--status-period-ms must be > 0");
    }
    let settings = RosSettings::resolve(&cli.ros, &RosEnv::from_process(), "capsule_controller")?;
    let core = ControllerCore::new(scale, alpha, omega, mode, kp, config, cli.state_timeout_s);
    Ok((
        settings,
        ControllerOptions {
            core,
            status_period: Duration::from_millis(cli.status_period_ms),
        },
    ))
}

fn main() -> std::process::ExitCode {
    ros::init_logging();
    let cli = Cli::parse();
    let result = build(&cli).and_then(|(settings, opts)| {
        if cli.check {
            let (mode, kp) = (opts.core.mode(), opts.core.law().kp);
            println!(
                "capsule_controller: ok: {}, {mode} k_p = {kp}",
                settings.describe()
            );
            return Ok(());
        }
        ros::block_on(
            settings.cpu_affinity.clone().as_ref(),
            controller::run(settings, opts),
        )
    });
    ros::exit_code("capsule_controller", result)
}
