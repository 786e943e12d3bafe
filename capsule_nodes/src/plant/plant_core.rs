//! The plant's logic without DDS: the zero-order hold of the last accepted command, command
//! validation (non-finite refused, huge saturated, late or future refused), the stale-command
//! watchdog, SI conversion, and the samples it publishes.

use capsule_msgs::{ActuatorForce, CapsuleState, Header, Time};
use capsule_plant::scene::PhysicalScale;
use capsule_plant::Snapshot;
use capsule_record::sample::state_message;
use capsule_ros_base::error::Result;
use tracing::info;

use super::LoopStats;
use crate::command_gate::{self, CommandGate, DEFAULT_MAX_FORCE_PF};

/// What the node needs from its capsule (the simulator, or a device behind a driver): hold a
/// force until a time, and report a sample.
pub trait PlantSim {
    /// Holds the non-dimensional actuator force `force` until `tau_end` (a simulator
    /// integrates; a driver sends it and takes the next measurement).
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()>;
    /// The current sample (NaN where a device does not measure).
    fn sample(&self) -> Snapshot;
    /// Brings the capsule up before the first sample, waiting at most `timeout`: a driver
    /// opens its line and waits for the device's first measurement (and goes on without one,
    /// saying so); a simulator is ready at once.
    fn start(&mut self, timeout: std::time::Duration) {
        let _ = timeout;
    }
    /// How a device is doing, for `/diagnostics` and the summary; `None` for a simulator,
    /// which cannot fail between steps.
    fn health(&self) -> Option<&SourceHealth> {
        None
    }
}

/// A plant chosen at run time (`--source`).
impl<P: PlantSim + ?Sized> PlantSim for Box<P> {
    fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
        (**self).advance(force, tau_end)
    }
    fn sample(&self) -> Snapshot {
        (**self).sample()
    }
    fn health(&self) -> Option<&SourceHealth> {
        (**self).health()
    }
    fn start(&mut self, timeout: std::time::Duration) {
        (**self).start(timeout)
    }
}

/// How a plant's device is doing.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SourceHealth {
    /// What the plant is (`serial /dev/ttyUSB0 at 921600 baud`).
    pub label: String,
    /// What is wrong now, if anything (the force is zero while it lasts).
    pub fault: Option<String>,
    /// Counters and limits, as `/diagnostics` key-value pairs.
    pub values: Vec<(&'static str, String)>,
}

/// Why a command was not taken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CommandOutcome {
    /// Taken; held from the next step on.
    Accepted,
    /// A repeat of the last accepted command (lock-step re-answers): ignored, not counted.
    Duplicate,
    /// Force NaN or infinite: refused and counted.
    NonFinite,
    /// Stamped before the last accepted command, or answering an old sample: refused, counted.
    Late,
    /// Answering a sample not yet published (lock-step), or stamped after the newest sample:
    /// refused, counted.
    Future,
}

/// The plant node's logic around a simulator.
pub struct PlantCore<S: PlantSim> {
    pub(super) sim: S,
    pub(super) scale: PhysicalScale,
    pub(super) rate_hz: f64,
    pub(super) command_timeout: f64,
    pub(super) frame_id: String,
    pub(super) step: u64,
    pub(super) held_n: f64,
    pub(super) last_accepted: Option<(i64, u64, f64)>,
    pub(super) last_command_at: Option<f64>,
    pub(super) stale: bool,
    pub(super) rejected: u32,
    pub(super) answered_current: bool,
    pub(super) published_at: Option<f64>,
    pub(super) gate: CommandGate,
    /// Engaged: zero force from the next step on (see [`crate::emergency_stop`]).
    pub(super) emergency_stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    /// Statistics of the loop.
    pub stats: LoopStats,
}

impl<S: PlantSim> PlantCore<S> {
    /// A plant sampling at `rate_hz`, falling back to zero force after `command_timeout` \[s\].
    pub fn new(sim: S, scale: PhysicalScale, rate_hz: f64, command_timeout: f64) -> Self {
        PlantCore {
            sim,
            scale,
            rate_hz,
            command_timeout,
            frame_id: "odom".to_string(),
            step: 0,
            held_n: 0.0,
            last_accepted: None,
            last_command_at: None,
            stale: true,
            rejected: 0,
            answered_current: false,
            published_at: None,
            gate: CommandGate::new(DEFAULT_MAX_FORCE_PF * scale.force_n()),
            emergency_stop: Default::default(),
            stats: LoopStats::default(),
        }
    }

    /// The same plant saturating commands at `max_force_n` \[N\] (finite, > 0) instead of the
    /// default [`DEFAULT_MAX_FORCE_PF`] `P_f`.
    pub fn with_max_force_n(mut self, max_force_n: f64) -> Self {
        self.gate = CommandGate::new(max_force_n);
        self
    }

