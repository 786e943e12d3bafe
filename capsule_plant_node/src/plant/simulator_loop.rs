//! The two pacings of node-paced hardware (the simulator): real time, and lock-step. Both run
//! on the sample loop's own thread, never on the one that serves the node's services.

use capsule_msgs::std_types::JointState;
use std::time::{Duration, Instant};

use capsule_msgs::std_types::Clock;
use capsule_msgs::CapsuleState;
use capsule_ros_base::error::{bail, Context as _, Result};
use futures::StreamExt;
use tracing::{info, warn};

use super::endpoints::{log_refused, log_undecodable, Endpoints};
use super::loop_control::{Exit, LoopControl};
use super::silence::{Silence, Verdict, Waiting};
use super::{CommandOutcome, InPlantRecording, PlantCore, PlantOptions};
use crate::hardware::CapsuleHardware;
use capsule_hardware::throttle::Throttle;

/// What a pacing loop runs on: the plant, its endpoints and options, the lifecycle's control
/// of the loop, and the in-plant recording when recording.
pub(super) struct SampleLoop<'a, H: CapsuleHardware> {
    pub(super) core: &'a mut PlantCore<H>,
    pub(super) io: &'a Endpoints,
    pub(super) opts: &'a PlantOptions,
    pub(super) control: &'a mut LoopControl,
    pub(super) rec: Option<&'a mut InPlantRecording>,
}

/// The current sample and, every `clock_every`-th sample, its /clock, recorded when recording.
pub(super) fn outgoing<H: CapsuleHardware>(
    core: &PlantCore<H>,
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
pub(super) fn take_joint_commands<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    sub: &ros2_client::dds::Subscription<JointState>,
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

/// Loop times: wall-clock seconds since the loop started, the clock DDS stamps receptions with.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wall(i64);

impl Wall {
    /// From now.
    pub(super) fn start() -> Wall {
        Wall(capsule_record::writer::now_ns() as i64)
    }
    /// Seconds since the start.
    pub(super) fn now(self) -> f64 {
        (capsule_record::writer::now_ns() as i64 - self.0) as f64 * 1e-9
    }
    /// When DDS received a message (now, if it does not say).
    pub(super) fn at(self, info: &ros2_client::MessageInfo) -> f64 {
        info.received_timestamp()
            .map_or_else(|| self.now(), |t| self.at_ns(t.to_nanos()))
    }
    /// Seconds since the start at `ns` of [`capsule_record::writer::now_ns`]'s clock.
    pub(super) fn at_ns(self, ns: impl TryInto<i64>) -> f64 {
        (ns.try_into().unwrap_or(i64::MAX) - self.0) as f64 * 1e-9
    }
}

/// Publishes the current sample (with /clock when due and wanted; the views; recorded when
/// recording); true when it was the last one (`--until-s`).
pub(super) fn publish_now<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Endpoints,
    opts: &PlantOptions,
    wall: Wall,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<bool> {
    let stamp = core.stamp();
    let (state, clock) = outgoing(core, opts, rec.as_deref_mut())?;
    if let Some(c) = clock.filter(|_| io.clock_wanted()) {
        let _ = io.clock_pub.publish(c);
    }
    if let (Some(d), Some(r)) = (io.publish_state(state, &core.stats), rec) {
        r.diagnostics(&d)?;
    }
    core.published(wall.now());
    let end = opts.until_s.map(|s| (s * 1e9).round() as i64);
    if end.is_some_and(|u| stamp.to_nanos() >= u) {
        info!("reached the end time {:.3} s", stamp.as_secs_f64());
        return Ok(true);
    }
    Ok(false)
}

/// Rate-limited logs of the commands not taken.
#[derive(Default)]
pub(super) struct CommandLogs {
    pub(super) refused: Throttle,
    pub(super) undecodable: Throttle,
    pub(super) joint_bad: Throttle,
}

/// Takes one force command received at `at` (recorded when recording).
pub(super) fn take_command<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    cmd: &capsule_msgs::ActuatorForce,
    info: Option<&ros2_client::MessageInfo>,
    at: f64,
    logs: &mut CommandLogs,
    rec: Option<&mut InPlantRecording>,
) -> Result<CommandOutcome> {
    let outcome = core.on_command(cmd, at, false);
    record_unless_resent(rec, cmd, info, outcome)?;
    match outcome {
        CommandOutcome::Accepted | CommandOutcome::Duplicate => {}
        refused => log_refused(refused, cmd, &mut logs.refused, core.rejected()),
    }
    Ok(outcome)
}

/// Takes every command received (force and JointState), without waiting.
pub(super) fn take_commands<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Endpoints,
    wall: Wall,
    logs: &mut CommandLogs,
    mut rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    while let Some((cmd, ns)) = io.next_answer() {
        take_command(core, &cmd, None, wall.at_ns(ns), logs, rec.as_deref_mut())?;
    }
    while let Some(sub) = io.force_sub() {
        match sub.take() {
            Ok(Some((cmd, info))) => {
                let at = wall.at(&info);
                take_command(core, &cmd, Some(&info), at, logs, rec.as_deref_mut())?;
            }
            Ok(None) => break,
            // the rest waits for the next sample: never spin on a reader that keeps failing
            Err(e) => {
                log_undecodable(&mut logs.undecodable, &e);
                break;
            }
        }
    }
    if let Some(sub) = &io.joint_sub {
        let at = |info: &ros2_client::MessageInfo| wall.at(info);
        take_joint_commands(core, sub, at, &mut logs.refused, &mut logs.joint_bad);
    }
    Ok(())
}

