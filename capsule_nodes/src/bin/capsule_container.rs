//! `capsule_container`: the plant and the controller composed in one process, as rclcpp's
//! component container runs nodes: each the same node as its own binary runs (its name,
//! parameters, services, diagnostics, lifecycle), on one DDS participant, with state and force
//! delivered in-process ([`capsule_plant_node::intra_process`]) and their DDS copies published for
//! the rest of the graph. With --foxglove-port, capsule_foxglove's bridge is a third node of the
//! process, on a thread and a DDS participant of its own, fed state and force by the link.

#[path = "cli/controller.rs"]
mod controller_cli;
#[path = "cli/plant.rs"]
mod plant_cli;

use std::ffi::OsString;
use std::sync::Arc;

use anyhow::{bail, Context as _, Result};
use capsule_controller_node::controller::{self, ControllerOptions};
use capsule_msgs::names::nodes;
use capsule_plant_node::{
    intra_process::{Link, Transport},
    plant::{self, PlantOptions},
};
use capsule_ros_base::{
    affinity::{self, CpuList},
    node_main, ros_args,
    ros_options::RosOptions,
    signals,
};
use capsule_tools::foxglove_bridge::{self, BridgeOptions, BridgeThread, Source};
use clap::Parser;

/// Runs capsule_plant and capsule_controller as two nodes of one process (ROS 2 composition):
/// the plant's state reaches the controller and its command comes back in-process (no
/// serialisation, no DDS round trip on the loop's critical path), while both still publish
/// their topics on DDS for everyone else (recorder, Foxglove, RViz, rclcpp nodes) from a
/// publisher thread, and serve their services and parameters as before. With --record-dir the
/// plant records every sample in-process (the file capsule_recorder writes). With
/// --foxglove-port it also serves the graph live to Foxglove (capsule_foxglove's bridge, a node
/// of its own in this process).
#[derive(Debug, Parser)]
#[command(name = "capsule_container", version, allow_negative_numbers = true)]
struct Cli {
    /// Scene TOML, for both nodes (capsule_plant's and capsule_controller's --scene)
    #[arg(long)]
    scene: String,
    /// The plant's pacing: realtime or lockstep (capsule_plant --pacing)
    #[arg(long, default_value = "realtime")]
    pacing: String,
    /// Stop at this sim time [s] (capsule_plant --until-s)
    #[arg(long)]
    until_s: Option<String>,
    /// The controller's mode (capsule_controller --mode)
    #[arg(long)]
    mode: Option<String>,
    /// Record every sample in-process to DIR/capsule_<scene>_<UTC time>.mcap (capsule_plant
    /// --record-dir)
    #[arg(long, value_name = "DIR")]
    record_dir: Option<String>,
    /// Record in-process to exactly this file (capsule_plant --record-output)
    #[arg(long, value_name = "FILE", conflicts_with = "record_dir")]
    record_output: Option<String>,
    /// Write the plant's JSON summary here at the end (capsule_plant --summary-json)
    #[arg(long, value_name = "FILE")]
    summary_json: Option<String>,
    /// Also serve the graph live to Foxglove on ws://127.0.0.1:PORT (0: any free port, printed
    /// as `capsule_foxglove: serving ws://127.0.0.1:PORT`): capsule_foxglove's bridge, the same
    /// node, channels and schemas, run in this process on a thread of its own; loopback only. A
    /// port it cannot serve on ends the container before the loop starts, 0 to 65535
    #[arg(long, value_name = "PORT")]
    foxglove_port: Option<u16>,
    /// Pin the process's threads (both nodes, DDS's) to these CPUs, e.g. 0 or 0-1
    #[arg(long, value_name = "LIST")]
    cpu_affinity: Option<CpuList>,
    /// One more argument for the plant node, as capsule_plant takes it (repeat; a
    /// `--ros-args ...` among them is the plant's)
    #[arg(long = "plant-arg", value_name = "ARG", allow_hyphen_values = true)]
    plant_args: Vec<OsString>,
    /// One more argument for the controller node, as capsule_controller takes it (repeat)
    #[arg(
        long = "controller-arg",
        value_name = "ARG",
        allow_hyphen_values = true
    )]
    controller_args: Vec<OsString>,
    /// Check both nodes' scene and flags, print what would run, and exit (no DDS)
    #[arg(long)]
    check: bool,
}

