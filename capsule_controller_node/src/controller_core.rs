//! The controller's decision logic without DDS: state in, force command out, status, the mode
//! service's answers and the attractor switch; unit-tested here, wired to ROS by
//! [`crate::controller`] (or by anything else that brings state samples and takes commands).
//!
//! It sees only what a capsule driver publishes (the state topic) and converts SI back to the
//! paper's units with the scene's physical scale it is given ([`PhysicalScale`]).
//!
//! Time: the drive phase is taken from the state sample's stamp (`tau = Omega0 t_stamp`), so a
//! command depends only on the sample it answers (deterministic in lock-step); the command
//! carries that stamp and the sample's seq. The stale-state watchdog runs on a steady clock
//! passed in, because sim time stops when the plant does.

use capsule_plant::number_text::short;
use capsule_plant::scene::PhysicalScale;
use capsule_plant::AffineLaw;

use capsule_controller::{
    mode::{Mode, ModeConfig, ProgressMeter, Staleness},
    move_goal::{MoveConfig, MoveProgress, MoveRequest, MoveRun},
    switch::{AttractorSwitch, OrbitWatch, SwitchConfig, SwitchRequest},
    velocity::LineFit,
};
use capsule_msgs::{
    ActuatorForce, CapsuleState, ControllerStatus, Header, SetModeRequest, SetModeResponse, Time,
};

use crate::command_feedback::CommandFeedback;

/// Everything the controller decides, fed with samples, requests and clock readings.
#[derive(Debug, Clone)]
pub struct ControllerCore {
    scale: PhysicalScale,
    law: AffineLaw,
    config: ModeConfig,
    mode: Mode,
    pending: Vec<(i64, Mode, f64)>,
    meter: ProgressMeter,
    staleness: Staleness,
    last: Option<(u64, i64)>,
    last_command: Option<ActuatorForce>,
    commanding: bool,
    commands_sent: u64,
    ignored_samples: u64,
    /// Why the last sample ignored was.
    ignored_why: Option<Ignored>,
    /// Velocities the plant does not measure, from its positions (orbit watch and switch only).
    velocity: LineFit,
    feedback: CommandFeedback,
    switch_settings: SwitchConfig,
    watch: OrbitWatch,
    /// The last attractor switch, and the mode and gain it returns to.
    switch: Option<(AttractorSwitch, Mode)>,
    /// The switch changed phase or started a pulse since the last [`ControllerCore::take_switch_event`].
    switch_event: bool,
    /// The Move action's goal, running or ended and not yet taken ([`crate::controller_actions`]).
    move_run: Option<MoveRun>,
    /// The plant's lifecycle state id, as last heard (`None`: not heard;
    /// [`crate::plant_lifecycle`]).
    plant_lifecycle: Option<u8>,
}

/// `lifecycle_msgs/msg/State`'s id of the active state.
pub const LIFECYCLE_ACTIVE: u8 = 3;

/// Why a move goal is refused or ended when the plant applies none of our commands.
const NOT_ACTIVE: &str =
    "the plant is not active (it applies none of our commands: zero force on a run of samples)";
/// Why a move goal is refused or ended when the plant's lifecycle says it is not active.
const NOT_ACTIVE_LIFECYCLE: &str = "the plant is not active (its lifecycle state says so)";

/// Why a state sample was not used.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ignored {
    /// A position the law needs is not finite.
    PositionNotFinite {
        /// Mass position \[m\].
        mass_m: f64,
        /// Capsule position \[m\].
        capsule_m: f64,
    },
    /// Older than the newest sample seen (out of order on the network).
    Older {
        /// The newest sample's seq.
        last_seq: u64,
    },
    /// The law's force for it is not finite.
    ForceNotFinite,
}

impl std::fmt::Display for Ignored {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Ignored::PositionNotFinite { mass_m, capsule_m } => write!(
                f,
                "position not finite: mass {mass_m} m, capsule {capsule_m} m"
            ),
            Ignored::Older { last_seq } => {
                write!(f, "older than the last (seq {last_seq})")
            }
            Ignored::ForceNotFinite => f.write_str("the control law's force is not finite"),
        }
    }
}

impl ControllerCore {
    /// A controller in `mode` with gain `kp`, drive `alpha`, `omega`, and the stale timeout \[s\].
    pub fn new(
        scale: PhysicalScale,
        alpha: f64,
        omega: f64,
        mode: Mode,
        kp: f64,
        config: ModeConfig,
        stale_s: f64,
    ) -> Self {
        let law = AffineLaw::paper(alpha, omega, kp);
        ControllerCore {
            scale,
            law,
            config,
            mode,
            pending: Vec::new(),
            meter: ProgressMeter::new(law.period()),
            staleness: Staleness::new(stale_s),
            last: None,
            last_command: None,
            commanding: false,
            commands_sent: 0,
            ignored_samples: 0,
            ignored_why: None,
            velocity: LineFit::for_period(law.period()),
            feedback: CommandFeedback::default(),
            switch_settings: SwitchConfig::DEFAULT,
            watch: OrbitWatch::new(law.period(), &SwitchConfig::DEFAULT),
            switch: None,
            switch_event: false,
            move_run: None,
            plant_lifecycle: None,
        }
    }

