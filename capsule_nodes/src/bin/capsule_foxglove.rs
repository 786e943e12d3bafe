//! `capsule_foxglove`: the capsule graph live in Foxglove, without ROS installed.

use anyhow::{bail, Result};
use capsule_args::ranges;
use capsule_msgs::names::nodes;
use capsule_ros_base::{
    node_main,
    ros_args::{self, Override},
    ros_options::RosArgs,
    ros_options::RosEnv,
    ros_options::RosOptions,
};
use capsule_tools::foxglove_bridge::{self, BridgeOptions};
use clap::Parser;

/// Serves the plant's state, the controller's commands and status, and the capsule's frame on
/// a Foxglove WebSocket (foxglove.sdk.v1, Foxglove's v1 protocol) on 127.0.0.1: in Foxglove,
/// "Open connection", Foxglove WebSocket, ws://127.0.0.1:PORT, then the layout
/// docs/foxglove/capsule_layout.json. A node of its own that reads the DDS topics: the plant's
/// loop is untouched.
#[derive(Debug, Parser)]
#[command(name = "capsule_foxglove", version)]
struct Cli {
    /// Port to serve on (0: any free port; the bound one is printed), 0 to 65535
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// Address to bind: 127.0.0.1 (or localhost) only; anything else is refused
    #[arg(long, default_value = "127.0.0.1")]
    host: String,
    /// Controller node name (its status topic is private to it)
    #[arg(long, default_value = "capsule_controller")]
    controller_node: String,
    /// Most state, frame and command messages per second, each by its stamps (0: all),
    /// [0, 1e6]
    #[arg(long, default_value_t = BridgeOptions::DEFAULT_MAX_RATE_HZ, value_parser = ranges::non_negative(1e6))]
    max_rate_hz: f64,
    /// Check the flags, print what would be served, and exit (no DDS, no server)
    #[arg(long)]
    check: bool,
    #[command(flatten)]
    ros: RosArgs,
}

fn build(cli: &Cli, overrides: &[Override]) -> Result<(RosOptions, BridgeOptions)> {
    foxglove_bridge::check_host(&cli.host)?;
    // names, namespace and remaps apply (`--ros-args -r __ns:=/robot1`); it has no parameters
    if let Some(o) = overrides.first() {
        bail!(
            "{}: {} has no parameter {:?} (its settings are flags: --help)",
            o.origin,
            nodes::FOXGLOVE,
            o.name
        );
    }
    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), nodes::FOXGLOVE)?;
    Ok((
        settings,
        BridgeOptions {
            port: cli.port,
            controller_node: cli.controller_node.clone(),
            max_rate_hz: cli.max_rate_hz,
        },
    ))
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let (cli, overrides) = match ros_args::parse_node_cli::<Cli>(nodes::FOXGLOVE, |c| &mut c.ros) {
        Ok(parsed) => parsed,
        Err(e) => return node_main::exit_code(nodes::FOXGLOVE, Err(e)),
    };
    let would = |opts: &BridgeOptions| format!(", would serve ws://127.0.0.1:{}", opts.port);
    node_main::async_node_main(
        nodes::FOXGLOVE,
        cli.check,
        build(&cli, &overrides),
        would,
        foxglove_bridge::run,
    )
}