/// What the container runs: each node as its own binary would build it.
struct Composed {
    plant: (RosOptions, plant_cli::Plant, PlantOptions),
    plant_cli: plant_cli::Cli,
    controller: (RosOptions, ControllerOptions),
    /// The Foxglove bridge's node, if asked for.
    foxglove: Option<(RosOptions, BridgeOptions)>,
}

/// The Foxglove bridge's node: `capsule_foxglove` in the plant's namespace, domain and security
/// with the plant's remaps, serving the composed controller's status, on `port`. State and force
/// come from the in-process link (thinned on the loop's thread to the bridge's rate: at 10 kHz,
/// fed over DDS, the loop's copies of every sample would be published for it alone); the status
/// over DDS, in a participant of its own ([`foxglove_bridge::Bridge::start`] makes one): RustDDS
/// delivers nothing to a reader on the writer's own participant, the plant's and controller's.
fn bridge_node(
    plant: &RosOptions,
    controller: &RosOptions,
    port: u16,
) -> (RosOptions, BridgeOptions) {
    let settings = RosOptions {
        node_name: nodes::FOXGLOVE.to_string(),
        cpu_affinity: None,
        ..plant.clone()
    };
    let opts = BridgeOptions {
        port,
        controller_node: controller.node_name.clone(),
        max_rate_hz: BridgeOptions::DEFAULT_MAX_RATE_HZ,
    };
    (settings, opts)
}

/// The command lines of the two nodes: the shared flags, then each one's own.
fn node_argvs(cli: &Cli) -> (Vec<OsString>, Vec<OsString>) {
    let mut plant: Vec<OsString> = [
        "capsule_plant",
        "--scene",
        &cli.scene,
        "--pacing",
        &cli.pacing,
    ]
    .map(OsString::from)
    .into();
    let flags = [
        ("--until-s", &cli.until_s),
        ("--record-dir", &cli.record_dir),
        ("--record-output", &cli.record_output),
        ("--summary-json", &cli.summary_json),
    ];
    for (flag, value) in flags {
        if let Some(v) = value {
            plant.extend([flag.into(), v.into()]);
        }
    }
    plant.extend(cli.plant_args.iter().cloned());
    let mut controller: Vec<OsString> = ["capsule_controller", "--scene", &cli.scene]
        .map(OsString::from)
        .into();
    if let Some(m) = &cli.mode {
        controller.extend(["--mode".into(), m.into()]);
    }
    controller.extend(cli.controller_args.iter().cloned());
    (plant, controller)
}

/// Both nodes built from their command lines, checked to share one participant; an error names
/// the node and the input.
fn build(cli: &Cli) -> Result<Composed> {
    let (plant_argv, controller_argv) = node_argvs(cli);
    let (pcli, overrides) =
        ros_args::parse_node_cli_from::<plant_cli::Cli>(plant_argv, nodes::PLANT, |c| &mut c.ros)?;
    let plant = plant_cli::build(&pcli, &overrides).context("capsule_plant")?;
    let (ccli, overrides) = ros_args::parse_node_cli_from::<controller_cli::Cli>(
        controller_argv,
        nodes::CONTROLLER,
        |c| &mut c.ros,
    )?;
    let controller = controller_cli::build(&ccli, &overrides).context("capsule_controller")?;
    if pcli.check() || ccli.check() {
        bail!("--check is the container's own flag, not a node's");
    }
    let (p, c) = (&plant.0, &controller.0);
    if p.cpu_affinity.is_some() || c.cpu_affinity.is_some() {
        bail!("--cpu-affinity in a node's arguments: the nodes share one process; give the container's --cpu-affinity");
    }
    let same = |what: &str, a: String, b: String| -> Result<()> {
        if a != b {
            bail!("the plant's {what} ({a}) and the controller's ({b}) differ: composed nodes share one DDS participant");
        }
        Ok(())
    };
    same("domain", p.domain_id.to_string(), c.domain_id.to_string())?;
    same(
        "discovery range",
        format!("{:?}", p.range),
        format!("{:?}", c.range),
    )?;
    same("security", p.security.describe(), c.security.describe())?;
    if (&p.namespace, &p.node_name) == (&c.namespace, &c.node_name) {
        bail!(
            "both nodes are named {}/{}: composed nodes need names of their own",
            p.namespace.trim_end_matches('/'),
            p.node_name
        );
    }
    let foxglove = cli
        .foxglove_port
        .map(|port| bridge_node(&plant.0, &controller.0, port));
    Ok(Composed {
        plant,
        plant_cli: pcli,
        controller,
        foxglove,
    })
}