    /// The force limit \[N\].
    pub fn max_force_n(&self) -> f64 {
        self.gate.max_force_n()
    }

    /// Seq of the current sample.
    pub fn seq(&self) -> u64 {
        self.step
    }

    /// Stamp of sample `k` in nanoseconds of sim time (`k / rate`, rounded).
    pub(super) fn stamp_nanos(&self, k: u64) -> i64 {
        (k as f64 * 1e9 / self.rate_hz).round() as i64
    }

    /// Stamp of the current sample.
    pub fn stamp(&self) -> Time {
        Time::from_nanos(self.stamp_nanos(self.step))
    }

    /// Force held now \[N\]: zero while the watchdog has fired or the emergency stop is
    /// engaged.
    pub fn held_force(&self) -> f64 {
        if self.stale || self.emergency_stopped() {
            0.0
        } else {
            self.held_n
        }
    }

    /// The emergency stop's flag, for the service that sets it.
    pub fn emergency_stop(&self) -> std::sync::Arc<std::sync::atomic::AtomicBool> {
        self.emergency_stop.clone()
    }

    /// Whether the emergency stop is engaged.
    pub fn emergency_stopped(&self) -> bool {
        self.emergency_stop
            .load(std::sync::atomic::Ordering::Relaxed)
    }

    /// Brings the capsule up (see [`PlantSim::start`]) and takes its first sample.
    pub fn start(&mut self, timeout: std::time::Duration) {
        self.sim.start(timeout);
        if let Some(h) = self.sim.health() {
            self.stats.device = Some(h.clone());
        }
    }

    /// How the device is doing (`None`: a simulator).
    pub fn health(&self) -> Option<&SourceHealth> {
        self.sim.health()
    }

    /// Commands refused so far.
    pub fn rejected(&self) -> u32 {
        self.rejected
    }

    /// True when the watchdog has fallen back to zero force.
    pub fn stale(&self) -> bool {
        self.stale
    }

    /// True once the current sample has been answered (lock-step).
    pub fn answered(&self) -> bool {
        self.answered_current
    }

    /// The current sample as a message (SI).
    pub fn state(&self) -> CapsuleState {
        let header = Header {
            stamp: self.stamp(),
            frame_id: self.frame_id.clone(),
        };
        let mut msg = state_message(&self.sim.sample(), &self.scale, header, self.step);
        msg.command_stale = self.stale;
        msg.rejected_commands = self.rejected;
        msg
    }

    /// Notes that the current sample went out at steady time `now`.
    pub fn published(&mut self, now: f64) {
        if self.published_at.is_none() {
            self.published_at = Some(now);
            self.stats.on_publish(self.step, now);
        }
    }

    /// Takes a command received at steady time `now`. `lockstep` requires it to answer the
    /// current sample.
    pub fn on_command(&mut self, cmd: &ActuatorForce, now: f64, lockstep: bool) -> CommandOutcome {
        let stamp = cmd.header.stamp.to_nanos();
        if let Some((t, seq, f)) = self.last_accepted {
            if t == stamp && seq == cmd.state_seq && f.to_bits() == cmd.force.to_bits() {
                self.stats.on_answer(cmd.state_seq, now, self.step);
                return CommandOutcome::Duplicate;
            }
        }
        let outcome = if !cmd.force.is_finite() {
            CommandOutcome::NonFinite
        } else if self.last_accepted.is_some_and(|(t, _, _)| stamp < t)
            || (lockstep && cmd.state_seq < self.step)
        {
            CommandOutcome::Late
        } else if (lockstep && cmd.state_seq > self.step)
            || command_gate::from_the_future(
                stamp,
                self.stamp_nanos(self.step),
                self.stamp_nanos(1),
            )
        {
            CommandOutcome::Future
        } else {
            CommandOutcome::Accepted
        };
        if outcome != CommandOutcome::Accepted {
            self.rejected = self.rejected.saturating_add(1);
            return outcome;
        }
        self.last_accepted = Some((stamp, cmd.state_seq, cmd.force));
        self.held_n = self.gate.limit(cmd.force, cmd.state_seq);
        self.stats.saturated_commands = self.gate.saturated();
        self.last_command_at = Some(now);
        if self.stale {
            info!(
                "command received (seq {}): applying commanded force",
                cmd.state_seq
            );
        }
        self.stale = false;
        self.stats.on_answer(cmd.state_seq, now, self.step);
        if cmd.state_seq == self.step {
            self.answered_current = true;
        }
        outcome
    }

    /// Watchdog at steady time `now`: true when it just fell back to zero force.
    pub fn check_watchdog(&mut self, now: f64) -> bool {
        let fresh = self
            .last_command_at
            .is_some_and(|t| now - t <= self.command_timeout);
        if !fresh && !self.stale {
            self.stale = true;
            return true;
        }
        false
    }

