//! The plant's logic without DDS: the zero-order hold of the last accepted command, command
//! validation (non-finite refused, huge saturated, late or future refused), the stale-command
//! watchdog, the lifecycle's gate (zero force unless active), and the samples it publishes,
//! around any [`CapsuleHardware`].

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use capsule_msgs::{ActuatorForce, CapsuleState, Header, Time};
use capsule_plant::scene::PhysicalScale;
use tracing::info;

use super::LoopStats;
use crate::command_gate::{self, CommandGate, DEFAULT_MAX_FORCE_PF};
use capsule_hardware::{CapsuleHardware, HardwareError, Reading, Sample, SourceHealth};
use capsule_record::sample::state_message;

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

/// The plant node's logic around its hardware.
pub struct PlantCore<H: CapsuleHardware> {
    pub(super) hw: H,
    /// The newest sample (the last one again while a device sends nothing usable).
    pub(super) current: Sample,
    /// Active (lifecycle): written forces apply; otherwise zero goes out.
    pub(super) active: bool,
    /// Whether the current sample's force went out (a device is answered once per sample).
    pub(super) written: bool,
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
    pub(super) emergency_stop: Arc<AtomicBool>,
    /// The hardware's [`capsule_hardware::Ready`] as the loop awaits it (a device's).
    ready: Option<Arc<tokio::sync::Notify>>,
    /// Statistics of the loop.
    pub stats: LoopStats,
}

