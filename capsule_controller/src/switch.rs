//! Live attractor switching (intermittent control): watch the Poincaré section of the running
//! capsule, pulse the gain for a few drive periods from a section crossing, release it, let the
//! orbit settle, check its period, and pulse again (one drive period later on the cycle each
//! time, since the outcome depends on the phase) until the orbit has the requested period or the
//! tries are used up. Pure: fed with state samples (non-dimensional), it answers the gain.
//!
//! The section is the drive phase 0 (`tau = n 2 pi / omega`), the point `[x1 - x2, y1 - y2, y1]`
//! as `capsule_analysis` records it; between two samples the crossing is interpolated (cubic
//! Hermite in the positions, whose derivatives are the velocities; linear in the velocities).

use std::collections::VecDeque;

use capsule_plant::number_text::short;

use crate::period::{self, Over};

/// How an attractor switch is bounded and judged (the controller's settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchConfig {
    /// Longest pulse accepted [drive periods].
    pub max_pulse_periods: i32,
    /// Largest try limit accepted.
    pub max_tries: i32,
    /// Largest orbit period that can be requested and detected [drive periods].
    pub max_period: i32,
    /// Section points to wait after a release (and after the request) before judging the orbit.
    pub settle_periods: u32,
    /// Section points after which an orbit that shows no period counts as none.
    pub wait_periods: u32,
    /// Recurrence tolerance on the section (max norm, non-dimensional).
    pub tol: f64,
    /// Tolerance of the reduction to the smallest period (see [`orbit_period`]).
    pub reduce_tol: f64,
}

impl SwitchConfig {
    /// Pulses up to 10 periods, up to 20 tries, orbits up to period 12, 6 periods of settling,
    /// 60 periods of patience, a recurrence tolerance of 0.02 (the interpolated section's error
    /// at 100 samples per period is far below it) and a reduction tolerance of 0.25 (the
    /// period-3 cycle's points at alpha 1.5 are about 1 apart).
    pub const DEFAULT: SwitchConfig = SwitchConfig {
        max_pulse_periods: 10,
        max_tries: 20,
        max_period: 12,
        settle_periods: 6,
        wait_periods: 60,
        tol: 0.02,
        reduce_tol: 0.25,
    };
}

impl Default for SwitchConfig {
    fn default() -> Self {
        SwitchConfig::DEFAULT
    }
}

/// A switch request as it comes over the wire (`SetMode` with `SWITCH_ATTRACTOR`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SwitchRequest {
    /// `k_p` during the pulse.
    pub gain: f64,
    /// Pulse length [drive periods].
    pub pulse_periods: i32,
    /// Period of the orbit wanted [drive periods].
    pub target_period: i32,
    /// Most pulses to apply.
    pub max_tries: i32,
}

/// Why a switch request was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SwitchError {
    /// NaN or infinite pulse gain.
    #[error("pulse gain {} is not finite", short(*.0))]
    NonFiniteGain(f64),
    /// |pulse gain| beyond the controller's limit.
    #[error("pulse gain {} is beyond the configured limit |k_p| <= {}", short(*.gain), short(*.limit))]
    BeyondLimit {
        /// The gain.
        gain: f64,
        /// The limit.
        limit: f64,
    },
    /// An integer field out of its range.
    #[error("{name} = {value}: must be in [{min}, {max}]")]
    OutOfRange {
        /// The field.
        name: &'static str,
        /// Its value.
        value: i32,
        /// Smallest accepted.
        min: i32,
        /// Largest accepted.
        max: i32,
    },
}

impl SwitchRequest {
    /// Checks the request against the settings and the gain limit.
    pub fn validate(&self, s: &SwitchConfig, gain_limit: f64) -> Result<(), SwitchError> {
        if !self.gain.is_finite() {
            return Err(SwitchError::NonFiniteGain(self.gain));
        }
        if self.gain.abs() > gain_limit {
            return Err(SwitchError::BeyondLimit {
                gain: self.gain,
                limit: gain_limit,
            });
        }
        for (name, value, max) in [
            ("pulse_periods", self.pulse_periods, s.max_pulse_periods),
            ("target_period", self.target_period, s.max_period),
            ("max_tries", self.max_tries, s.max_tries),
        ] {
            if !(1..=max).contains(&value) {
                return Err(SwitchError::OutOfRange {
                    name,
                    value,
                    min: 1,
                    max,
                });
            }
        }
        Ok(())
    }
}