impl<H: CapsuleHardware> SampleLoop<'_, H> {
    /// Real time on one thread: publish sample `k`, sleep until `start + (k+1) / rate`, take every
    /// command received meanwhile, step. Commands are taken, not awaited, and the timer is this
    /// thread's own sleep, so a sample costs no wake-up of another thread in this process besides
    /// DDS's own (an earlier timer thread -> tokio -> DDS hand-off, with a wake-up per command,
    /// cost a third of the plant's CPU at 1 kHz). Latency is measured from DDS's reception time.
    pub(super) fn realtime(mut self) -> Result<Exit> {
        let period = Duration::from_secs_f64(1.0 / self.core.rate_hz);
        let start = Instant::now();
        let first = self.core.seq();
        let wall = Wall::start();
        let mut logs = CommandLogs::default();
        loop {
            // how late this sample goes out (its due time: start + k / rate)
            let due = start + period.mul_f64((self.core.seq() - first) as f64);
            let late = Instant::now().saturating_duration_since(due);
            self.core.stats.lateness.record(late.as_secs_f64());
            if publish_now(self.core, self.io, self.opts, wall, self.rec.as_deref_mut())? {
                return Ok(Exit::Over);
            }
            let due = start + period.mul_f64((self.core.seq() + 1 - first) as f64);
            let wait = due.saturating_duration_since(Instant::now());
            if !wait.is_zero() {
                std::thread::sleep(wait);
            }
            if let Some(exit) = self.control.poll(self.core) {
                return Ok(exit);
            }
            take_commands(self.core, self.io, wall, &mut logs, self.rec.as_deref_mut())?;
            if self.core.check_watchdog(wall.now()) {
                warn!(
                    "no command for {:.3} s: applying zero force",
                    self.core.command_timeout
                );
            }
            self.core.step().context("the plant's hardware")?;
        }
    }

    /// Lock-step: publishes the current sample, its clock and views, and records it.
    async fn publish_current(&mut self, now_s: f64) -> Result<()> {
        let (state, clock) = outgoing(self.core, self.opts, self.rec.as_deref_mut())?;
        if let Some(c) = clock.filter(|_| self.io.clock_wanted()) {
            let _ = self.io.clock_pub.async_publish(c).await;
        }
        let copy = self.io.views.per_sample.is_some().then(|| state.clone());
        self.io.send_state_async(state).await;
        if let (Some(d), Some(r)) = (
            self.io.views_of(copy, &self.core.stats),
            self.rec.as_deref_mut(),
        ) {
            r.diagnostics(&d)?;
        }
        self.core.published(now_s);
        Ok(())
    }

    /// Lock-step: publish sample `k`, wait for the command answering it (re-sending the sample
    /// every `retransmit`), step with it; never a step without its answer unless
    /// `--lockstep-on-silence zero-force` asks (see [`super::silence`]).
    pub(super) async fn lockstep(mut self) -> Result<Exit> {
        let start = Instant::now();
        let steady = move || start.elapsed().as_secs_f64();
        let commands = commands_of(self.io);
        tokio::pin!(commands);
        let woken = self.control.woken.clone();
        let until_nanos = self.opts.until_s.map(|s| (s * 1e9).round() as i64);
        let mut wait_started = steady();
        let silence = Silence::of(self.opts, self.core.command_timeout);
        let mut resend = tokio::time::interval(self.opts.retransmit);
        resend.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        let mut ever_commanded = false;
        let mut refused_logged = Throttle::default();
        let mut undecodable = Throttle::default();
        let mut need_publish = true;
        loop {
            if need_publish {
                self.publish_current(steady()).await?;
                need_publish = false;
                wait_started = steady();
                resend.reset();
            }
            if until_nanos.is_some_and(|u| self.core.stamp().to_nanos() >= u) {
                info!(
                    "reached the end time {:.3} s",
                    self.core.stamp().as_secs_f64()
                );
                return Ok(Exit::Over);
            }
            if let Some(exit) = self.control.poll(self.core) {
                return Ok(exit);
            }
            // in-process, the answer to the sample just sent is here already
            while let Some((cmd, _)) = self.io.next_answer() {
                let mut answers = Answers {
                    ever_commanded: &mut ever_commanded,
                    refused_logged: &mut refused_logged,
                };
                answers.take(self.core, (&cmd, None), steady(), self.rec.as_deref_mut())?;
            }
            // only an active plant steps: sim time stands still while inactive (before the
            // activation that follows configure, too), so the run does not depend on how long
            // the lifecycle took; nor while paused
            let holding = !self.core.active() || self.control.paused();
            if self.core.answered() && !holding {
                self.core.step().context("the plant's hardware")?;
                need_publish = true;
                continue;
            }
            tokio::select! {
                _ = woken.notified() => {}
                Some(r) = self.control.requests.recv() => {
                    if let Some(exit) = super::loop_control::apply(self.core, r) {
                        return Ok(exit);
                    }
                }
                msg = commands.select_next_some() => match msg {
                    Ok((cmd, info)) => {
                        let mut answers = Answers { ever_commanded: &mut ever_commanded, refused_logged: &mut refused_logged };
                        answers.take(self.core, (&cmd, Some(&info)), steady(), self.rec.as_deref_mut())?;
                    }
                    Err(e) => log_undecodable(&mut undecodable, &e),
                },
                _ = resend.tick() => {
                    let holding = !self.core.active() || self.control.paused();
                    if holding {
                        // sim time stands still while inactive or paused: the wait counts from
                        // activation (or resumption)
                        wait_started = steady();
                    }
                    let waiting = Waiting {
                        seq: self.core.seq(),
                        waited_s: steady() - wait_started,
                        ever_commanded,
                        publishers: self.io.force_publishers(),
                    };
                    // a node that is ending (a signal) ends at the next turn, without an error
                    let ending = self.control.halt.load(std::sync::atomic::Ordering::SeqCst);
                    match silence.judge(waiting) {
                        _ if holding || ending => {
                            send_again(self.core, self.io, self.rec.as_deref_mut()).await?;
                        }
                        Verdict::Resend => send_again(self.core, self.io, self.rec.as_deref_mut()).await?,
                        Verdict::ZeroForce => {
                            if self.core.force_stale() || !ever_commanded {
                                warn!("no command for seq {} within {:.3} s: applying zero force (--lockstep-on-silence zero-force)", self.core.seq(), waiting.waited_s);
                            }
                            ever_commanded = true;
                            self.core.step().context("the plant's hardware")?;
                            need_publish = true;
                        }
                        Verdict::GiveUp(e) => bail!("{e}"),
                    }
                }
            }
        }
    }
}

