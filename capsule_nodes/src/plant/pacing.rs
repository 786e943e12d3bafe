//! The two pacings: real time on one thread, and lock-step.

use capsule_msgs::std_types::JointState;
use std::time::{Duration, Instant};

use capsule_msgs::std_types::Clock;
use capsule_msgs::CapsuleState;
use capsule_ros_base::error::Result;
use futures::StreamExt;
use tracing::{info, warn};

use super::node::{log_refused, log_undecodable, Endpoints};
use super::{CommandOutcome, InPlantRecording, PlantCore, PlantOptions, PlantSim};
use capsule_ros_base::throttle::Throttle;

/// The current sample and, every `clock_every`-th sample, its /clock, recorded when recording.
pub(super) fn outgoing<S: PlantSim>(
    core: &PlantCore<S>,
    opts: &PlantOptions,
    rec: Option<&mut InPlantRecording>,
) -> Result<(CapsuleState, Option<Clock>)> {
    let clock = core
        .seq()
        .is_multiple_of(opts.clock_every.max(1))
        .then_some(Clock {
            clock: core.stamp(),
        });
    let state = core.state();
    if let Some(r) = rec {
        r.published(&state, clock.as_ref())?;
        r.poll()?;
    }
    Ok((state, clock))
}

/// Takes every JointState command received (see [`crate::joint_commands`]): each answers the
/// current sample and goes through [`PlantCore::on_command`] as a force command does.
fn take_joint_commands<S: PlantSim>(
    core: &mut PlantCore<S>,
    sub: &ros2_client::Subscription<JointState>,
    at: impl Fn(&ros2_client::MessageInfo) -> f64,
    refused_logged: &mut Throttle,
    bad: &mut Throttle,
) {
    loop {
        match sub.take() {
            Ok(Some((js, info))) => {
                match crate::joint_commands::to_force(&js, core.seq(), core.stamp(), &core.frame_id)
                {
                    Ok(cmd) => match core.on_command(&cmd, at(&info), false) {
                        CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, refused_logged, core.rejected()),
                    },
                    Err(e) => {
                        if bad.tick() {
                            warn!("JointState command not taken ({} so far): {e}", bad.seen());
                        }
                    }
                }
            }
            Ok(None) => break,
            Err(e) => {
                if bad.tick() {
                    warn!(
                        "undecodable JointState command ({} so far): {e:?}",
                        bad.seen()
                    );
                }
                break;
            }
        }
    }
}

/// Real time on one thread: publish sample `k`, sleep until `start + (k+1) / rate`, take every
/// command received meanwhile, step. Commands are taken, not awaited, and the timer is this
/// thread's own sleep, so a sample costs no wake-up of another thread in this process besides
/// DDS's own (an earlier timer thread -> tokio -> DDS hand-off, with a wake-up per command,
/// cost a third of the plant's CPU at 1 kHz). Latency is measured from DDS's reception time.
pub(super) fn realtime_loop<S: PlantSim>(
    core: &mut PlantCore<S>,
    io: &Endpoints,
    opts: &PlantOptions,
    stop: &std::sync::atomic::AtomicBool,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    let period = Duration::from_secs_f64(1.0 / core.rate_hz);
    let until_nanos = opts.until_s.map(|s| (s * 1e9).round() as i64);
    let start = Instant::now();
    // loop times are wall-clock seconds since the start, the clock DDS stamps receptions with
    let wall0 = capsule_record::writer::now_ns() as i64;
    let now = || (capsule_record::writer::now_ns() as i64 - wall0) as f64 * 1e-9;
    let mut refused_logged = Throttle::default();
    let mut undecodable = Throttle::default();
    let mut joint_bad = Throttle::default();
    loop {
        let stamp = core.stamp();
        let (state, clock) = outgoing(core, opts, rec.as_deref_mut())?;
        if let Some(c) = clock.filter(|_| io.clock_wanted()) {
            let _ = io.clock_pub.publish(c);
        }
        if let (Some(d), Some(r)) = (io.publish_state(state, &core.stats), rec.as_deref_mut()) {
            r.diagnostics(&d)?;
        }
        core.published(now());
        if until_nanos.is_some_and(|u| stamp.to_nanos() >= u) {
            info!("reached the end time {:.3} s", stamp.as_secs_f64());
            return Ok(());
        }
        let due = start + period.mul_f64((core.seq() + 1) as f64);
        let wait = due.saturating_duration_since(Instant::now());
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        if stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Ok(());
        }
        loop {
            match io.force_sub.take() {
                Ok(Some((cmd, info))) => {
                    if let Some(r) = rec.as_deref_mut() {
                        r.received(&cmd, &info)?;
                    }
                    let at = info
                        .received_timestamp()
                        .map_or_else(now, |t| (t.to_nanos() - wall0) as f64 * 1e-9);
                    match core.on_command(&cmd, at, false) {
                        CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, &mut refused_logged, core.rejected()),
                    }
                }
                Ok(None) => break,
                // the rest waits for the next sample: never spin on a reader that keeps failing
                Err(e) => {
                    log_undecodable(&mut undecodable, &e);
                    break;
                }
            }
        }
        if let Some(sub) = &io.joint_sub {
            let at = |info: &ros2_client::MessageInfo| {
                info.received_timestamp()
                    .map_or_else(now, |t| (t.to_nanos() - wall0) as f64 * 1e-9)
            };
            take_joint_commands(core, sub, at, &mut refused_logged, &mut joint_bad);
        }
        if core.check_watchdog(now()) {
            warn!(
                "no command for {:.3} s: applying zero force",
                core.command_timeout
            );
        }
        core.step()?;
    }
}

