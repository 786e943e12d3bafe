//! The loop of hardware that paces itself (a device): a sample is published when the device's
//! measurement arrives, and the controller's answer to it goes to the device the moment it
//! arrives, not at the next sample. Every measurement is answered once: by the controller's
//! force, or, when none came before the next measurement, with zero by the driver. Nothing here
//! waits on the device: its line is read on a thread of its own, which wakes this loop.
//!
//! - real time: every measurement is a sample; commands answering the current one are written at
//!   once (older ones are held, as the simulator's pacing holds them, and not written);
//! - lock-step: the next measurement is taken only once the current sample is answered; the
//!   sample is re-published every `retransmit` (what comes of a silent controller: `silence`).
//!
//! While the device sends nothing (no line, no hello, silent), samples go on at the node's rate
//! with the last measurement, so `/diagnostics` and the summary say what is wrong; before the
//! first measurement (up to the start-up timeout) none is published.

use std::sync::Arc;
use std::time::{Duration, Instant};

use capsule_ros_base::error::{bail, Context as _, Result};
use futures::StreamExt;
use tokio::sync::Notify;
use tracing::warn;

use super::endpoints::{log_undecodable, Endpoints};
use super::loop_control::{apply, Exit};
use super::silence::{Silence, Verdict, Waiting};
use super::simulator_loop::{
    commands_of, publish_now, take_answer, take_command, take_joint_commands, CommandLogs,
    SampleLoop, Wall,
};
use super::{CommandOutcome, InPlantRecording, Pacing, PlantCore, PlantOptions};
use crate::hardware::{CapsuleHardware, Reading};

/// Where the loop is.
struct Paced<'a> {
    io: &'a Endpoints,
    opts: &'a PlantOptions,
    lockstep: bool,
    wall: Wall,
    /// A measurement has been published since configure (or the start-up wait is over).
    started: bool,
    /// When the start-up wait ends.
    startup_until: Instant,
    /// When a sample goes out without a measurement.
    due: Instant,
    /// Lock-step: when the wait for the current answer started, and whether any came yet.
    waited_from: Instant,
    ever_commanded: bool,
    logs: CommandLogs,
}

impl Paced<'_> {
    /// How long the device is given for its next measurement: two periods and 5 ms while it is
    /// well, one period while it is not (the node keeps its rate).
    fn next_due<H: CapsuleHardware>(core: &PlantCore<H>) -> Instant {
        let period = Duration::from_secs_f64(1.0 / core.rate_hz);
        let faulted = core.health().is_some_and(|h| h.fault.is_some());
        Instant::now()
            + if faulted {
                period
            } else {
                period * 2 + Duration::from_millis(5)
            }
    }

    /// Whether the loop may take the next measurement: in lock-step only once the current
    /// sample is answered.
    fn may_advance<H: CapsuleHardware>(&self, core: &PlantCore<H>) -> bool {
        !self.lockstep || !self.started || core.written()
    }

    /// Takes what the device sent; true when the run is over (`--until-s`).
    fn drain<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        mut rec: Option<&mut InPlantRecording>,
    ) -> Result<bool> {
        while self.may_advance(core) {
            let reading = core.read(Instant::now()).context("the plant's hardware")?;
            match reading {
                Reading::Timeout => return Ok(false),
                Reading::Sample(_) if !self.started => {
                    self.started = true;
                    core.first_sample(reading);
                }
                // not a sample to start with
                Reading::Fault(_) if !self.started => continue,
                r => core.next_sample(r),
            }
            if self.publish(core, rec.as_deref_mut())? {
                return Ok(true);
            }
        }
        Ok(false)
    }

    fn publish<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        rec: Option<&mut InPlantRecording>,
    ) -> Result<bool> {
        self.due = Self::next_due(core);
        self.waited_from = Instant::now();
        publish_now(core, self.io, self.opts, self.wall, rec)
    }

    /// No measurement by `due`: the last one again (after the start-up wait).
    fn overdue<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        rec: Option<&mut InPlantRecording>,
    ) -> Result<bool> {
        if !self.started {
            if Instant::now() < self.startup_until {
                self.due = Self::next_due(core);
                return Ok(false);
            }
            warn!(
                "no measurement from the device within {:?}: starting without (zero force until one comes)",
                self.opts.startup_timeout
            );
            self.started = true;
        } else {
            core.next_sample(Reading::Timeout);
        }
        self.publish(core, rec)
    }

    /// Lock-step: no answer yet; re-publish (not recorded again), or what [`Silence`] says.
    fn unanswered<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        rec: Option<&mut InPlantRecording>,
    ) -> Result<()> {
        if !core.active() {
            // the wait counts from activation
            self.waited_from = Instant::now();
        }
        let waiting = Waiting {
            seq: core.seq(),
            waited_s: self.waited_from.elapsed().as_secs_f64(),
            ever_commanded: self.ever_commanded,
            publishers: self.io.force_publishers(),
        };
        match Silence::of(self.opts, core.command_timeout).judge(waiting) {
            Verdict::ZeroForce if core.active() => {
                if core.force_stale() || !self.ever_commanded {
                    warn!(
                        "no command for seq {} within {:.3} s: applying zero force (--lockstep-on-silence zero-force)",
                        core.seq(),
                        waiting.waited_s
                    );
                }
                self.ever_commanded = true;
                return core.answer().context("the plant's hardware");
            }
            Verdict::GiveUp(e) if core.active() => bail!("{e}"),
            _ => {}
        }
        core.stats.resent += 1;
        if let Some(r) = rec {
            r.poll()?;
        }
        self.io.send_state(core.state());
        Ok(())
    }

    /// A command received at `at` (`info`: as DDS delivered it; `None`: in-process): held, and
    /// written at once if it answers the current sample.
    fn command<H: CapsuleHardware>(
        &mut self,
        core: &mut PlantCore<H>,
        cmd: &capsule_msgs::ActuatorForce,
        info: Option<&ros2_client::MessageInfo>,
        at: f64,
        rec: Option<&mut InPlantRecording>,
    ) -> Result<()> {
        let outcome = if self.lockstep {
            take_answer(core, cmd, info, at, rec)?
        } else {
            take_command(core, cmd, info, at, &mut self.logs, rec)?
        };
        if outcome == CommandOutcome::Accepted {
            self.ever_commanded = true;
            // the answer to the current sample goes out now
            if self.started && cmd.state_seq == core.seq() {
                core.answer().context("the plant's hardware")?;
            }
        }
        Ok(())
    }
}