/// Lock-step: sends the current sample again (not recorded again: a recording holds each sample
/// once), and polls the recording's other readers meanwhile.
async fn send_again<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    io: &Endpoints,
    rec: Option<&mut InPlantRecording>,
) -> Result<()> {
    core.stats.resent += 1;
    if let Some(r) = rec {
        r.poll()?;
    }
    io.send_state_async(core.state()).await;
    Ok(())
}

/// The commands DDS delivers (none in-process: the answers come with each sample sent).
pub(super) fn commands_of(
    io: &Endpoints,
) -> impl futures::stream::FusedStream<
    Item = ros2_client::ReadResult<(capsule_msgs::ActuatorForce, ros2_client::MessageInfo)>,
> + '_ {
    // fused: `select_next_some` refuses a stream that says it has ended, as `Pending` does
    match io.force_sub() {
        Some(sub) => sub.async_stream().left_stream(),
        None => futures::stream::pending().fuse().right_stream(),
    }
}

/// Lock-step: takes a command received at `at` as the answer to the current sample (recorded
/// when recording; `info`: as DDS delivered it, `None`: in-process).
pub(super) fn take_answer<H: CapsuleHardware>(
    core: &mut PlantCore<H>,
    cmd: &capsule_msgs::ActuatorForce,
    info: Option<&ros2_client::MessageInfo>,
    at: f64,
    rec: Option<&mut InPlantRecording>,
) -> Result<CommandOutcome> {
    let outcome = core.on_command(cmd, at, true);
    record_unless_resent(rec, cmd, info, outcome)?;
    Ok(outcome)
}

/// Records a command that arrived, unless it repeats the one last accepted (the controller's
/// answer to a re-sent sample): a recording counts each command once, refused ones included.
fn record_unless_resent(
    rec: Option<&mut InPlantRecording>,
    cmd: &capsule_msgs::ActuatorForce,
    info: Option<&ros2_client::MessageInfo>,
    outcome: CommandOutcome,
) -> Result<()> {
    match rec {
        Some(r) if outcome != CommandOutcome::Duplicate => r.received(cmd, info),
        _ => Ok(()),
    }
}

/// Lock-step: what a command answering a sample does (recorded when recording).
struct Answers<'a> {
    ever_commanded: &'a mut bool,
    refused_logged: &'a mut Throttle,
}

impl Answers<'_> {
    /// Takes `received` (the command, and as DDS delivered it or `None` in-process) at `now`.
    fn take<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        received: (
            &capsule_msgs::ActuatorForce,
            Option<&ros2_client::MessageInfo>,
        ),
        now: f64,
        rec: Option<&mut InPlantRecording>,
    ) -> Result<()> {
        let (cmd, info) = received;
        match take_answer(core, cmd, info, now, rec)? {
            CommandOutcome::Accepted => *self.ever_commanded = true,
            CommandOutcome::Duplicate => {}
            refused => log_refused(refused, cmd, self.refused_logged, core.rejected()),
        }
        Ok(())
    }
}
