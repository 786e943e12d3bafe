//! `capsule_recorder`: records the capsule graph to one MCAP file per run (ROS 2 profile).

use capsule_msgs::names::nodes;
use std::{path::PathBuf, time::Duration};

use anyhow::Result;
use capsule_args::{ranges, scene_file::SceneFile, storage::StorageArgs};
use capsule_plant_node::recorder::{self, RecorderOptions};
use capsule_ros_base::{
    node_main, ros_args,
    ros_options::{RosArgs, RosEnv, RosOptions},
};
use clap::Parser;

/// Records state, force commands, controller status, /clock and the set_mode service events to
/// `<record-dir>/capsule_<scene>_<UTC time>.mcap` (or --output), the way rosbag2 writes MCAP.
/// SIGINT / SIGTERM finish the file; after a SIGKILL, `capsule record recover FILE` completes it.
#[derive(Debug, Parser)]
#[command(name = "capsule_recorder", version, allow_negative_numbers = true)]
struct Cli {
    /// Directory for the run's file (created if missing)
    #[arg(long, default_value = "runs")]
    record_dir: PathBuf,
    /// Write exactly this file instead (must not exist)
    #[arg(long)]
    output: Option<PathBuf>,
    /// The scene that is run (validated as capsule_plant does): attached to the file, and its
    /// name goes into the file name
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Close the open chunk at least this often [ms] (bounds what a SIGKILL loses), 1 to 60000
    #[arg(long, default_value_t = 250, value_parser = ranges::millis())]
    flush_ms: u64,
    /// Drain the DDS readers this often [ms], 1 to 60000
    #[arg(long, default_value_t = 2, value_parser = ranges::millis())]
    poll_ms: u64,
    /// Samples each DDS reader keeps (the DDS history depth, held in memory all run): enough for
    /// the drain loop to stall depth / rate seconds without losing any (the default is 2 s at
    /// 10 kHz), 1 to 1000000
    #[arg(long, default_value_t = recorder::DEFAULT_QUEUE_DEPTH,
          value_parser = ranges::count_usize(1, 1_000_000))]
    queue_depth: usize,
    /// Seconds to wait for the controller's publishers before subscribing to the state,
    /// [0, 1e6]
    #[arg(long, default_value_t = 10.0, value_parser = ranges::non_negative(ranges::MAX_SECONDS))]
    wait_publishers_s: f64,
    /// Controller node name (its status and service-event topics are private to it)
    #[arg(long, default_value = nodes::CONTROLLER)]
    controller_node: String,
    /// Finish by itself after this many seconds without a message (0: only on a signal),
    /// [0, 1e6]
    #[arg(long, default_value_t = 0.0, value_parser = ranges::non_negative(ranges::MAX_SECONDS))]
    idle_stop_s: f64,
    /// Check the flags and the output place, print the file name, and exit (no DDS)
    #[arg(long)]
    check: bool,
    #[command(flatten)]
    storage: StorageArgs,
    #[command(flatten)]
    ros: RosArgs,
}

fn build(cli: &Cli) -> Result<(RosOptions, RecorderOptions)> {
    let scene = match cli.scene.as_deref() {
        Some(path) => Some(SceneFile::read(path)?.record()),
        None => None,
    };
    let output = recorder::output_path(&cli.record_dir, cli.output.as_deref(), scene.as_ref())?;
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::RECORDER)?;
    Ok((
        settings,
        RecorderOptions {
            bag: cli.storage.options(),
            output,
            scene,
            flush_period: Duration::from_millis(cli.flush_ms),
            poll_period: Duration::from_millis(cli.poll_ms),
            wait_publishers: Duration::from_secs_f64(cli.wait_publishers_s),
            controller_node: cli.controller_node.clone(),
            idle_stop: (cli.idle_stop_s > 0.0).then(|| Duration::from_secs_f64(cli.idle_stop_s)),
            queue_depth: cli.queue_depth,
        },
    ))
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let cli = match ros_args::parse_cli_without_params::<Cli>(nodes::RECORDER, |c| &mut c.ros) {
        Ok(cli) => cli,
        Err(e) => return node_main::exit_code("capsule_recorder", Err(e)),
    };
    let would = |opts: &RecorderOptions| format!(", would write {}", opts.output.display());
    node_main::node_main(
        "capsule_recorder",
        cli.check,
        build(&cli),
        would,
        |settings, opts| {
            let report = node_main::block_on(
                settings.cpu_affinity.clone().as_ref(),
                recorder::run(settings, opts),
            )?;
            let total: u64 = report.per_topic.values().sum();
            println!(
                "capsule_recorder: wrote {total} messages to {}",
                report.path.display()
            );
            for (topic, n) in &report.per_topic {
                println!("  {topic}: {n}");
            }
            Ok(())
        },
    )
}