impl<H: CapsuleHardware> PlantCore<H> {
    /// A plant on `hw` sampling at `rate_hz`, falling back to zero force after
    /// `command_timeout` \[s\]; its default force limit is [`DEFAULT_MAX_FORCE_PF`] of
    /// `scale`'s `P_f`. Unconfigured and inactive until [`PlantCore::configure`] and
    /// [`PlantCore::activate`].
    pub fn new(mut hw: H, scale: PhysicalScale, rate_hz: f64, command_timeout: f64) -> Self {
        let emergency_stop: Arc<AtomicBool> = Default::default();
        hw.zero_while(emergency_stop.clone());
        let ready = hw.ready().map(|r| {
            let woken = Arc::new(tokio::sync::Notify::new());
            let wake = woken.clone();
            r.on_ready(move || wake.notify_one());
            woken
        });
        PlantCore {
            ready,
            hw,
            current: Sample::unknown(),
            active: false,
            written: false,
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
            emergency_stop,
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

    /// Force held now \[N\]: zero while the watchdog has fired, the emergency stop is
    /// engaged, or the node is not active.
    pub fn held_force(&self) -> f64 {
        if self.stale || self.emergency_stopped() || !self.active {
            0.0
        } else {
            self.held_n
        }
    }

    /// The emergency stop's flag, for the service that sets it.
    pub fn emergency_stop(&self) -> Arc<AtomicBool> {
        self.emergency_stop.clone()
    }

    /// Whether the emergency stop is engaged.
    pub fn emergency_stopped(&self) -> bool {
        self.emergency_stop.load(Ordering::SeqCst)
    }

    /// Zeroes the actuator at once from another thread (the emergency stop's service), if the
    /// hardware can be reached outside the loop.
    pub fn stopper(&self) -> Option<capsule_hardware::Stopper> {
        self.hw.stopper()
    }

    /// `Some` when the hardware paces itself (a device): notified whenever it has something
    /// to read (see [`CapsuleHardware::ready`]).
    pub fn ready(&self) -> Option<Arc<tokio::sync::Notify>> {
        self.ready.clone()
    }

    /// Whether the lifecycle has it active.
    pub fn active(&self) -> bool {
        self.active
    }

    /// Unconfigured -> inactive: configures the hardware; a simulator's first sample is read at
    /// once, a device's comes when it measures.
    pub fn configure(&mut self) -> Result<(), HardwareError> {
        self.hw.configure()?;
        self.current = Sample::unknown();
        if self.stats.published > 0 {
            // configured again after a cleanup: a new sample, never a second seq k
            self.next_sample(Reading::Timeout);
        }
        self.written = false;
        if self.hw.ready().is_none() {
            if let Reading::Sample(s) = self.hw.read(Instant::now())? {
                self.current = s;
            }
        }
        self.note_health();
        Ok(())
    }

    /// Inactive -> active: commands apply.
    pub fn activate(&mut self) -> Result<(), HardwareError> {
        self.hw.activate()?;
        self.active = true;
        Ok(())
    }

    /// Active -> inactive: zero force from the next sample on.
    pub fn deactivate(&mut self) -> Result<(), HardwareError> {
        self.active = false;
        self.hw.deactivate()
    }

    /// Inactive -> unconfigured: the hardware let go (the line closed).
    pub fn cleanup(&mut self) -> Result<(), HardwareError> {
        self.active = false;
        self.hw.cleanup()
    }

    /// How the device is doing (`None`: a simulator).
    pub fn health(&self) -> Option<&SourceHealth> {
        self.hw.health()
    }

    fn note_health(&mut self) {
        if let Some(h) = self.hw.health() {
            self.stats.device = Some(h.clone());
        }
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
        CapsuleState {
            command_stale: self.stale,
            rejected_commands: self.rejected,
            ..state_message(&self.current, header, self.step)
        }
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

    /// Node-paced hardware (a simulator): writes the held force, reads the next sample (one
    /// sample period later) and moves to it.
    pub fn step(&mut self) -> Result<(), HardwareError> {
        self.answer()?;
        let reading = self.hw.read(Instant::now())?;
        self.next_sample(reading);
        Ok(())
    }

    /// Writes the held force as the answer to the current sample, once per sample (a device
    /// gets it the moment it is known).
    pub fn answer(&mut self) -> Result<(), HardwareError> {
        if self.written {
            return Ok(());
        }
        self.written = true;
        self.stats.emergency_stop = self.emergency_stopped();
        self.hw.write(self.held_force())
    }

    /// Moves to the next sample: `reading`'s, or the last one again (a timeout or a fault of a
    /// device: the samples go on at the node's rate, the device's answer is zero). Such a
    /// sample has no applied force (NaN: nobody measured what acted over its period), which
    /// also tells it from the device's own samples in a recording: a sensor may send one
    /// reading twice, so equal positions do not.
    pub fn next_sample(&mut self, reading: Reading) {
        match reading {
            Reading::Sample(s) => self.current = s,
            _ => self.current.actuator_force = f64::NAN,
        }
        self.note_health();
        self.step += 1;
        self.answered_current = false;
        self.written = false;
        self.published_at = None;
    }

    /// The first sample after configure (published as the current seq, not the next).
    pub fn first_sample(&mut self, reading: Reading) {
        if let Reading::Sample(s) = reading {
            self.current = s;
        }
        self.note_health();
    }

    /// Whether the current sample's force went out.
    pub fn written(&self) -> bool {
        self.written
    }

    /// Paced hardware: the next reading, waiting until `deadline` at most.
    pub fn read(&mut self, deadline: Instant) -> Result<Reading, HardwareError> {
        self.hw.read(deadline)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use CommandOutcome as Outcome;

    use capsule_hardware::mock::FreeMass;

    type Result<T> = std::result::Result<T, HardwareError>;

    fn scale() -> PhysicalScale {
        PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        }
    }

    /// A configured, active plant on the mock.
    fn plant() -> PlantCore<FreeMass> {
        let mut p = PlantCore::new(FreeMass::default(), scale(), 100.0, 0.05);
        assert!(p.configure().is_ok() && p.activate().is_ok());
        p
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
    fn a_sample_without_a_new_measurement_keeps_the_positions_and_says_no_applied_force(
    ) -> Result<()> {
        let mut p = published(plant());
        command(&mut p, 0, 1.0, 0.0, false);
        p.step()?;
        let measured = p.state();
        assert_eq!(measured.actuator_force, 1.0);
        p.next_sample(Reading::Timeout);
        let again = p.state();
        assert_eq!(again.seq, measured.seq + 1);
        assert_eq!(again.capsule_position, measured.capsule_position);
        assert!(again.actuator_force.is_nan());
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
    fn zero_force_goes_out_while_inactive_and_from_the_sample_after_a_deactivate() -> Result<()> {
        let mut p = PlantCore::new(FreeMass::default(), scale(), 100.0, 0.05);
        p.configure()?;
        p.published(0.0);
        // inactive: commands are taken (and counted) but zero goes out
        assert_eq!(command(&mut p, 0, 1.0, 0.0, false), Outcome::Accepted);
        p.step()?;
        p.activate()?;
        assert_eq!(command(&mut p, 1, 1.0, 0.01, false), Outcome::Accepted);
        p.step()?;
        p.deactivate()?;
        p.step()?;
        assert_eq!(p.hw.writes, [0.0, 1.0, 0.0]);
        assert_eq!(p.state().actuator_force, 0.0);
        p.cleanup()?;
        assert!(p.step().is_err(), "no reads after a cleanup");
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

#[cfg(test)]
mod lifecycle_gate {
    use super::*;

    #[test]
    fn a_configure_that_cannot_build_says_why_and_reads_wait_for_one() {
        // the simulator's adapter, through the trait object as the node holds it
        let mut p: PlantCore<Box<dyn CapsuleHardware>> = PlantCore::new(
            Box::new(capsule_hardware::sim::SimulatedPlant::new(
                Box::new(|| Err("no scene here".to_string())),
                PhysicalScale {
                    m1_kg: 0.04,
                    k1_n_per_m: 100.0,
                    pf_n: 2.0,
                },
                100.0,
            )),
            PhysicalScale {
                m1_kg: 0.04,
                k1_n_per_m: 100.0,
                pf_n: 2.0,
            },
            100.0,
            0.05,
        );
        // a configure that cannot build says why, and reads are refused until one succeeds
        let e = p.configure().err().map(|e| e.to_string());
        assert_eq!(e.as_deref(), Some("simulation failed: no scene here"));
        assert!(p.step().is_err());
        assert!(!p.active());
    }
}