    /// Forces the zero-force fallback (lock-step: no answer within the timeout).
    pub fn force_stale(&mut self) -> bool {
        let was = self.stale;
        self.stale = true;
        !was
    }

    /// Integrates one sample period with the held force and moves to the next sample.
    pub fn step(&mut self) -> Result<()> {
        self.stats.emergency_stop = self.emergency_stopped();
        let force = self.held_force() / self.scale.force_n();
        let tau_end = self.stamp_nanos(self.step + 1) as f64 * 1e-9 / self.scale.time_s();
        self.sim.advance(force, tau_end)?;
        if let Some(h) = self.sim.health() {
            self.stats.device = Some(h.clone());
        }
        self.step += 1;
        self.answered_current = false;
        self.published_at = None;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use CommandOutcome as Outcome;

    /// Stand-in model: the capsule is pinned, the mass is a unit mass under the held force
    /// only (y1' = f), integrated exactly. Enough to check the node's bookkeeping.
    struct FreeMass(Snapshot);

    impl PlantSim for FreeMass {
        fn advance(&mut self, force: f64, tau_end: f64) -> Result<()> {
            let h = tau_end - self.0.tau;
            self.0.state.x1 += self.0.state.y1 * h + 0.5 * force * h * h;
            self.0.state.y1 += force * h;
            self.0.tau = tau_end;
            self.0.actuator_force = force;
            Ok(())
        }
        fn sample(&self) -> Snapshot {
            self.0
        }
    }

    fn scale() -> PhysicalScale {
        PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        }
    }

    fn plant() -> PlantCore<FreeMass> {
        PlantCore::new(
            FreeMass(Snapshot {
                tau: 0.0,
                state: Default::default(),
                stuck: false,
                contact: false,
                friction_force: 0.0,
                contact_force: 0.0,
                actuator_force: 0.0,
            }),
            scale(),
            100.0,
            0.05,
        )
    }

    /// `p` with its first sample published at 0.
    fn published(mut p: PlantCore<FreeMass>) -> PlantCore<FreeMass> {
        p.published(0.0);
        p
    }

    fn cmd(p: &PlantCore<FreeMass>, seq: u64, force: f64) -> ActuatorForce {
        let stamp = Time::from_nanos(p.stamp_nanos(seq));
        ActuatorForce {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            state_seq: seq,
            force,
        }
    }

    /// `p` takes a command of `force` for sample `seq`, received at `now`.
    fn command(
        p: &mut PlantCore<FreeMass>,
        seq: u64,
        force: f64,
        now: f64,
        lockstep: bool,
    ) -> CommandOutcome {
        let c = cmd(p, seq, force);
        p.on_command(&c, now, lockstep)
    }

    #[test]
    fn held_command_drives_the_step_in_si() -> Result<()> {
        let mut p = published(plant());
        assert_eq!(command(&mut p, 0, 1.0, 0.001, true), Outcome::Accepted);
        p.step()?;
        // 1 N on 0.04 kg for 0.01 s: v = 0.25 m/s, x = 1.25 mm
        let s = p.state();
        assert!(
            (s.mass_velocity - 0.25).abs() < 1e-12,
            "{}",
            s.mass_velocity
        );
        assert!(
            (s.mass_position - 1.25e-3).abs() < 1e-15,
            "{}",
            s.mass_position
        );
        assert!((s.actuator_force - 1.0).abs() < 1e-12);
        assert_eq!((s.seq, s.header.stamp.to_nanos()), (1, 10_000_000));
        assert!(!s.command_stale);
        Ok(())
    }

    #[test]
    fn non_finite_and_late_commands_are_refused_and_counted() -> Result<()> {
        let mut p = published(plant());
        assert_eq!(command(&mut p, 0, f64::NAN, 0.0, false), Outcome::NonFinite);
        assert_eq!(
            command(&mut p, 0, f64::INFINITY, 0.0, false),
            Outcome::NonFinite
        );
        assert_eq!(p.rejected(), 2);
        assert!(p.stale(), "nothing accepted yet");
        assert_eq!(command(&mut p, 0, 0.5, 0.0, false), Outcome::Accepted);
        p.step()?;
        p.step()?;
        assert_eq!(command(&mut p, 2, 0.7, 0.02, false), Outcome::Accepted);
        // an older command arriving late does not take over (time does not rewind)
        assert_eq!(command(&mut p, 1, -3.0, 0.021, false), Outcome::Late);
        assert_eq!(p.held_force(), 0.7);
        assert_eq!(command(&mut p, 2, 0.7, 0.022, false), Outcome::Duplicate);
        assert_eq!(p.rejected(), 3);
        assert_eq!(p.state().rejected_commands, 3);
        assert_eq!(p.seq(), 2, "the plant kept stepping");
        Ok(())
    }

