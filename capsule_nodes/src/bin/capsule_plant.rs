//! `capsule_plant`: the ROS 2 plant node, a simulated vibro-impact capsule.

use std::time::Duration;

use anyhow::{bail, Context as _, Result};
use capsule_nodes::{
    plant::{self, InPlantRecordOptions, Pacing, PlantCore, PlantOptions},
    recorder,
    ros::{self, RosArgs, RosEnv, RosSettings},
    scale::Scale,
    sim::ExactSim,
};
use capsule_plant::{scene::Scene, Simulator};
use clap::Parser;

/// Simulates the capsule of a scene exactly and serves it as a capsule driver would: state on
/// capsule/state at the scene's rate (SI units through the scene's [physical] scale), force
/// commands from capsule/actuator_force (held between samples; non-finite or late ones refused;
/// zero force once they go stale), and sim time on /clock.
#[derive(Debug, Parser)]
#[command(name = "capsule_plant", version)]
struct Cli {
    /// Scene TOML (model, friction, initial state, physical scale, node rate and timeout)
    #[arg(long)]
    scene: String,
    /// realtime: one sample per 1/rate of wall time; lockstep: each step waits for the
    /// controller's answer (reproducible, as fast as the loop allows)
    #[arg(long, value_enum, default_value = "realtime")]
    pacing: Pacing,
    /// Sample rate [Hz] (overrides the scene's node.rate_hz)
    #[arg(long)]
    rate_hz: Option<f64>,
    /// Seconds without a fresh command before zero force (overrides node.command_timeout_s)
    #[arg(long)]
    command_timeout_s: Option<f64>,
    /// Stop at this sim time [s] (default: run until Ctrl-C / SIGTERM)
    #[arg(long)]
    until_s: Option<f64>,
    /// Lock-step: re-send an unanswered sample every this many ms
    #[arg(long, default_value_t = 20)]
    retransmit_ms: u64,
    /// Lock-step: seconds to wait for the first command and for --wait-subscribers
    #[arg(long, default_value_t = 30.0)]
    startup_timeout_s: f64,
    /// Publish the first sample once this many subscribers matched the state topic
    #[arg(long, default_value_t = 0)]
    wait_subscribers: usize,
    /// Publish /clock with every N-th sample (1 = every sample; larger saves CPU at high rates
    /// at the cost of a coarser sim clock for use_sim_time nodes). /clock is sent only while
    /// it has a subscriber; a recording always holds it
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u64).range(1..))]
    clock_every: u64,
    /// Record the graph in this process to DIR/capsule_<scene>_<UTC time>.mcap (what the plant
    /// publishes and receives, the controller's status and mode changes): the same file as
    /// capsule_recorder writes, at a fraction of its CPU at high rates
    #[arg(long, value_name = "DIR")]
    record_dir: Option<std::path::PathBuf>,
    /// Record in-process to exactly this file (must not exist)
    #[arg(long, value_name = "FILE", conflicts_with = "record_dir")]
    record_output: Option<std::path::PathBuf>,
    /// Controller node whose status and service events the in-process recording takes
    #[arg(long, default_value = "capsule_controller")]
    controller_node: String,
    /// In-process recording: close the open chunk at least this often [ms]
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(1..))]
    flush_ms: u64,
    /// Write a JSON summary (loop statistics, last sample) to this file at the end
    #[arg(long)]
    summary_json: Option<String>,
    /// Check the scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    check: bool,
    #[command(flatten)]
    ros: RosArgs,
}

fn positive(name: &str, v: f64) -> Result<f64> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        bail!("{name} = {v}: must be finite and > 0")
    }
}

fn record_options(cli: &Cli) -> Result<Option<InPlantRecordOptions>> {
    if cli.record_dir.is_none() && cli.record_output.is_none() {
        return Ok(None);
    }
    let scene = recorder::scene_record(std::path::Path::new(&cli.scene))?;
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
    }))
}

fn build(cli: &Cli) -> Result<(RosSettings, PlantCore<ExactSim>, PlantOptions)> {
    let text = std::fs::read_to_string(&cli.scene)
        .with_context(|| format!("cannot read scene {}", cli.scene))?;
    let scene = Scene::from_toml_str(&text, &cli.scene).map_err(|e| anyhow::anyhow!("{e}"))?;
    let p = &scene.physical;
    let scale = Scale {
        m1_kg: p.m1_kg,
        k1_n_per_m: p.k1_n_per_m,
        pf_n: p.pf_n,
    };
    scale
        .validate()
        .with_context(|| format!("{}: [physical]", cli.scene))?;
    let rate = positive(
        "--rate-hz / node.rate_hz",
        cli.rate_hz.unwrap_or(scene.node.rate_hz),
    )?;
    let timeout = positive(
        "--command-timeout-s / node.command_timeout_s",
        cli.command_timeout_s
            .unwrap_or(scene.node.command_timeout_s),
    )?;
    if let Some(u) = cli.until_s {
        positive("--until-s", u)?;
    }
    positive("--startup-timeout-s", cli.startup_timeout_s)?;
    if cli.retransmit_ms == 0 {
        bail!("--retransmit-ms must be > 0");
    }
    let sim = Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver())
        .map_err(|e| anyhow::anyhow!("{}: cannot set up the simulation: {e}", cli.scene))?;
    let settings = RosSettings::resolve(&cli.ros, &RosEnv::from_process(), "capsule_plant")?;
    let core = PlantCore::new(ExactSim(sim), scale, rate, timeout);
    let opts = PlantOptions {
        pacing: cli.pacing,
        until_s: cli.until_s,
        retransmit: Duration::from_millis(cli.retransmit_ms),
        startup_timeout: Duration::from_secs_f64(cli.startup_timeout_s),
        wait_subscribers: cli.wait_subscribers,
        clock_every: cli.clock_every,
        record: record_options(cli)?,
    };
    Ok((settings, core, opts))
}

fn main() -> std::process::ExitCode {
    ros::init_logging();
    let cli = Cli::parse();
    let result = build(&cli).and_then(|(settings, core, opts)| {
        if cli.check {
            println!(
                "capsule_plant: ok: {}, {:?}{}",
                settings.describe(),
                opts.pacing,
                opts.record
                    .as_ref()
                    .map(|r| format!(", would record to {}", r.output.display()))
                    .unwrap_or_default()
            );
            return Ok(());
        }
        let started = std::time::Instant::now();
        let (stats, last) = ros::block_on(
            settings.cpu_affinity.clone().as_ref(),
            plant::run(settings, core, opts),
        )?;
        if let Some(path) = &cli.summary_json {
            let json = plant::summary_json(&stats, &last, started.elapsed().as_secs_f64());
            std::fs::write(path, json + "\n").with_context(|| format!("cannot write {path}"))?;
        }
        Ok(())
    });
    ros::exit_code("capsule_plant", result)
}