    /// The switch in progress, if one is.
    fn running_switch(&self) -> Option<&(AttractorSwitch, Mode)> {
        self.switch.as_ref().filter(|(sw, _)| !sw.state().is_done())
    }

    /// The mode and gain the controller settles in: the current ones, or during an attractor
    /// switch the ones it returns to (what the `mode` / `gain` parameters show).
    pub fn settled_mode(&self) -> (Mode, f64) {
        match self.running_switch() {
            Some((sw, mode)) => (*mode, sw.base_gain()),
            None => (self.mode, self.law.kp),
        }
    }

    /// The last attractor switch (running or ended), if any.
    pub fn attractor_switch(&self) -> Option<&AttractorSwitch> {
        self.switch.as_ref().map(|(sw, _)| sw)
    }

    /// Starts afresh with a new plant (restarted or replaced): its samples start again from
    /// its own seq and time, so nothing of the last plant's ordering or progress applies.
    /// Modes scheduled for a sim time stay scheduled.
    pub fn new_plant(&mut self) {
        self.last = None;
        self.last_command = None;
        self.meter.reset();
        self.feedback.reset();
        self.watch.reset();
        self.velocity.reset();
        self.abort_move("a new plant publishes: the travel so far was the last plant's");
        // an attractor switch was about the last plant's orbit
        if let Some((mode, kp)) = self.running_switch().map(|_| self.settled_mode()) {
            self.change_mode(mode, kp);
        }
    }

    /// True while the plant's state says it refuses our commands (see [`CommandFeedback`]).
    pub fn plant_refuses(&self) -> bool {
        self.feedback.refused()
    }

    /// True while the plant's state says it applies none of our commands (see
    /// [`CommandFeedback::applied`]), or its lifecycle state is known and not active.
    pub fn plant_inactive(&self) -> bool {
        self.not_active().is_some()
    }