/// Runs the nodes: the Foxglove bridge first, if asked for (a port it cannot serve on ends the
/// container before anything else starts), then plant and controller ([`run_loop`]); the bridge
/// stops after them. A bridge that failed on the way is named and makes the exit non-zero, but
/// did not stop control (as the launcher treats a separate live view).
async fn run(mut composed: Composed) -> Result<()> {
    let link = Link::new();
    let bridge = match composed.foxglove.take() {
        Some((settings, opts)) => {
            let bridge = BridgeThread::spawn(settings, opts, Source::InProcess(link.clone()))
                .await
                .context(nodes::FOXGLOVE)?;
            foxglove_bridge::announce(bridge.port());
            Some(bridge)
        }
        None => None,
    };
    let result = run_loop(composed, link).await;
    let bridged = bridge.map(BridgeThread::stop).transpose();
    match (result, bridged) {
        (Err(e), Err(b)) => {
            tracing::error!("{}: {b:#}", nodes::FOXGLOVE);
            Err(e)
        }
        (result, bridged) => {
            bridged.context(nodes::FOXGLOVE)?;
            result
        }
    }
}

/// Runs plant and controller until the plant's end (`--until-s`, a lifecycle shutdown) or a
/// signal, their state and force over `link`; a node that fails is named and ends the process
/// (the other does not run on).
async fn run_loop(composed: Composed, link: Link) -> Result<()> {
    let Composed {
        plant: (psettings, core, popts),
        plant_cli,
        controller: (csettings, copts),
        ..
    } = composed;
    let context = psettings.context().context("the container's participant")?;
    let plant_done = Arc::new(tokio::sync::Notify::new());
    let done = plant_done.clone();
    let end = async move {
        tokio::select! {
            r = signals::shutdown() => r,
            _ = done.notified() => Ok(()),
        }
    };
    let started = std::time::Instant::now();
    let ctl = controller::run_in(
        &context,
        csettings,
        copts,
        Transport::InProcess(link.clone()),
        end,
    );
    tokio::pin!(ctl);
    // the controller first, as the launcher starts it first: the plant's first sample finds it
    let attached = async {
        while !link.is_attached() {
            tokio::time::sleep(std::time::Duration::from_millis(1)).await;
        }
    };
    tokio::select! {
        c = &mut ctl => {
            c.context("capsule_controller")?;
            return Ok(());
        }
        () = attached => {}
    }
    let plant = plant::run_in(
        Some(&context),
        psettings,
        core,
        popts,
        Transport::InProcess(link),
    );
    tokio::pin!(plant);
    let (stats, last) = tokio::select! {
        p = &mut plant => {
            plant_done.notify_one();
            let p = p.context("capsule_plant")?;
            (&mut ctl).await.context("capsule_controller")?;
            p
        }
        c = &mut ctl => {
            c.context("capsule_controller")?;
            // the controller ended by a signal: so does the plant
            plant.await.context("capsule_plant")?
        }
    };
    if let Some(path) = &plant_cli.summary_json() {
        let json = plant::summary_json(&stats, &last, started.elapsed().as_secs_f64());
        std::fs::write(path, json + "\n").with_context(|| format!("cannot write {path}"))?;
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    node_main::init_logging();
    let cli = Cli::parse();
    let result = build(&cli).and_then(|composed| {
        if let Some(list) = &cli.cpu_affinity {
            affinity::check(list, &affinity::allowed()?)
                .with_context(|| format!("--cpu-affinity {list}"))?;
        }
        if cli.check {
            let (p, core, popts) = &composed.plant;
            println!(
                "capsule_container: ok: plant {}, {}, {:?}, force limit {} N{}; controller {}, {} k_p = {}; in-process state and force{}",
                p.describe(),
                composed.plant_cli.source_label(),
                popts.pacing,
                core.max_force_n(),
                popts
                    .record
                    .as_ref()
                    .map(|r| format!(", would record to {}", r.output.display()))
                    .unwrap_or_default(),
                composed.controller.0.describe(),
                composed.controller.1.core.mode(),
                composed.controller.1.core.law().kp,
                composed
                    .foxglove
                    .as_ref()
                    .map(|(s, o)| format!(
                        "; {} would serve ws://127.0.0.1:{}",
                        s.node_name, o.port
                    ))
                    .unwrap_or_default()
            );
            return Ok(());
        }
        node_main::block_on(cli.cpu_affinity.as_ref(), run(composed))
    });
    node_main::exit_code("capsule_container", result)
}