/// Where a switch is (codes as in `ControllerStatus.SWITCH_*`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SwitchState {
    /// Watching the section until the orbit's period is known.
    Observing,
    /// The pulse gain is applied.
    Pulsing,
    /// Released; waiting for the orbit to settle, then judging it.
    Settling,
    /// The orbit has the requested period, gain released.
    Succeeded,
    /// The tries are used up without the requested orbit, gain released.
    Failed,
    /// Another mode was requested before the switch ended.
    Cancelled,
}

impl SwitchState {
    /// The wire code (`ControllerStatus.SWITCH_OBSERVING` = 1, ...; 0 = no switch yet).
    pub fn code(self) -> u8 {
        match self {
            SwitchState::Observing => 1,
            SwitchState::Pulsing => 2,
            SwitchState::Settling => 3,
            SwitchState::Succeeded => 4,
            SwitchState::Failed => 5,
            SwitchState::Cancelled => 6,
        }
    }

    /// The name, for humans.
    pub fn name(self) -> &'static str {
        match self {
            SwitchState::Observing => "observing",
            SwitchState::Pulsing => "pulsing",
            SwitchState::Settling => "settling",
            SwitchState::Succeeded => "succeeded",
            SwitchState::Failed => "failed",
            SwitchState::Cancelled => "cancelled",
        }
    }

    /// True once the switch is over.
    pub fn is_done(self) -> bool {
        matches!(
            self,
            SwitchState::Succeeded | SwitchState::Failed | SwitchState::Cancelled
        )
    }
}

/// A state sample in the paper's units: time and `[x1, y1, x2, y2]`.
type Sample = (f64, [f64; 4]);

/// Finds the drive-phase-0 crossings in a stream of samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Section {
    period: f64,
    last: Option<Sample>,
}

impl Section {
    /// A section for a drive of period `period` (non-dimensional).
    pub fn new(period: f64) -> Self {
        Section { period, last: None }
    }

    /// Forgets the last sample (a new plant, a time jump).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// Adds a sample; returns the section point `[x1 - x2, y1 - y2, y1]` interpolated at the
    /// phase-0 time in `(previous tau, tau]`, if there is one. Samples going back in time reset.
    pub fn sample(&mut self, tau: f64, s: [f64; 4]) -> Option<[f64; 3]> {
        let prev = self.last.replace((tau, s));
        let (t0, s0) = prev?;
        let h = tau - t0;
        // (the sample is kept as the last one in every case: a jump back starts afresh)
        if h.is_nan() || h <= 0.0 || !self.period.is_finite() || self.period <= 0.0 {
            return None;
        }
        let n = (tau / self.period).floor();
        let tc = n * self.period;
        if !(tc > t0 && tc <= tau) {
            return None;
        }
        let w = (tc - t0) / h;
        // cubic Hermite for a position x with derivative v
        let hermite = |x0: f64, v0: f64, x1: f64, v1: f64| {
            let (w2, w3) = (w * w, w * w * w);
            (2.0 * w3 - 3.0 * w2 + 1.0) * x0
                + (w3 - 2.0 * w2 + w) * h * v0
                + (-2.0 * w3 + 3.0 * w2) * x1
                + (w3 - w2) * h * v1
        };
        let x1 = hermite(s0[0], s0[1], s[0], s[1]);
        let x2 = hermite(s0[2], s0[3], s[2], s[3]);
        let y1 = s0[1] + w * (s[1] - s0[1]);
        let y2 = s0[3] + w * (s[3] - s0[3]);
        Some([x1 - x2, y1 - y2, y1])
    }
}