impl<H: CapsuleHardware> SampleLoop<'_, H> {
    /// Runs hardware that paces itself (`ready` wakes the loop when it has something) until the
    /// end time, a signal, a cleanup or a shutdown.
    pub(super) async fn paced(mut self, ready: Arc<Notify>) -> Result<Exit> {
        let lockstep = self.opts.pacing == Pacing::Lockstep;
        let mut p = Paced {
            io: self.io,
            opts: self.opts,
            lockstep,
            wall: Wall::start(),
            started: false,
            startup_until: Instant::now() + self.opts.startup_timeout,
            due: Instant::now() + self.opts.startup_timeout.min(Duration::from_millis(100)),
            waited_from: Instant::now(),
            ever_commanded: false,
            logs: CommandLogs::default(),
        };
        let commands = commands_of(self.io);
        tokio::pin!(commands);
        let woken = self.control.woken.clone();
        let period = Duration::from_secs_f64(1.0 / self.core.rate_hz);
        let mut tick = tokio::time::interval(if lockstep {
            self.opts.retransmit
        } else {
            period
        });
        tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            if let Some(exit) = self.control.poll(self.core) {
                return Ok(exit);
            }
            if p.drain(self.core, self.rec.as_deref_mut())? {
                return Ok(Exit::Over);
            }
            while let Some((cmd, ns)) = self.io.next_answer() {
                p.command(
                    self.core,
                    &cmd,
                    None,
                    p.wall.at_ns(ns),
                    self.rec.as_deref_mut(),
                )?;
            }
            let advance = p.may_advance(self.core);
            tokio::select! {
                biased;
                _ = woken.notified() => {}
                Some(r) = self.control.requests.recv() => {
                    if let Some(exit) = apply(self.core, r) {
                        return Ok(exit);
                    }
                }
                msg = commands.select_next_some() => match msg {
                    Ok((cmd, info)) => {
                        let at = p.wall.at(&info);
                        p.command(self.core, &cmd, Some(&info), at, self.rec.as_deref_mut())?;
                    }
                    Err(e) => log_undecodable(&mut p.logs.undecodable, &e),
                },
                _ = ready.notified() => {}
                _ = tokio::time::sleep_until(p.due.into()), if advance => {
                    if p.overdue(self.core, self.rec.as_deref_mut())? {
                        return Ok(Exit::Over);
                    }
                }
                _ = tick.tick() => {
                    if lockstep {
                        if p.started && !self.core.written() {
                            p.unanswered(self.core, self.rec.as_deref_mut())?;
                        }
                    } else {
                        // JointState commands and the watchdog, once a period
                        if let Some(sub) = &self.io.joint_sub {
                            let at = |info: &ros2_client::MessageInfo| p.wall.at(info);
                            let logs = &mut p.logs;
                            take_joint_commands(self.core, sub, at, &mut logs.refused, &mut logs.joint_bad);
                            if p.started && self.core.answered() {
                                self.core.answer().context("the plant's hardware")?;
                            }
                        }
                        if self.core.check_watchdog(p.wall.now()) {
                            warn!("no command for {:.3} s: applying zero force", self.core.command_timeout);
                        }
                    }
                }
            }
        }
    }
}