    #[test]
    fn huge_finite_commands_are_saturated_and_the_plant_goes_on() -> Result<()> {
        // default limit: 100 P_f = 200 N at this scale
        let mut p = plant();
        assert_eq!(p.max_force_n(), 200.0);
        for (k, f) in [1e308, -1e308, 1000.0].into_iter().enumerate() {
            let k = k as u64;
            p.published(k as f64 * 0.01);
            assert_eq!(
                command(&mut p, k, f, k as f64 * 0.01, false),
                Outcome::Accepted
            );
            assert_eq!(p.held_force(), 200.0f64.copysign(f));
            p.step()?;
            let s = p.state();
            assert!(s.mass_position.is_finite() && s.mass_velocity.is_finite());
            assert_eq!(s.actuator_force, 200.0f64.copysign(f));
        }
        assert_eq!(p.stats.saturated_commands, 3);
        assert_eq!(p.rejected(), 0);
        let mut p = published(plant().with_max_force_n(0.5));
        command(&mut p, 0, 3.0, 0.0, false);
        assert_eq!(p.held_force(), 0.5);
        Ok(())
    }

    #[test]
    fn a_command_stamped_in_the_future_is_refused_and_does_not_block_later_ones() -> Result<()> {
        let mut p = published(plant());
        assert_eq!(command(&mut p, 0, 0.1, 0.0, false), Outcome::Accepted);
        p.step()?;
        p.published(0.01);
        let mut poison = cmd(&p, 1, 5.0);
        poison.header.stamp = Time {
            sec: i32::MAX,
            nanosec: 0,
        };
        assert_eq!(p.on_command(&poison, 0.01, false), Outcome::Future);
        assert_eq!(p.held_force(), 0.1);
        for k in 1..50 {
            assert_eq!(
                command(&mut p, k, 0.2, k as f64 * 0.01, false),
                Outcome::Accepted,
                "sample {k}"
            );
            p.step()?;
            p.published(k as f64 * 0.01 + 0.01);
        }
        assert_eq!(p.rejected(), 1);
        Ok(())
    }

    #[test]
    fn lockstep_takes_only_the_answer_to_the_current_sample() -> Result<()> {
        let mut p = published(plant());
        assert_eq!(command(&mut p, 1, 1.0, 0.0, true), Outcome::Future);
        assert!(!p.answered());
        assert_eq!(command(&mut p, 0, 1.0, 0.0, true), Outcome::Accepted);
        assert!(p.answered());
        p.step()?;
        p.published(0.01);
        assert_eq!(command(&mut p, 0, 1.0, 0.01, true), Outcome::Duplicate);
        assert!(!p.answered());
        assert_eq!(p.stats.latencies.count(), 1);
        Ok(())
    }

    #[test]
    fn the_emergency_stop_zeroes_the_next_step_until_released() -> Result<()> {
        let mut p = published(plant());
        command(&mut p, 0, 1.0, 0.0, false);
        let stop = p.emergency_stop();
        stop.store(true, std::sync::atomic::Ordering::SeqCst);
        assert_eq!(p.held_force(), 0.0);
        p.step()?;
        assert_eq!(p.state().actuator_force, 0.0);
        assert_eq!(p.state().mass_velocity, 0.0, "no force was applied");
        assert!(p.stats.emergency_stop);
        // commands keep being taken (and counted), but do not apply while engaged
        assert_eq!(command(&mut p, 1, 2.0, 0.01, false), Outcome::Accepted);
        assert_eq!(p.held_force(), 0.0);
        stop.store(false, std::sync::atomic::Ordering::SeqCst);
        assert_eq!(p.held_force(), 2.0);
        p.step()?;
        assert!(!p.stats.emergency_stop);
        assert_eq!(p.state().actuator_force, 2.0);
        Ok(())
    }

    #[test]
    fn watchdog_falls_back_to_zero_force_and_says_so() -> Result<()> {
        let mut p = published(plant());
        command(&mut p, 0, 2.0, 0.0, false);
        assert!(!p.check_watchdog(0.04));
        assert_eq!(p.held_force(), 2.0);
        assert!(p.check_watchdog(0.06));
        assert!(!p.check_watchdog(0.07), "reported once");
        assert_eq!(p.held_force(), 0.0);
        p.step()?;
        let s = p.state();
        assert!(s.command_stale);
        assert_eq!(s.mass_velocity, 0.0);
        p.published(0.08);
        p.step()?;
        p.published(0.09);
        p.stats.finish();
        // sample 0 answered; sample 1 never (lost); sample 2 was in flight at the end
        assert_eq!(
            (
                p.stats.published,
                p.stats.unanswered,
                p.stats.before_first_answer
            ),
            (3, 1, 0)
        );
        Ok(())
    }
}