/// The period of the orbit the last section points show: the smallest lag `k <= max_period`
/// with which each of the last `cycles * k` points repeats within `tol` (so `(cycles + 1) k`
/// points are needed), reduced to the smallest period of those `k` points within `reduce_tol`
/// ([`crate::period`]); or `None`.
///
/// The reduction is needed because an orbit approached along a Floquet multiplier near -1 (the
/// period-1 orbit at alpha 1.5 is one: its section points alternate about it and close in by
/// well under 1 % a period) repeats with lag 2 at `tol` long before it does with lag 1.
/// `reduce_tol` must stay below the distance between the points of a real cycle (about 1 for
/// the period-3 orbit at alpha 1.5).
pub fn orbit_period(
    points: &[[f64; 3]],
    max_period: usize,
    cycles: usize,
    tol: f64,
    reduce_tol: f64,
) -> Option<usize> {
    let k = period::smallest_lag(points, max_period, Over::Cycles(cycles), tol)?;
    Some(period::reduced(&points[points.len() - k..], reduce_tol))
}

/// Full cycles a period must repeat for [`orbit_period`] to accept it here.
pub const CYCLES: usize = 2;

/// Watches the section continuously and keeps the recent points (for the status's orbit period).
#[derive(Debug, Clone, PartialEq)]
pub struct OrbitWatch {
    section: Section,
    points: VecDeque<[f64; 3]>,
    max_period: usize,
    tol: f64,
    reduce_tol: f64,
}

impl OrbitWatch {
    /// A watch over a drive of period `period`, judging orbits as `settings` say.
    pub fn new(period: f64, settings: &SwitchConfig) -> Self {
        OrbitWatch {
            section: Section::new(period),
            points: VecDeque::new(),
            max_period: settings.max_period.max(1) as usize,
            tol: settings.tol,
            reduce_tol: settings.reduce_tol,
        }
    }

    /// Forgets everything (a new plant, a new drive).
    pub fn reset(&mut self) {
        self.section.reset();
        self.points.clear();
    }

    /// Adds a sample; returns the section point if the sample crossed the section.
    pub fn sample(&mut self, tau: f64, s: [f64; 4]) -> Option<[f64; 3]> {
        let p = self.section.sample(tau, s)?;
        if self.points.len() == (CYCLES + 1) * self.max_period {
            self.points.pop_front();
        }
        self.points.push_back(p);
        Some(p)
    }

    /// The period the last points show (see [`orbit_period`]), or `None`.
    pub fn period(&self) -> Option<usize> {
        let v: Vec<[f64; 3]> = self.points.iter().copied().collect();
        orbit_period(&v, self.max_period, CYCLES, self.tol, self.reduce_tol)
    }
}

/// One attractor switch in progress (or ended): feed it every sample, apply the gain it answers.
#[derive(Debug, Clone, PartialEq)]
pub struct AttractorSwitch {
    request: SwitchRequest,
    settings: SwitchConfig,
    base_gain: f64,
    section: Section,
    points: Vec<[f64; 3]>,
    state: SwitchState,
    tries: i32,
    crossings: u32,
    delay: u32,
    pulse_start: Option<f64>,
    pulse_end: Option<f64>,
    pulse_pending: bool,
    release_pending: bool,
    before: Option<usize>,
    detected: Option<usize>,
    cycle: Vec<[f64; 3]>,
}

impl AttractorSwitch {
    /// A switch (request already validated) over a drive of period `period`, returning to
    /// `base_gain` between and after the pulses.
    pub fn new(
        request: SwitchRequest,
        settings: SwitchConfig,
        base_gain: f64,
        period: f64,
    ) -> Self {
        AttractorSwitch {
            request,
            settings,
            base_gain,
            section: Section::new(period),
            points: Vec::new(),
            state: SwitchState::Observing,
            tries: 0,
            crossings: 0,
            delay: 0,
            pulse_start: None,
            pulse_end: None,
            pulse_pending: false,
            release_pending: false,
            before: None,
            detected: None,
            cycle: Vec::new(),
        }
    }

