//! The plant on Zenoh (rmw_zenoh_cpp's protocol, through ros2-client's Zenoh backend): the
//! state out on `/capsule/state`, the force command in, the same [`PlantCore`] as on DDS, in
//! real time or in lock-step (each step waits for the command answering the last sample,
//! re-sending it, as on DDS: [`super::silence`]). Served by their own tasks with the same logic
//! as on DDS ([`NodeOn`]): the parameters (read-only), the emergency stop
//! ([`crate::emergency_stop`]), the pause in lock-step ([`crate::pause`]) and the lifecycle
//! (`lifecycle_services`: the loop takes its steps between samples, as on DDS). What is not
//! ported yet is refused by name before any work ([`refuse_unported`]); `/clock` and the views
//! are not served on Zenoh yet, which the log says at start.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use capsule_hardware::throttle::Throttle;
use capsule_msgs::names::topics;
use capsule_msgs::{ActuatorForce, CapsuleState};
use capsule_ros_base::error::{bail, Context as _, Result};
use capsule_ros_base::node_on::NodeOn;
use capsule_ros_base::{qos, ros_options::RosOptions, types};
use ros2_client::zenoh::{Node, Publisher, Subscription};
use tokio::sync::{mpsc, Notify};
use tracing::{info, warn};

use super::endpoints::{log_refused, log_undecodable, MATCH_GRACE};
use super::lifecycle_services;
use super::loop_control::{apply, apply_unconfigured, Exit, Request};
use super::silence::{Silence, Verdict, Waiting};
use super::simulator_loop::Wall;
use super::{CommandOutcome, LoopStats, Pacing, PlantCore, PlantOptions};
use crate::hardware::CapsuleHardware;

/// Refuses, on Zenoh, what the plant does not do there yet.
fn refuse_unported(settings: &RosOptions, opts: &PlantOptions) -> Result<()> {
    let mw = &settings.middleware;
    let asked = [
        (opts.record.is_some(), "--record"),
        (opts.joint_commands, "--joint-commands"),
        (settings.use_sim_time, "--use-sim-time"),
    ];
    for (_, what) in asked.iter().filter(|(on, _)| *on) {
        mw.refuse_on_zenoh(&format!("the plant's {what}"))?;
    }
    Ok(())
}

/// The plant's endpoints on Zenoh, and its node (the graph it asks for subscribers and
/// publishers).
struct Io {
    node: Node,
    states: Publisher<CapsuleState>,
    forces: Subscription<ActuatorForce>,
}

impl Io {
    /// The state publisher and the force subscription of a new node, named as on DDS.
    fn create(settings: &RosOptions, context: &ros2_client::zenoh::Context) -> Result<Io> {
        let node = settings.zenoh_node(context)?;
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
        Ok(Io {
            node,
            states,
            forces,
        })
    }

    /// Sends `state` (a failure is logged: the next sample, or lock-step's re-send, follows).
    async fn send(&self, state: CapsuleState) {
        if let Err(e) = self.states.async_publish(state).await {
            warn!("state not sent: {e:?}");
        }
    }

