//! A minimal controller: a ROS 2 node that reads the plant's state on `/capsule/state` and
//! answers every sample on `/capsule/actuator_force`, built on the project's plumbing in
//! `capsule_ros_base` (the ROS conventions and flags, the loopback participant, names, QoS and
//! type names). Its law is the paper's drive plus position feedback, in SI through the scene's
//! physical scale: `F = P_f (alpha cos(omega tau) + k_p |x2 - x1|)`.
//!
//!   cargo build -p capsule_nodes --bins --examples
//!   target/debug/capsule_plant --scene scenes/control_point.toml --pacing lockstep --until-s 2 \
//!       --wait-subscribers 1 --discovery-range localhost &
//!   target/debug/examples/minimal_controller --kp 0.2 --discovery-range localhost
//!
//! At Ctrl-C (or SIGTERM) it stops and prints how far the capsule went. The real controller node (`capsule_controller`) adds modes, the set_mode service,
//! parameters, status, diagnostics and the faults it survives.

use std::path::PathBuf;

use anyhow::{Context as _, Result};
use capsule_args::scene_file::SceneFile;
use capsule_msgs::names::topics;
use capsule_msgs::{ActuatorForce, CapsuleState, Header};
use capsule_ros_base::{
    endpoints::subscribe,
    node_main, qos,
    ros_options::{RosArgs, RosEnv, RosOptions},
    signals, types,
};
use clap::Parser;
use futures::StreamExt;

/// Drives the plant with the paper's law.
#[derive(Debug, Parser)]
struct Cli {
    /// Scene (its drive and physical scale)
    #[arg(long, default_value = "scenes/control_point.toml")]
    scene: PathBuf,
    /// Feedback gain k_p
    #[arg(long, default_value_t = 0.2, allow_negative_numbers = true)]
    kp: f64,
    #[command(flatten)]
    ros: RosArgs,
}

async fn run(cli: Cli) -> Result<()> {
    let scene = SceneFile::read(&cli.scene)?.scene;
    if !cli.kp.is_finite() {
        anyhow::bail!("--kp {}: must be finite", cli.kp);
    }
    let scale = scene.physical;
    let (alpha, omega) = (scene.drive.alpha, scene.drive.omega);

    let settings = RosOptions::resolve(&cli.ros, &RosEnv::from_process(), "minimal_controller")?;
    let context = settings.context()?;
    let mut node = settings.node(&context)?;
    // the state as the nodes read it (best effort, keep last 16: matches any writer)
    let state_topic = settings.topic(&node, topics::STATE, types::state(), &qos::data())?;
    let states = subscribe::<CapsuleState>(&mut node, &state_topic, &qos::data_reader())?;
    // the force as the controller node writes it (reliable, keep last 16)
    let force_topic = settings.topic(&node, topics::FORCE, types::force(), &qos::data())?;
    let forces = node.create_publisher::<ActuatorForce>(&force_topic, None)?;
    println!(
        "{}: waiting for {}",
        settings.describe(),
        settings.resolve_name(topics::STATE)
    );

    let stream = states.async_stream();
    let shutdown = signals::shutdown_signal();
    tokio::pin!(stream, shutdown);
    let mut first_x2 = None;
    let mut last = None;
    loop {
        let state = tokio::select! {
            s = stream.next() => match s {
                Some(Ok((s, _))) => s,
                Some(Err(e)) => { eprintln!("bad state sample: {e:?}"); continue; }
                None => break,
            },
            _ = &mut shutdown => break,
        };
        // the law, non-dimensional as in the paper, from the sample's stamp and positions
        let tau = state.header.stamp.as_secs_f64() / scale.time_s();
        let gap = (state.capsule_position - state.mass_position) / scale.length_m();
        let force = scale.force_n() * (alpha * (omega * tau).cos() + cli.kp * gap.abs());
        let answer = ActuatorForce {
            header: Header {
                stamp: state.header.stamp,
                frame_id: state.header.frame_id.clone(),
            },
            state_seq: state.seq,
            force,
        };
        forces
            .async_publish(answer)
            .await
            .context("publishing the force")?;
        first_x2.get_or_insert(state.capsule_position);
        last = Some(state);
    }
    if let (Some(x0), Some(s)) = (first_x2, last) {
        println!(
            "answered up to seq {}; the capsule went {:.3} mm (t = {:.3} s)",
            s.seq,
            (s.capsule_position - x0) * 1e3,
            s.header.stamp.as_secs_f64()
        );
    }
    Ok(())
}

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = node_main::block_on(cli.ros.cpu_affinity.clone().as_ref(), run(cli));
    node_main::exit_code("minimal_controller", result)
}
