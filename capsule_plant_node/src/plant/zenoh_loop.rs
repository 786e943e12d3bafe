//! The plant on Zenoh (rmw_zenoh_cpp's protocol, through ros2-client's Zenoh backend), its core
//! interface first: the state out on `/capsule/state` at the scene's rate in real time, the
//! force command in, the same [`PlantCore`] as on DDS. What is not ported yet is refused by name
//! before any work ([`refuse_unported`]); the parameters, `/clock`, the views, the emergency
//! stop and the lifecycle services are not served on Zenoh yet, which the log says at start.

use std::time::{Duration, Instant};

use capsule_hardware::throttle::Throttle;
use capsule_msgs::names::topics;
use capsule_msgs::{ActuatorForce, CapsuleState};
use capsule_ros_base::error::{Context as _, Result};
use capsule_ros_base::{qos, ros_options::RosOptions, types};
use tracing::{info, warn};

use super::endpoints::{log_refused, log_undecodable};
use super::simulator_loop::Wall;
use super::{CommandOutcome, LoopStats, Pacing, PlantCore, PlantOptions};
use crate::hardware::CapsuleHardware;

/// Refuses, on Zenoh, what the plant does not do there yet.
fn refuse_unported(settings: &RosOptions, opts: &PlantOptions) -> Result<()> {
    let mw = &settings.middleware;
    let asked = [
        (opts.pacing == Pacing::Lockstep, "--pacing lockstep"),
        (opts.record.is_some(), "--record"),
        (opts.joint_commands, "--joint-commands"),
        (opts.wait_subscribers > 0, "--wait-subscribers"),
        (!opts.autostart, "the lifecycle (a plant not autostarted)"),
        (settings.use_sim_time, "--use-sim-time"),
    ];
    for (_, what) in asked.iter().filter(|(on, _)| *on) {
        mw.refuse_on_zenoh(&format!("the plant's {what}"))?;
    }
    Ok(())
}

/// Runs the plant on Zenoh in real time until `until_s` or SIGINT/SIGTERM.
pub(super) async fn run<H: CapsuleHardware>(
    settings: RosOptions,
    mut core: PlantCore<H>,
    opts: PlantOptions,
) -> Result<(LoopStats, CapsuleState)> {
    refuse_unported(&settings, &opts)?;
    let context = settings.zenoh_context()?;
    let node = settings.zenoh_node(&context)?;
    let topic = |name: &str, type_name| -> Result<_> {
        Ok(node.create_topic(&settings.ros_name(name)?, type_name, &qos::data()))
    };
    let states = node
        .create_publisher::<CapsuleState>(&topic(topics::STATE, types::state())?, None)
        .context("state publisher on Zenoh")?;
    let forces = node
        .create_subscription::<ActuatorForce>(
            &topic(topics::FORCE, types::force())?,
            Some(qos::data_reader()),
        )
        .context("force subscription on Zenoh")?;
    info!(
        "{}: real time at {} Hz, state {} <- force {}; not on Zenoh yet: parameters, /clock, \
         views, emergency stop, lifecycle services",
        settings.describe(),
        core.rate_hz,
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
    );
    core.configure().context("the plant's hardware")?;
    core.activate().context("the plant's hardware")?;
    let end = capsule_ros_base::signals::shutdown();
    tokio::pin!(end);
    let period = Duration::from_secs_f64(1.0 / core.rate_hz);
    let (start, wall) = (Instant::now(), Wall::start());
    let (mut refused, mut undecodable) = (Throttle::default(), Throttle::default());
    let until = opts.until_s.map(|s| (s * 1e9).round() as i64);
    let stopped = loop {
        let stamp = core.stamp();
        if let Err(e) = states.async_publish(core.state()).await {
            warn!("state not sent: {e:?}");
        }
        core.published(wall.now());
        if until.is_some_and(|u| stamp.to_nanos() >= u) {
            info!("reached the end time {:.3} s", stamp.as_secs_f64());
            break Ok(());
        }
        let due = start + period.mul_f64(core.stats.published as f64);
        tokio::select! {
            stopped = &mut end => break stopped,
            () = tokio::time::sleep_until(due.into()) => {}
        }
        loop {
            match forces.try_take() {
                Ok(Some((cmd, _))) => match core.on_command(&cmd, wall.now(), false) {
                    CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
                    outcome => log_refused(outcome, &cmd, &mut refused, core.rejected()),
                },
                Ok(None) => break,
                Err(e) => {
                    log_undecodable(&mut undecodable, &e);
                    break;
                }
            }
        }
        if core.check_watchdog(wall.now()) {
            warn!(
                "no command for {:.3} s: applying zero force",
                core.command_timeout
            );
        }
        core.step().context("the plant's hardware")?;
    };
    core.stats.finish();
    info!("loop: {} samples on Zenoh", core.stats.published);
    stopped.map(|()| (core.stats.clone(), core.state()))
}