    /// `--wait-subscribers`: until `n` subscriptions of the state are announced in the graph
    /// (liveliness), at most `timeout`.
    async fn wait_subscribers(
        &self,
        settings: &RosOptions,
        n: usize,
        timeout: Duration,
    ) -> Result<()> {
        if n == 0 {
            return Ok(());
        }
        let started = Instant::now();
        while self.states.get_subscription_count(&self.node) < n {
            if started.elapsed() > timeout {
                bail!(
                    "only {} of {n} subscribers announced {} within {timeout:?}",
                    self.states.get_subscription_count(&self.node),
                    settings.resolve_name(topics::STATE),
                );
            }
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        // a token announces a subscriber declared a moment before; the router may pass the
        // declaration on a moment after
        tokio::time::sleep(MATCH_GRACE).await;
        info!("{n} subscribers announced: starting");
        Ok(())
    }
}

/// Runs the plant on Zenoh until `until_s` or SIGINT/SIGTERM.
pub(super) async fn run<H: CapsuleHardware>(
    settings: RosOptions,
    mut core: PlantCore<H>,
    opts: PlantOptions,
) -> Result<(LoopStats, CapsuleState)> {
    refuse_unported(&settings, &opts)?;
    let context = settings.zenoh_context()?;
    let io = Io::create(&settings, &context)?;
    // ROS parameters (read-only here): served by their own task, as on DDS
    let _params = capsule_ros_base::param_services::serve_on_zenoh(
        &io.node,
        &settings,
        opts.params.clone(),
        capsule_ros_base::params::no_rules,
        || capsule_msgs::Time::from_nanos(capsule_record::writer::now_ns() as i64),
    )?;
    // the emergency stop: its own task answers, the loop reads the flag each step
    crate::emergency_stop::serve(
        NodeOn::Zenoh(&io.node),
        &settings,
        core.emergency_stop(),
        core.stopper(),
    )?;
    // the lifecycle: its own tasks answer, the loop takes the steps between samples
    let (lifecycle, requests) = lifecycle_services::serve(NodeOn::Zenoh(&io.node), &settings)?;
    // the pause (lock-step): its own task answers, the loop holds while the flag is set
    let mut control = Control {
        paused: Arc::new(AtomicBool::new(opts.start_paused)),
        woken: Arc::new(Notify::new()),
        requests,
    };
    match opts.pacing {
        Pacing::Lockstep => crate::pause::serve(
            NodeOn::Zenoh(&io.node),
            &settings,
            control.paused.clone(),
            control.woken.clone(),
        )?,
        Pacing::Realtime if opts.start_paused => bail!("{}", crate::pause::NEEDS_LOCKSTEP),
        Pacing::Realtime => {}
    }
    info!(
        "{}: {:?} at {} Hz, state {} <- force {}, parameters, emergency stop, pause \
         (lock-step), lifecycle{}; not on Zenoh yet: /clock, views, recording",
        settings.describe(),
        opts.pacing,
        core.rate_hz,
        settings.resolve_name(topics::STATE),
        settings.resolve_name(topics::FORCE),
        if opts.autostart {
            ""
        } else {
            " (unconfigured until `ros2 lifecycle set` configures it)"
        }
    );
    let end = capsule_ros_base::signals::shutdown();
    tokio::pin!(end);
    let stopped = tokio::select! {
        stopped = &mut end => stopped,
        waited = io.wait_subscribers(&settings, opts.wait_subscribers, opts.startup_timeout) => {
            waited?;
            // --autostart: configure and activate, through the lifecycle as on DDS
            let started = async {
                if opts.autostart {
                    lifecycle.autostart().await?;
                }
                std::future::pending::<Result<()>>().await
            };
            tokio::select! {
                stopped = &mut end => stopped,
                over = drive(&mut core, &io, &opts, &mut control) => over,
                failed = started => failed,
            }
        }
    };
    let _ = core.cleanup();
    core.stats.finish();
    info!("loop: {} samples on Zenoh", core.stats.published);
    stopped.map(|()| (core.stats.clone(), core.state()))
}

/// What reaches the loop from the services: the pause (its flag, and the wake-up when it
/// changes) and the lifecycle's steps.
struct Control {
    paused: Arc<AtomicBool>,
    woken: Arc<Notify>,
    requests: mpsc::UnboundedReceiver<Request>,
}

impl Control {
    /// Whether the plant is paused.
    fn paused(&self) -> bool {
        self.paused.load(Ordering::SeqCst)
    }

    /// Applies the lifecycle steps waiting, without waiting for any; `Some` when the pacing
    /// loop must return.
    fn poll<H: CapsuleHardware>(&mut self, core: &mut PlantCore<H>) -> Option<Exit> {
        while let Ok(r) = self.requests.try_recv() {
            if let Some(exit) = apply(core, r) {
                return Some(exit);
            }
        }
        None
    }
}

/// The plant's life, as on DDS: unconfigured until configured, then the pacing loop until a
/// cleanup (unconfigured again) or the end.
async fn drive<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Io,
    opts: &PlantOptions,
    control: &mut Control,
) -> Result<()> {
    loop {
        let Some(request) = control.requests.recv().await else {
            return Ok(());
        };
        match apply_unconfigured(core, request) {
            Some(Exit::Over) => return Ok(()),
            Some(Exit::CleanedUp) => continue,
            None => {}
        }
        let exit = match opts.pacing {
            Pacing::Realtime => realtime(core, io, opts, control).await?,
            Pacing::Lockstep => lockstep(core, io, opts, control).await?,
        };
        if exit == Exit::Over {
            return Ok(());
        }
    }
}