/// Lock-step: publish sample `k`, wait for the command answering it (re-sending the sample
/// every `retransmit`), step with it; zero force after the command timeout.
pub(super) async fn lockstep_loop<S: PlantSim>(
    core: &mut PlantCore<S>,
    io: &Endpoints,
    opts: &PlantOptions,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    let start = Instant::now();
    let steady = move || start.elapsed().as_secs_f64();
    let commands = io.force_sub.async_stream();
    tokio::pin!(commands);
    let shutdown = capsule_ros_base::ros::shutdown_signal();
    tokio::pin!(shutdown);
    let until_nanos = opts.until_s.map(|s| (s * 1e9).round() as i64);
    let mut wait_started = steady();
    let mut resend = tokio::time::interval(opts.retransmit);
    resend.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut ever_commanded = false;
    let mut refused_logged = Throttle::default();
    let mut undecodable = Throttle::default();
    let mut need_publish = true;
    loop {
        if need_publish {
            let (state, clock) = outgoing(core, opts, rec.as_deref_mut())?;
            if let Some(c) = clock.filter(|_| io.clock_wanted()) {
                let _ = io.clock_pub.async_publish(c).await;
            }
            let copy = io.views.per_sample.is_some().then(|| state.clone());
            if let Err(e) = io.state_pub.async_publish(state).await {
                warn!("state not sent: {e:?}");
            }
            if let (Some(d), Some(r)) = (io.views_of(copy, &core.stats), rec.as_deref_mut()) {
                r.diagnostics(&d)?;
            }
            core.published(steady());
            need_publish = false;
            wait_started = steady();
            resend.reset();
        }
        if until_nanos.is_some_and(|u| core.stamp().to_nanos() >= u) {
            info!("reached the end time {:.3} s", core.stamp().as_secs_f64());
            return Ok(());
        }
        if core.answered() {
            core.step()?;
            need_publish = true;
            continue;
        }
        tokio::select! {
            sig = &mut shutdown => {
                match sig {
                    Ok(s) => info!("{s}: shutting down"),
                    Err(e) => warn!("{}", capsule_ros_base::error::chain(&e)),
                }
                return Ok(());
            }
            msg = commands.select_next_some() => match msg {
                Ok((cmd, info)) => {
                    if let Some(r) = rec.as_deref_mut() {
                        r.received(&cmd, &info)?;
                    }
                    match core.on_command(&cmd, steady(), true) {
                        CommandOutcome::Accepted => ever_commanded = true,
                        CommandOutcome::Duplicate => {}
                        refused => log_refused(refused, &cmd, &mut refused_logged, core.rejected()),
                    }
                }
                Err(e) => log_undecodable(&mut undecodable, &e),
            },
            _ = resend.tick() => {
                let waited = steady() - wait_started;
                let limit = if ever_commanded { core.command_timeout } else { opts.startup_timeout.as_secs_f64() };
                if waited > limit {
                    if core.force_stale() || !ever_commanded {
                        warn!("no command for seq {} within {:.3} s: applying zero force", core.seq(), limit);
                    }
                    ever_commanded = true;
                    core.step()?;
                    need_publish = true;
                } else {
                    let state = core.state();
                    if let Some(r) = rec.as_deref_mut() {
                        r.published(&state, None)?;
                        r.poll()?;
                    }
                    if let Err(e) = io.state_pub.async_publish(state).await {
                        warn!("state not re-sent: {e:?}");
                    }
                }
            }
        }
    }
}