    /// The request.
    pub fn request(&self) -> SwitchRequest {
        self.request
    }

    /// Where the switch is.
    pub fn state(&self) -> SwitchState {
        self.state
    }

    /// Pulses started so far.
    pub fn tries(&self) -> i32 {
        self.tries
    }

    /// Time (tau) of the first sample of the last pulse.
    pub fn pulse_start(&self) -> Option<f64> {
        self.pulse_start
    }

    /// Time (tau) of the first sample after the last pulse (gain released).
    pub fn pulse_end(&self) -> Option<f64> {
        self.pulse_end
    }

    /// The orbit's period before the first pulse (None: not periodic within the patience).
    pub fn before(&self) -> Option<usize> {
        self.before
    }

    /// The period last detected (before the first pulse, then after each release).
    pub fn detected(&self) -> Option<usize> {
        self.detected
    }

    /// The gain to go back to.
    pub fn base_gain(&self) -> f64 {
        self.base_gain
    }

    /// Cancels the switch (another mode was requested).
    pub fn cancel(&mut self) {
        if !self.state.is_done() {
            self.state = SwitchState::Cancelled;
        }
    }

    /// Adds a sample at `tau` with state `[x1, y1, x2, y2]`; returns the gain to apply from this
    /// sample on.
    pub fn sample(&mut self, tau: f64, s: [f64; 4]) -> f64 {
        if self.state.is_done() {
            return self.base_gain;
        }
        if let Some(p) = self.section.sample(tau, s) {
            self.crossing(p);
        }
        if self.pulse_pending {
            self.pulse_pending = false;
            self.pulse_start = Some(tau);
            self.pulse_end = None;
        }
        if self.release_pending {
            self.release_pending = false;
            self.pulse_end = Some(tau);
        }
        match self.state {
            SwitchState::Pulsing => self.request.gain,
            _ => self.base_gain,
        }
    }

    fn start_pulse(&mut self) {
        self.tries += 1;
        self.state = SwitchState::Pulsing;
        self.crossings = 0;
        self.pulse_pending = true;
    }

    /// Starts the next try at another phase of the cycle seen before the first pulse: try
    /// `i + 1` at the crossing `i` drive periods after the first pulse's along that cycle. If the
    /// orbit is not that cycle (or none was seen), the try starts `i` periods from now.
    fn retry(&mut self, p: [f64; 3]) {
        let k = self.cycle.len();
        let tol = self.settings.tol;
        let close = |c: &[f64; 3]| c.iter().zip(&p).all(|(a, b)| (a - b).abs() <= tol);
        let delay = match self.cycle.iter().position(close) {
            Some(m) => {
                let wanted = (k - 1 + self.tries as usize) % k;
                ((wanted + k - m) % k) as u32
            }
            None => self.tries as u32,
        };
        if delay == 0 {
            self.start_pulse();
        } else {
            self.delay = delay;
        }
    }