/// Sends the current sample; true when it was the last one (`--until-s`), said in the log.
async fn publish<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Io,
    opts: &PlantOptions,
    wall: Wall,
) -> bool {
    io.send(core.state()).await;
    core.published(wall.now());
    let stamp = core.stamp();
    let over = opts
        .until_s
        .is_some_and(|s| stamp.to_nanos() >= (s * 1e9).round() as i64);
    if over {
        info!("reached the end time {:.3} s", stamp.as_secs_f64());
    }
    over
}

/// Real time: sample `k` out at `start + k / rate`, the lifecycle's steps and the commands
/// received meanwhile taken, step (zero force unless active).
async fn realtime<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Io,
    opts: &PlantOptions,
    control: &mut Control,
) -> Result<Exit> {
    let period = Duration::from_secs_f64(1.0 / core.rate_hz);
    let (start, wall) = (Instant::now(), Wall::start());
    let (mut refused, mut undecodable) = (Throttle::default(), Throttle::default());
    loop {
        if publish(core, io, opts, wall).await {
            return Ok(Exit::Over);
        }
        let due = start + period.mul_f64(core.stats.published as f64);
        tokio::time::sleep_until(due.into()).await;
        if let Some(exit) = control.poll(core) {
            return Ok(exit);
        }
        loop {
            match io.forces.try_take() {
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
    }
}

/// Lock-step: publish sample `k`, wait for the command answering it (re-sending the sample
/// every `retransmit`), step with it; never a step without its answer unless
/// `--lockstep-on-silence zero-force` asks; the controller gone (its force publisher's token
/// withdrawn, or silent for `lockstep_give_up_s`) ends the run with an error. Paused, it is
/// answered but takes no step: the sample is re-sent, sim time stands still; so while inactive.
async fn lockstep<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Io,
    opts: &PlantOptions,
    control: &mut Control,
) -> Result<Exit> {
    let wall = Wall::start();
    let silence = Silence::of(opts, core.command_timeout);
    let mut resend = tokio::time::interval(opts.retransmit);
    resend.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut ever_commanded = false;
    let (mut refused, mut undecodable) = (Throttle::default(), Throttle::default());
    loop {
        if publish(core, io, opts, wall).await {
            return Ok(Exit::Over);
        }
        let mut sent = wall.now();
        resend.reset();
        while !core.answered() || !core.active() || control.paused() {
            let woken = control.woken.clone();
            tokio::select! {
                _ = woken.notified() => {}
                Some(r) = control.requests.recv() => {
                    if let Some(exit) = apply(core, r) {
                        return Ok(exit);
                    }
                }
                msg = io.forces.async_take() => match msg {
                    Ok((cmd, _)) => match core.on_command(&cmd, wall.now(), true) {
                        CommandOutcome::Accepted => ever_commanded = true,
                        CommandOutcome::Duplicate => {}
                        outcome => log_refused(outcome, &cmd, &mut refused, core.rejected()),
                    },
                    Err(e) => log_undecodable(&mut undecodable, &e),
                },
                _ = resend.tick() => {
                    if !core.active() || control.paused() {
                        // sim time stands still while inactive or paused: the wait counts from
                        // activation (or resumption)
                        sent = wall.now();
                        core.stats.resent += 1;
                        io.send(core.state()).await;
                        continue;
                    }
                    let waiting = Waiting {
                        seq: core.seq(),
                        waited_s: wall.now() - sent,
                        ever_commanded,
                        publishers: Some(io.forces.get_publisher_count(&io.node)),
                    };
                    match silence.judge(waiting) {
                        Verdict::Resend => {
                            core.stats.resent += 1;
                            io.send(core.state()).await;
                        }
                        Verdict::ZeroForce => {
                            if core.force_stale() || !ever_commanded {
                                warn!("no command for seq {} within {:.3} s: applying zero force (--lockstep-on-silence zero-force)", core.seq(), waiting.waited_s);
                            }
                            ever_commanded = true;
                            break;
                        }
                        Verdict::GiveUp(e) => bail!("{e}"),
                    }
                }
            }
        }
        core.step().context("the plant's hardware")?;
    }
}