    /// Why the plant is taken as not active, if it is.
    fn not_active(&self) -> Option<&'static str> {
        if self
            .plant_lifecycle
            .is_some_and(|id| id != LIFECYCLE_ACTIVE)
        {
            Some(NOT_ACTIVE_LIFECYCLE)
        } else if self.feedback.inactive() {
            Some(NOT_ACTIVE)
        } else {
            None
        }
    }

    /// Notes the plant's lifecycle state `id` (`lifecycle_msgs/msg/State`): a move goal ends
    /// when it is not active. The only evidence of an inactive plant in lock-step, where an
    /// inactive plant stands still and its samples say nothing new.
    pub fn plant_lifecycle(&mut self, id: u8) {
        self.plant_lifecycle = Some(id);
        if id != LIFECYCLE_ACTIVE {
            self.abort_move(NOT_ACTIVE_LIFECYCLE);
        }
    }

    /// Current mode.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Current law (drive and gain).
    pub fn law(&self) -> AffineLaw {
        self.law
    }

    /// The controller with the orbit watch's recurrence tolerance `tol` (non-dimensional, on
    /// the section; [`SwitchConfig::tol`]): a device's noisy positions need more than the
    /// simulator's 0.02 (docs/hardware.md).
    pub fn with_orbit_tolerance(mut self, tol: f64) -> Self {
        self.switch_settings.tol = tol;
        self.watch = OrbitWatch::new(self.law.period(), &self.switch_settings);
        self
    }

    /// The orbit watch's recurrence tolerance (non-dimensional).
    pub fn orbit_tolerance(&self) -> f64 {
        self.switch_settings.tol
    }

    /// The mode configuration (defaults and limit).
    pub fn config(&self) -> ModeConfig {
        self.config
    }

    /// The physical scale.
    pub fn scale(&self) -> PhysicalScale {
        self.scale
    }

    /// Takes new settings (from ROS parameters that passed `ModeConfig::select`): a changed
    /// mode or gain acts now, as an immediate `set_mode`; a changed drive restarts the meter.
    pub fn reconfigure(&mut self, mode: Mode, kp: f64, alpha: f64, omega: f64, config: ModeConfig) {
        self.config = config;
        let drive_changed = (alpha, omega) != (self.law.alpha, self.law.omega);
        if drive_changed {
            self.law.alpha = alpha;
            self.law.omega = omega;
            self.meter = ProgressMeter::new(self.law.period());
            self.watch = OrbitWatch::new(self.law.period(), &self.switch_settings);
        }
        // a new drive ends an attractor switch (its orbits are gone) as a new mode does
        if (mode, kp) != self.settled_mode() || (drive_changed && self.running_switch().is_some()) {
            self.pending.clear();
            self.change_mode_for(
                mode,
                kp,
                "the mode or gain parameter changed during the goal",
            );
        }
    }

    /// Samples ignored so far (non-finite, out of order).
    pub fn ignored_samples(&self) -> u64 {
        self.ignored_samples
    }

    /// Why the last sample ignored was (`None`: none was).
    pub fn ignored_why(&self) -> Option<Ignored> {
        self.ignored_why
    }

    fn ignore(&mut self, why: Ignored) -> Option<ActuatorForce> {
        self.ignored_samples += 1;
        self.ignored_why = Some(why);
        None
    }

    /// Goes to `mode` with `kp` (ending an attractor switch in progress: cancelled; a move
    /// goal: aborted, saying `why`).
    fn change_mode_for(&mut self, mode: Mode, kp: f64, why: &str) {
        self.abort_move(why);
        self.change_mode(mode, kp);
    }

    /// Goes to `mode` with `kp` (ending an attractor switch in progress: cancelled).
    fn change_mode(&mut self, mode: Mode, kp: f64) {
        if let Some((sw, _)) = &mut self.switch {
            sw.cancel();
        }
        self.mode = mode;
        self.law.kp = kp;
        self.meter.reset();
    }

    /// Starts an attractor switch (`SWITCH_ATTRACTOR`), or refuses it with the reason.
    fn start_switch(&mut self, req: &SetModeRequest) -> SetModeResponse {
        let request = SwitchRequest {
            gain: req.gain,
            pulse_periods: req.pulse_periods,
            target_period: req.target_period,
            max_tries: req.max_tries,
        };
        let refused = |reason: String| SetModeResponse {
            accepted: false,
            mode: self.mode.code(),
            gain: self.law.kp,
            reason,
        };
        if let Err(e) = request.validate(&self.switch_settings, self.config.gain_limit) {
            return refused(format!("SWITCH_ATTRACTOR: {e}"));
        }
        if !req.effective_from.is_zero() {
            return refused(
                "SWITCH_ATTRACTOR: effective_from must be zero (the pulses start at section crossings)"
                    .to_string(),
            );
        }
        let (mode, kp) = self.settled_mode();
        self.pending.clear();
        self.change_mode_for(
            Mode::SwitchAttractor,
            kp,
            "set_mode SWITCH_ATTRACTOR during the goal ended it",
        );
        let sw = AttractorSwitch::new(request, self.switch_settings, kp, self.law.period());
        self.switch = Some((sw, mode));
        SetModeResponse {
            accepted: true,
            mode: Mode::SwitchAttractor.code(),
            gain: req.gain,
            reason: format!(
                "SWITCH_ATTRACTOR: pulses of k_p = {} for {} period(s) until the orbit has period {} (at most {} tries), then back to {mode} with k_p = {}",
                short(req.gain), req.pulse_periods, req.target_period, req.max_tries, short(kp)
            ),
        }
    }

    /// Handles a `set_mode` request: refused (mode unchanged) with the reason, applied now, or
    /// scheduled for `effective_from`; `SWITCH_ATTRACTOR` starts an attractor switch.
    pub fn set_mode(&mut self, req: &SetModeRequest) -> SetModeResponse {
        if req.mode == SetModeRequest::SWITCH_ATTRACTOR {
            return self.start_switch(req);
        }
        match self.config.select(req.mode, req.gain) {
            Err(e) => SetModeResponse {
                accepted: false,
                mode: self.mode.code(),
                gain: self.law.kp,
                reason: e.to_string(),
            },
            Ok((mode, kp)) => {
                let at = req.effective_from.to_nanos();
                let now = self.last.map(|(_, t)| t).unwrap_or(i64::MIN);
                if req.effective_from.is_zero() || at <= now {
                    self.pending.clear();
                    self.change_mode_for(
                        mode,
                        kp,
                        &format!("set_mode {mode} during the goal ended it"),
                    );
                    SetModeResponse {
                        accepted: true,
                        mode: mode.code(),
                        gain: kp,
                        reason: format!("{mode} with k_p = {}", short(kp)),
                    }
                } else {
                    self.abort_move(&format!(
                        "set_mode {mode} (scheduled) during the goal ended it"
                    ));
                    self.pending.retain(|(t, _, _)| *t < at);
                    self.pending.push((at, mode, kp));
                    SetModeResponse {
                        accepted: true,
                        mode: mode.code(),
                        gain: kp,
                        reason: format!(
                            "{mode} with k_p = {} from t = {:.9} s",
                            short(kp),
                            req.effective_from.as_secs_f64()
                        ),
                    }
                }
            }
        }
    }

    /// Handles a state sample received at steady time `now` \[s\]; returns the command to publish.
    ///
    /// Samples older than the newest one seen are ignored (a late sample must not rewind the
    /// controller); a repeat of the newest seq (a lock-step plant re-sending) gets the same
    /// command again without being counted twice.
    pub fn on_state(&mut self, s: &CapsuleState, now: f64) -> Option<ActuatorForce> {
        let stamp = s.header.stamp.to_nanos();
        // positions are what the law needs; a velocity may be NaN (a device that does not
        // measure it) and is then estimated (capsule_controller::velocity)
        if !(s.mass_position.is_finite() && s.capsule_position.is_finite()) {
            return self.ignore(Ignored::PositionNotFinite {
                mass_m: s.mass_position,
                capsule_m: s.capsule_position,
            });
        }
        if let Some((seq, t)) = self.last {
            if seq == s.seq && t == stamp {
                self.staleness.seen(now);
                // a plant holding its sample (lock-step, inactive or paused) is there: after a
                // stall of the host went stale, its re-sends alone must bring commanding back
                self.commanding = true;
                return self.last_command.clone();
            }
            if stamp < t || (stamp == t && s.seq < seq) {
                return self.ignore(Ignored::Older { last_seq: seq });
            }
        }
        self.staleness.seen(now);
        self.commanding = true;
        self.last = Some((s.seq, stamp));
        self.feedback.sample(s.rejected_commands, s.command_stale);
        let commanded = self.last_command.as_ref().map(|c| c.force);
        if self
            .feedback
            .applied(s.actuator_force, commanded, s.command_stale)
            == Some(true)
        {
            self.abort_move(NOT_ACTIVE);
        }
        while let Some(i) = self.pending.iter().position(|(t, _, _)| *t <= stamp) {
            let (_, mode, kp) = self.pending.remove(i);
            self.change_mode(mode, kp);
        }
        let tau = s.header.stamp.as_secs_f64() / self.scale.time_s();
        let x1 = s.mass_position / self.scale.length_m();
        let x2 = s.capsule_position / self.scale.length_m();
        let v = self.scale.velocity_m_per_s();
        // with velocities estimated, the watch and the switch see the window's middle, later
        if let Some((tm, nd)) =
            self.velocity
                .state(tau, x1, s.mass_velocity / v, x2, s.capsule_velocity / v)
        {
            self.watch.sample(tm, nd);
            if let Some((sw, back)) = self.switch.as_mut().filter(|(sw, _)| !sw.state().is_done()) {
                let was = (sw.state(), sw.tries());
                self.law.kp = sw.sample(tm, nd);
                self.switch_event |= (sw.state(), sw.tries()) != was;
                if sw.state().is_done() {
                    let back = *back;
                    let kp = sw.base_gain();
                    self.mode = back;
                    self.law.kp = kp;
                    self.meter.reset();
                }
            }
        }
        self.drive_move(s);
        let f = self.law.force_at(tau, x1, x2);
        if !f.is_finite() {
            return self.ignore(Ignored::ForceNotFinite);
        }
        self.meter.sample(tau, x1, x2, f);
        let cmd = ActuatorForce {
            header: Header {
                stamp: s.header.stamp,
                frame_id: s.header.frame_id.clone(),
            },
            state_seq: s.seq,
            force: f * self.scale.force_n(),
        };
        self.last_command = Some(cmd.clone());
        self.commands_sent += 1;
        Some(cmd)
    }

    /// A move goal's law on sample `s`: the gain (and with it the mode) it holds.
    fn drive_move(&mut self, s: &CapsuleState) {
        let Some(run) = self.move_run.as_mut().filter(|r| r.outcome().is_none()) else {
            return;
        };
        let kp = run.sample(s.header.stamp.as_secs_f64(), s.capsule_position);
        self.law.kp = kp;
        self.mode = match kp {
            k if k > 0.0 => Mode::Forward,
            k if k < 0.0 => Mode::Backward,
            _ => Mode::Off,
        };
    }

    /// Starts a move goal; refused with the reason when the request is bad or the plant is not
    /// under control (the running goal, if any, goes on). Returns the goal it replaces (the
    /// running one aborted, saying so), OFF until the new goal's first decision.
    pub fn start_move(&mut self, request: MoveRequest) -> Result<Option<MoveRun>, String> {
        if !self.commanding {
            return Err("no fresh state from the plant (not active, or gone)".into());
        }
        if self.feedback.refused() {
            return Err("the plant refuses our commands".into());
        }
        if let Some(why) = self.not_active() {
            return Err(why.into());
        }
        let config = MoveConfig {
            cruise_gain: self.config.direction_gain,
            ..MoveConfig::DEFAULT
        };
        let period_s = self.law.period() * self.scale.time_s();
        let run = MoveRun::start(request, config, period_s).map_err(|e| e.to_string())?;
        self.pending.clear();
        self.change_mode_for(Mode::Off, 0.0, "a new goal preempted it");
        Ok(self.move_run.replace(run))
    }

    /// Ends the running move goal (if any) for `why`, OFF.
    pub fn abort_move(&mut self, why: &str) {
        if let Some(run) = self.move_run.as_mut().filter(|r| r.outcome().is_none()) {
            run.abort(why.to_string());
            self.mode = Mode::Off;
            self.law.kp = 0.0;
        }
    }

    /// Cancels the running attractor switch (if any): back to the mode it came from.
    pub fn cancel_switch(&mut self) {
        if let Some((mode, kp)) = self.running_switch().map(|_| self.settled_mode()) {
            self.change_mode(mode, kp);
        }
    }

    /// Cancels the running move goal (if any), OFF.
    pub fn cancel_move(&mut self) {
        if let Some(run) = self.move_run.as_mut().filter(|r| r.outcome().is_none()) {
            run.cancel();
            self.mode = Mode::Off;
            self.law.kp = 0.0;
        }
    }

    /// The running move goal's progress and the mode it holds (`None`: none runs).
    pub fn move_progress(&self) -> Option<(MoveProgress, Mode)> {
        let run = self.move_run.as_ref().filter(|r| r.outcome().is_none())?;
        Some((run.progress(), self.mode))
    }

    /// The move goal that ended, once (`None`: none did).
    pub fn take_ended_move(&mut self) -> Option<MoveRun> {
        if self.move_run.as_ref()?.outcome().is_some() {
            self.move_run.take()
        } else {
            None
        }
    }

    /// True once after each change of the attractor switch's phase (a pulse started, released,
    /// judged): the node publishes a status then, so that every pulse shows on the topic.
    pub fn take_switch_event(&mut self) -> bool {
        std::mem::take(&mut self.switch_event)
    }

    /// Checks the state watchdog at steady time `now`; returns true when it just went stale.
    pub fn check_stale(&mut self, now: f64) -> bool {
        if self.commanding && self.staleness.is_stale(now) {
            self.commanding = false;
            self.abort_move("the state went stale (plant gone?)");
            return true;
        }
        false
    }

    /// True while fresh state arrives and commands go out (whether the plant takes them or
    /// not: see [`ControllerCore::plant_refuses`]).
    pub fn commanding(&self) -> bool {
        self.commanding
    }

    /// The status message, stamped `stamp`.
    pub fn status(&self, stamp: Time) -> ControllerStatus {
        let periods = self.meter.periods();
        let prog = self.meter.progression_per_period();
        let period_s = self.law.period() * self.scale.time_s();
        let prog_m = prog * self.scale.length_m();
        ControllerStatus {
            header: Header {
                stamp,
                frame_id: String::new(),
            },
            mode: self.mode.code(),
            mode_name: self.mode.name().to_string(),
            gain: self.law.kp,
            drive_amplitude: self.law.alpha,
            drive_frequency: self.law.omega,
            drive_amplitude_si: self.law.alpha * self.scale.force_n(),
            drive_frequency_hz: 1.0 / period_s,
            // commanding = in control: fresh state, and the plant takes our commands
            commanding: self.commanding && !self.feedback.refused(),
            commands_sent: self.commands_sent,
            periods,
            progression_per_period: prog,
            progression_per_period_m: prog_m,
            mean_speed: if periods > 0 { prog_m / period_s } else { 0.0 },
            efficiency: self.meter.efficiency(),
            ..self.switch_status()
        }
    }

    /// The `switch_*` and `orbit_period` fields of the status.
    fn switch_status(&self) -> ControllerStatus {
        let stamp = |tau: Option<f64>| {
            tau.map(|t| Time::from_secs_f64(t * self.scale.time_s()))
                .unwrap_or(Time::ZERO)
        };
        let orbit_period = self.watch.period().map_or(0, |p| p as i32);
        match self.attractor_switch() {
            None => ControllerStatus {
                orbit_period,
                ..ControllerStatus::default()
            },
            Some(sw) => ControllerStatus {
                switch_state: sw.state().code(),
                switch_target_period: sw.request().target_period,
                switch_tries: sw.tries(),
                switch_max_tries: sw.request().max_tries,
                switch_pulse_gain: sw.request().gain,
                switch_pulse_periods: sw.request().pulse_periods,
                switch_pulse_start: stamp(sw.pulse_start()),
                switch_pulse_end: stamp(sw.pulse_end()),
                orbit_period,
                ..ControllerStatus::default()
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scale() -> PhysicalScale {
        PhysicalScale {
            m1_kg: 0.04,
            k1_n_per_m: 100.0,
            pf_n: 2.0,
        }
    }

    fn core(mode: Mode, kp: f64) -> ControllerCore {
        ControllerCore::new(scale(), 1.6, 1.1, mode, kp, ModeConfig::default(), 0.5)
    }

    fn state(seq: u64, t: f64, x1_nd: f64, x2_nd: f64) -> CapsuleState {
        let l = scale().length_m();
        CapsuleState {
            header: Header {
                stamp: Time::from_secs_f64(t),
                frame_id: "odom".into(),
            },
            seq,
            mass_position: x1_nd * l,
            capsule_position: x2_nd * l,
            ..CapsuleState::default()
        }
    }

    /// A Move goal of 1 cm, with no tolerance and no timeout.
    fn move_1cm() -> MoveRequest {
        MoveRequest {
            distance_m: 0.01,
            tolerance_m: 0.0,
            timeout_s: 0.0,
        }
    }

    /// Why the 1 cm goal `ended` ended ("" when it did not).
    fn why_ended(ended: Option<MoveRun>) -> String {
        ended
            .and_then(|r| r.outcome().cloned())
            .map(|o| o.message(0.01))
            .unwrap_or_default()
    }

    /// Why the 1 cm goal that `c` ended last ended ("" when none did).
    fn ended_why(c: &mut ControllerCore) -> String {
        why_ended(c.take_ended_move())
    }

    #[test]
    fn command_is_the_papers_law_in_si() {
        let mut c = core(Mode::Forward, 0.2);
        let t = 0.013;
        let cmd = c
            .on_state(&state(0, t, 0.3, -0.1), 0.0)
            .map(|c| c.force)
            .unwrap_or(f64::NAN);
        let tau = t * scale().omega0();
        let expected = (1.6 * (1.1 * tau).cos() + 0.2 * 0.4) * 2.0;
        assert!((cmd - expected).abs() < 1e-12, "{cmd} vs {expected}");
    }

    #[test]
    fn refused_requests_leave_the_mode_alone() {
        let mut c = core(Mode::Forward, 0.2);
        for (mode, gain) in [
            (7u8, 0.1),
            (4, f64::NAN),
            (4, f64::INFINITY),
            (4, 5.0),
            (1, 3.0),
        ] {
            let r = c.set_mode(&SetModeRequest {
                mode,
                gain,
                ..SetModeRequest::default()
            });
            assert!(!r.accepted, "{mode} {gain}");
            assert!(!r.reason.is_empty());
            assert_eq!((c.mode(), c.law().kp), (Mode::Forward, 0.2));
            assert_eq!((r.mode, r.gain), (1, 0.2));
        }
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::BACKWARD,
            gain: 0.0,
            ..Default::default()
        });
        assert!(r.accepted);
        assert_eq!((c.mode(), c.law().kp), (Mode::Backward, -0.2));
    }

    #[test]
    fn scheduled_switches_apply_at_their_sample_and_late_samples_are_ignored() {
        let mut c = core(Mode::Forward, 0.2);
        assert!(c.on_state(&state(0, 0.0, 0.0, 0.0), 0.0).is_some());
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::OFF,
            gain: 0.0,
            effective_from: Time::from_secs_f64(0.02),
            ..SetModeRequest::default()
        });
        assert!(r.accepted);
        assert_eq!(c.mode(), Mode::Forward);
        assert!(c.on_state(&state(1, 0.01, 0.0, 0.0), 0.01).is_some());
        assert_eq!(c.mode(), Mode::Forward);
        // a late, older sample: ignored, no command
        assert!(c.on_state(&state(0, 0.0, 0.0, 0.0), 0.011).is_none());
        assert_eq!(c.ignored_samples(), 1);
        assert_eq!(
            c.ignored_why().map(|w| w.to_string()).as_deref(),
            Some("older than the last (seq 1)")
        );
        assert!(c.on_state(&state(2, 0.02, 0.0, 0.0), 0.02).is_some());
        assert_eq!((c.mode(), c.law().kp), (Mode::Off, 0.0));
    }

    #[test]
    fn repeated_sample_gets_the_same_command_and_stale_state_stops_commanding() {
        let mut c = core(Mode::Forward, 0.2);
        let a = c.on_state(&state(3, 0.03, 0.1, 0.0), 0.0);
        let b = c.on_state(&state(3, 0.03, 0.1, 0.0), 0.1);
        assert!(a.is_some());
        assert_eq!(a, b);
        assert_eq!(c.status(Time::ZERO).commands_sent, 1);
        assert!(c.commanding());
        assert!(!c.check_stale(0.5));
        assert!(c.check_stale(0.7));
        assert!(!c.commanding());
        assert!(!c.status(Time::ZERO).commanding);
        assert!(!c.check_stale(0.8), "reports going stale once");
        // a lock-step plant holding its sample re-sends it: fresh again
        assert_eq!(c.on_state(&state(3, 0.03, 0.1, 0.0), 0.85), a);
        assert!(c.commanding());
        assert!(c.check_stale(1.4));
        assert!(c.on_state(&state(4, 0.04, 0.1, 0.0), 1.5).is_some());
        assert!(c.commanding());
    }

    #[test]
    fn a_new_plant_is_commanded_from_its_first_sample() {
        let mut c = core(Mode::Forward, 0.2);
        for k in 0..4000 {
            assert!(c
                .on_state(&state(k, k as f64 * 1e-3, 0.1, 0.0), 0.0)
                .is_some());
        }
        // the restarted plant starts again at seq 0, t = 0: older than the last one's samples
        assert!(c.on_state(&state(0, 0.0, 0.0, 0.0), 1.0).is_none());
        c.new_plant();
        let cmd = c.on_state(&state(1, 1e-3, 0.0, 0.0), 1.0);
        assert_eq!(cmd.map(|c| c.state_seq), Some(1));
        assert_eq!(c.status(Time::ZERO).periods, 0, "progress measured afresh");
    }

    #[test]
    fn a_plant_refusing_every_command_is_not_reported_as_commanded() {
        let mut c = core(Mode::Forward, 0.2);
        let w = u64::from(CommandFeedback::WINDOW);
        for k in 0..w {
            assert!(c
                .on_state(&state(k, k as f64 * 1e-3, 0.1, 0.0), 0.0)
                .is_some());
        }
        assert!(c.status(Time::ZERO).commanding);
        for k in w..3 * w {
            let mut s = state(k, k as f64 * 1e-3, 0.1, 0.0);
            s.rejected_commands = (k - w) as u32;
            s.command_stale = true;
            assert!(c.on_state(&s, 0.0).is_some(), "commands still go out");
        }
        assert!(c.plant_refuses());
        assert!(c.commanding() && !c.status(Time::ZERO).commanding);
        for k in 3 * w..4 * w {
            let mut s = state(k, k as f64 * 1e-3, 0.1, 0.0);
            s.rejected_commands = (2 * w) as u32;
            c.on_state(&s, 0.0);
        }
        assert!(c.status(Time::ZERO).commanding, "taken again");
    }

    fn switch_request(
        gain: f64,
        pulse_periods: i32,
        target_period: i32,
        max_tries: i32,
    ) -> SetModeRequest {
        SetModeRequest {
            mode: SetModeRequest::SWITCH_ATTRACTOR,
            gain,
            pulse_periods,
            target_period,
            max_tries,
            ..SetModeRequest::default()
        }
    }

    #[test]
    fn attractor_switch_requests_are_checked_and_a_mode_request_cancels_one() {
        let mut c = core(Mode::Forward, 0.2);
        for bad in [
            switch_request(f64::NAN, 1, 1, 3),
            switch_request(5.0, 1, 1, 3),
            switch_request(0.3, 11, 1, 3),
            switch_request(0.3, 0, 1, 3),
            switch_request(0.3, -1, 1, 3),
            switch_request(0.3, 1, 0, 3),
            switch_request(0.3, 1, 1, 0),
            SetModeRequest {
                effective_from: Time::from_secs_f64(1.0),
                ..switch_request(0.3, 1, 1, 3)
            },
        ] {
            let r = c.set_mode(&bad);
            assert!(
                !r.accepted && r.reason.starts_with("SWITCH_ATTRACTOR: "),
                "{bad:?}: {r:?}"
            );
            assert_eq!((c.mode(), c.law().kp), (Mode::Forward, 0.2));
            assert_eq!(
                c.status(Time::ZERO).switch_state,
                ControllerStatus::SWITCH_NONE
            );
        }
        let r = c.set_mode(&switch_request(0.3, 1, 1, 3));
        assert!(r.accepted, "{r:?}");
        assert_eq!(c.mode(), Mode::SwitchAttractor);
        assert_eq!(
            c.settled_mode(),
            (Mode::Forward, 0.2),
            "what the parameters show"
        );
        let st = c.status(Time::ZERO);
        assert_eq!(
            (
                st.switch_state,
                st.switch_target_period,
                st.switch_max_tries,
                st.switch_tries
            ),
            (ControllerStatus::SWITCH_OBSERVING, 1, 3, 0)
        );
        assert_eq!(st.gain, 0.2, "no pulse before the orbit is known");
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::OFF,
            ..SetModeRequest::default()
        });
        assert!(r.accepted);
        assert_eq!((c.mode(), c.law().kp), (Mode::Off, 0.0));
        assert_eq!(
            c.status(Time::ZERO).switch_state,
            ControllerStatus::SWITCH_CANCELLED
        );
    }

    #[test]
    fn positions_alone_drive_the_law_when_velocities_are_not_measured() {
        // a device with a displacement sensor and an encoder: velocities NaN on the wire
        let mut measured = core(Mode::Forward, 0.2);
        let mut positions_only = core(Mode::Forward, 0.2);
        for k in 0..200u64 {
            let t = k as f64 * 1e-3;
            let (x1, x2) = ((7.0 * t).sin(), 0.1 * t);
            let mut s = state(k, t, x1, x2);
            s.mass_velocity = 0.3;
            s.capsule_velocity = 0.01;
            let a = measured.on_state(&s, t).map(|c| c.force);
            s.mass_velocity = f64::NAN;
            s.capsule_velocity = f64::NAN;
            let b = positions_only.on_state(&s, t).map(|c| c.force);
            assert!(b.is_some(), "no command at sample {k}");
            assert_eq!(a, b, "sample {k}");
        }
        assert_eq!(positions_only.ignored_samples(), 0);
        assert!(positions_only.commanding());
    }

    #[test]
    fn move_goals_are_refused_without_the_plant_and_ended_by_a_mode_or_a_new_goal() {
        let mut c = core(Mode::Forward, 0.2);
        let goal = move_1cm();
        assert!(c
            .start_move(goal)
            .is_err_and(|e| e.starts_with("no fresh state")));
        for k in 0..10 {
            c.on_state(&state(k, k as f64 * 1e-3, 0.1, 0.0), 0.0);
        }
        let bad = MoveRequest {
            distance_m: f64::NAN,
            ..goal
        };
        assert_eq!(
            c.start_move(bad).err().as_deref(),
            Some("distance_m = NaN is not finite")
        );
        assert_eq!(
            (c.mode(), c.law().kp),
            (Mode::Forward, 0.2),
            "refused: unchanged"
        );
        assert!(matches!(c.start_move(goal), Ok(None)));
        assert_eq!(
            (c.mode(), c.law().kp),
            (Mode::Off, 0.0),
            "OFF until the first section"
        );
        assert!(c.move_progress().is_some());
        // a new goal preempts the running one, which ends aborted saying why
        let old = c.start_move(goal).ok().flatten();
        let why = why_ended(old);
        assert!(why.starts_with("aborted: a new goal preempted it"), "{why}");
        let r = c.set_mode(&SetModeRequest {
            mode: SetModeRequest::BACKWARD,
            ..SetModeRequest::default()
        });
        assert!(r.accepted);
        assert!(c.move_progress().is_none());
        let why = ended_why(&mut c);
        assert!(
            why.starts_with("aborted: set_mode BACKWARD during the goal ended it"),
            "{why}"
        );
        assert!(c.take_ended_move().is_none(), "taken once");
        assert_eq!(c.mode(), Mode::Backward);
        // cancel: OFF
        assert!(c.start_move(goal).is_ok());
        c.cancel_move();
        assert_eq!((c.mode(), c.law().kp), (Mode::Off, 0.0));
        assert!(c.take_ended_move().is_some());
    }

    #[test]
    fn move_goals_are_refused_while_the_plant_applies_none_of_our_commands() {
        let mut c = core(Mode::Off, 0.0);
        let goal = move_1cm();
        let run = u64::from(CommandFeedback::INACTIVE_RUN);
        // configured, not active: every sample applied zero force while we drive
        let sample = |c: &mut ControllerCore, k: u64, applied: f64| {
            let mut s = state(k, k as f64 * 1e-3, 0.1, 0.0);
            s.actuator_force = applied;
            c.on_state(&s, 0.0)
        };
        for k in 0..=run {
            assert!(sample(&mut c, k, 0.0).is_some_and(|f| f.force != 0.0));
        }
        assert!(c.plant_inactive());
        let why = c.start_move(goal).err().unwrap_or_default();
        assert!(why.starts_with("the plant is not active"), "{why}");
        // activated: the next sample applies our command, and goals are taken
        sample(&mut c, run + 1, 0.04);
        assert!(!c.plant_inactive());
        assert!(c.start_move(goal).is_ok());
        // deactivated during the goal: it ends, saying so, OFF
        for k in run + 2..2 * run + 3 {
            sample(&mut c, k, 0.0);
        }
        let why = ended_why(&mut c);
        assert!(why.starts_with("aborted: the plant is not active"), "{why}");
        assert_eq!((c.mode(), c.law().kp), (Mode::Off, 0.0));
    }

    #[test]
    fn move_goals_are_refused_while_the_plant_s_lifecycle_is_not_active() {
        // lock-step: an inactive plant re-sends one sample, so its samples say nothing new
        let mut c = core(Mode::Off, 0.0);
        let goal = move_1cm();
        let s = state(0, 0.0, 0.0, 0.0);
        for _ in 0..3 * CommandFeedback::INACTIVE_RUN {
            c.on_state(&s, 0.0);
        }
        assert!(c.start_move(goal).is_ok(), "nothing says it is inactive");
        c.plant_lifecycle(2);
        assert!(c.plant_inactive());
        let why = ended_why(&mut c);
        assert!(
            why.starts_with("aborted: the plant is not active (its lifecycle"),
            "{why}"
        );
        let why = c.start_move(goal).err().unwrap_or_default();
        assert!(
            why.starts_with("the plant is not active (its lifecycle"),
            "{why}"
        );
        c.plant_lifecycle(LIFECYCLE_ACTIVE);
        assert!(!c.plant_inactive());
        assert!(c.start_move(goal).is_ok());
    }

    #[test]
    fn non_finite_samples_are_ignored() {
        let mut c = core(Mode::Off, 0.0);
        let mut s = state(0, 0.0, 0.0, 0.0);
        s.capsule_position = f64::NAN;
        assert!(c.on_state(&s, 0.0).is_none());
        assert_eq!(c.ignored_samples(), 1);
        assert_eq!(
            c.ignored_why().map(|w| w.to_string()).as_deref(),
            Some("position not finite: mass 0 m, capsule NaN m")
        );
    }
}