    fn crossing(&mut self, p: [f64; 3]) {
        self.crossings += 1;
        match self.state {
            SwitchState::Observing | SwitchState::Settling => {
                if self.delay > 0 {
                    // shifting the next pulse along the cycle: don't judge, just wait
                    self.delay -= 1;
                    if self.delay == 0 {
                        self.start_pulse();
                    }
                    return;
                }
                self.points.push(p);
                let settled = self.crossings > self.settings.settle_periods;
                let period = if settled {
                    let from = self.settings.settle_periods as usize;
                    orbit_period(
                        &self.points[from.min(self.points.len())..],
                        self.settings.max_period.max(1) as usize,
                        CYCLES,
                        self.settings.tol,
                        self.settings.reduce_tol,
                    )
                } else {
                    None
                };
                let judged = period.is_some() || self.crossings >= self.settings.wait_periods;
                if !judged {
                    return;
                }
                self.detected = period;
                if self.state == SwitchState::Observing {
                    self.before = period;
                }
                if period == Some(self.request.target_period as usize) {
                    self.state = SwitchState::Succeeded;
                } else if self.tries >= self.request.max_tries {
                    self.state = SwitchState::Failed;
                } else if self.tries == 0 {
                    // the cycle as seen, ending with the point the first pulse starts at
                    if let Some(k) = period {
                        self.cycle = self.points[self.points.len() - k..].to_vec();
                    }
                    self.start_pulse();
                } else {
                    self.retry(p);
                }
            }
            SwitchState::Pulsing => {
                if self.crossings >= self.request.pulse_periods as u32 {
                    self.state = SwitchState::Settling;
                    self.crossings = 0;
                    self.points.clear();
                    self.release_pending = true;
                }
            }
            SwitchState::Succeeded | SwitchState::Failed | SwitchState::Cancelled => {}
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request() -> SwitchRequest {
        SwitchRequest {
            gain: 0.3,
            pulse_periods: 1,
            target_period: 1,
            max_tries: 3,
        }
    }

    #[test]
    fn bad_requests_are_refused_with_the_field_and_reason() {
        let s = SwitchConfig::default();
        assert_eq!(request().validate(&s, 2.0), Ok(()));
        let bad = |r: SwitchRequest| r.validate(&s, 2.0).map_err(|e| e.to_string());
        let nan = bad(SwitchRequest {
            gain: f64::NAN,
            ..request()
        });
        assert!(nan.unwrap_err().contains("not finite"));
        let big = bad(SwitchRequest {
            gain: 2.5,
            ..request()
        });
        assert!(big.unwrap_err().contains("limit"));
        for (r, field) in [
            (
                SwitchRequest {
                    pulse_periods: 11,
                    ..request()
                },
                "pulse_periods = 11",
            ),
            (
                SwitchRequest {
                    pulse_periods: 0,
                    ..request()
                },
                "pulse_periods = 0",
            ),
            (
                SwitchRequest {
                    pulse_periods: -2,
                    ..request()
                },
                "pulse_periods = -2",
            ),
            (
                SwitchRequest {
                    target_period: 0,
                    ..request()
                },
                "target_period = 0",
            ),
            (
                SwitchRequest {
                    max_tries: 0,
                    ..request()
                },
                "max_tries = 0",
            ),
        ] {
            let e = bad(r).unwrap_err();
            assert!(e.starts_with(field), "{e}");
        }
    }

    #[test]
    fn orbit_period_is_the_smallest_repeating_one() {
        let p3: Vec<[f64; 3]> = (0..12).map(|n| [(n % 3) as f64, 0.5, 0.0]).collect();
        assert_eq!(orbit_period(&p3, 12, 2, 1e-3, 0.25), Some(3));
        assert_eq!(
            orbit_period(&p3[..8], 12, 2, 1e-3, 0.25),
            None,
            "needs 3 cycles"
        );
        let p1 = vec![[0.2, 0.1, 0.0]; 3];
        assert_eq!(orbit_period(&p1, 12, 2, 1e-3, 0.25), Some(1));
        let noisy: Vec<[f64; 3]> = (0..9).map(|n| [n as f64 * 1e-3, 0.0, 0.0]).collect();
        assert_eq!(orbit_period(&noisy, 12, 2, 0.01, 0.25), Some(1));
        assert_eq!(orbit_period(&noisy, 12, 2, 1e-4, 0.25), None);
        // alternating about a fixed point, closing in slowly: lag 2 first, reduced to 1
        let flip: Vec<[f64; 3]> = (0..6)
            .map(|n| [0.46 + 0.05 * (-1f64).powi(n) * 0.999f64.powi(n), 1.4, 1.5])
            .collect();
        assert_eq!(orbit_period(&flip, 12, 2, 0.01, 0.0), Some(2));
        assert_eq!(orbit_period(&flip, 12, 2, 0.01, 0.25), Some(1));
    }

    #[test]
    fn section_interpolates_the_phase_zero_point() {
        // x1 = sin(tau), y1 = cos(tau), capsule at rest; drive period 2 pi: at tau = 2 pi,
        // x1 - x2 = 0, y1 - y2 = 1
        let mut sec = Section::new(std::f64::consts::TAU);
        let dt = 0.07;
        let mut found = Vec::new();
        for k in 0..200 {
            let t = k as f64 * dt;
            if let Some(p) = sec.sample(t, [t.sin(), t.cos(), 0.0, 0.0]) {
                found.push(p);
            }
        }
        assert_eq!(found.len(), 2, "crossings at 2 pi and 4 pi: {found:?}");
        for p in found {
            assert!(p[0].abs() < 1e-5 && (p[1] - 1.0).abs() < 3e-3, "{p:?}");
        }
    }

    /// A fake plant: section points follow a period-3 cycle until the gain is pulsed at cycle
    /// phase 0, then stay on a fixed point.
    fn drive_fake(sw: &mut AttractorSwitch, periods: usize, good_phase: usize) -> Vec<f64> {
        let period = 1.0;
        let samples = 10;
        let mut on_p1 = false;
        let mut pulsed_at = None;
        let mut gains = Vec::new();
        for n in 0..periods {
            let point = if on_p1 {
                [0.5, 0.0]
            } else {
                [(n % 3) as f64, 1.0]
            };
            for k in 0..samples {
                let tau = n as f64 * period + k as f64 / samples as f64;
                // constant state within a period: the section sees `point`
                let g = sw.sample(tau, [point[0], 0.0, 0.0, -point[1]]);
                if k == 0 && g == 0.3 && pulsed_at.is_none() {
                    pulsed_at = Some(n);
                    if n % 3 == good_phase {
                        on_p1 = true;
                    }
                }
                if g != 0.3 {
                    pulsed_at = None;
                }
                gains.push(g);
            }
        }
        gains
    }

    #[test]
    fn switch_retries_at_other_phases_until_the_orbit_is_the_target() {
        let settings = SwitchConfig {
            tol: 1e-6,
            ..SwitchConfig::default()
        };
        for good in 0..3 {
            let mut sw = AttractorSwitch::new(request(), settings, 0.0, 1.0);
            let gains = drive_fake(&mut sw, 200, good);
            assert_eq!(sw.state(), SwitchState::Succeeded, "good phase {good}");
            assert_eq!(sw.before(), Some(3));
            assert_eq!(sw.detected(), Some(1));
            assert!((1..=3).contains(&sw.tries()), "{}", sw.tries());
            assert_eq!(gains.last(), Some(&0.0), "released");
            let pulsed = gains.iter().filter(|g| **g == 0.3).count();
            assert_eq!(pulsed, 10 * sw.tries() as usize, "one period per try");
            let (a, b) = (
                sw.pulse_start().unwrap_or(-1.0),
                sw.pulse_end().unwrap_or(-1.0),
            );
            assert!((b - a - 1.0).abs() < 0.2, "pulse {a}..{b}");
        }
    }

    #[test]
    fn switch_fails_after_its_tries_and_releases() {
        let settings = SwitchConfig {
            tol: 1e-6,
            ..SwitchConfig::default()
        };
        let mut sw = AttractorSwitch::new(request(), settings, 0.05, 1.0);
        // no phase works
        let gains = drive_fake(&mut sw, 300, 99);
        assert_eq!(sw.state(), SwitchState::Failed);
        assert_eq!(sw.tries(), 3);
        assert_eq!(sw.detected(), Some(3));
        assert_eq!(gains.last(), Some(&0.05));
    }

    #[test]
    fn already_on_the_target_needs_no_pulse() {
        let mut sw = AttractorSwitch::new(
            SwitchRequest {
                target_period: 3,
                ..request()
            },
            SwitchConfig::default(),
            0.0,
            1.0,
        );
        drive_fake(&mut sw, 40, 0);
        assert_eq!((sw.state(), sw.tries()), (SwitchState::Succeeded, 0));
        sw.cancel();
        assert_eq!(
            sw.state(),
            SwitchState::Succeeded,
            "a finished switch stays finished"
        );
    }
}
