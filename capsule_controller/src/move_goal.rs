//! Move goals: travel a signed distance along the capsule's axis, land within a tolerance and
//! stop in OFF (the `Move` action's law). Pure: fed with state samples (time, capsule position),
//! it gives the gain `k_p` to hold until the next one.
//!
//! The capsule moves in jumps (a slip or two per drive period), so where it lands is decided
//! one drive period at a time, at the Poincaré section (drive phase 0, `t` a multiple of the
//! drive period), where the orbit repeats:
//! - **Reference.** From acceptance to the first section crossing the law is OFF; the travel
//!   is counted from the capsule's position at that crossing (OFF's orbit does not progress,
//!   so this is where the goal was accepted, up to the orbit's intra-period swing).
//! - **Gain per period.** Far from the target the law cruises at the direction gain (1.5 mm
//!   per period at the section-5 control point); within [`MoveConfig::approach_m`] it holds the
//!   approach gain (0.05 there: 0.5 mm per period), so the last jumps are short. The orbit
//!   answers a gain change over a few periods (from OFF to 0.2 the progression per period
//!   grows 0.06, 0.5, 1.0, 1.3, 1.4, 1.5 mm), and after OFF the capsule coasts on (0.4 mm
//!   from cruising), so:
//! - **Timing the stop.** The law goes OFF at the first section where the distance left is
//!   within the coast plus half the last period's progression: the landing is then within about
//!   half a jump. The coast is predicted as a fraction of the last period's progression (1.7 at
//!   first, as measured at the control point from the approach gain), then as the fraction
//!   measured at each stop.
//! - **Landing.** After [`MoveConfig::settle_periods`] in OFF the goal succeeds if the capsule
//!   is within the tolerance; otherwise the law approaches again, from whichever side.
//! - **Ends otherwise.** A timeout, no progress for [`MoveConfig::stall_periods`] periods,
//!   a cancel, or an abort by the caller; every end holds OFF.

use capsule_plant::number_text::short;

/// The coast after OFF as a fraction of the last period's progression, before one was
/// measured: at the section-5 control point, OFF after periods of 0.52 mm at the approach gain
/// coasts 0.9 mm over the next 6 periods.
const COAST_RATIO: f64 = 1.7;

/// The move law's settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveConfig {
    /// |k_p| at full speed (the controller's direction gain).
    pub cruise_gain: f64,
    /// |k_p| near the target.
    pub approach_gain: f64,
    /// Distance left below which the law holds the approach gain \[m\].
    pub approach_m: f64,
    /// The tolerance of a goal that gives 0 \[m\].
    pub default_tolerance_m: f64,
    /// The largest |distance| accepted \[m\].
    pub max_distance_m: f64,
    /// Within this fraction of the tolerance the law stops whatever the coast.
    pub aim: f64,
    /// Drive periods in OFF before the landing is judged.
    pub settle_periods: u32,
    /// Drive periods without getting closer before the goal is aborted.
    pub stall_periods: u32,
}

impl MoveConfig {
    /// Cruise at 0.2 (FORWARD's default), approach at 0.05 within 5 mm (the orbit needs some 3
    /// periods to slow down); a 1 mm default tolerance (what the law promises at the section-5
    /// control point: docs/ros.md, "The Move action"); at most 10 m; stop at once within a
    /// quarter of the tolerance; 6 settling periods (the coast lasts about as long); 40 periods
    /// without getting closer to stall.
    pub const DEFAULT: MoveConfig = MoveConfig {
        cruise_gain: 0.2,
        approach_gain: 0.05,
        approach_m: 5e-3,
        default_tolerance_m: 1e-3,
        max_distance_m: 10.0,
        aim: 0.25,
        settle_periods: 6,
        stall_periods: 40,
    };
}

impl Default for MoveConfig {
    fn default() -> Self {
        MoveConfig::DEFAULT
    }
}

/// A goal as a client sends it (SI).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveRequest {
    /// Signed travel \[m\]: > 0 forward.
    pub distance_m: f64,
    /// Landing tolerance \[m\] (0 = the default).
    pub tolerance_m: f64,
    /// Time limit \[s\] (0 = none).
    pub timeout_s: f64,
}

/// Why a goal was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MoveRefusal {
    /// NaN or infinite distance.
    #[error("distance_m = {} is not finite", short(*.0))]
    DistanceNotFinite(f64),
    /// |distance| beyond the configured limit.
    #[error("distance_m = {} is beyond the configured limit of {} m", short(*.distance_m), short(*.limit_m))]
    BeyondLimit {
        /// The distance asked.
        distance_m: f64,
        /// The limit.
        limit_m: f64,
    },
    /// Negative or non-finite tolerance.
    #[error("tolerance_m = {} must be finite and >= 0 (0 = the default, {} m)", short(*.tolerance_m), short(*.default_m))]
    BadTolerance {
        /// The tolerance asked.
        tolerance_m: f64,
        /// The default.
        default_m: f64,
    },
    /// Negative or non-finite timeout.
    #[error("timeout_s = {} must be finite and >= 0 (0 = no limit)", short(*.0))]
    BadTimeout(f64),
}

impl MoveRequest {
    /// Checks the request against `config`: the refusal, or the tolerance that applies.
    pub fn validate(&self, config: &MoveConfig) -> Result<f64, MoveRefusal> {
        if !self.distance_m.is_finite() {
            return Err(MoveRefusal::DistanceNotFinite(self.distance_m));
        }
        if self.distance_m.abs() > config.max_distance_m {
            return Err(MoveRefusal::BeyondLimit {
                distance_m: self.distance_m,
                limit_m: config.max_distance_m,
            });
        }
        if !(self.tolerance_m.is_finite() && self.tolerance_m >= 0.0) {
            return Err(MoveRefusal::BadTolerance {
                tolerance_m: self.tolerance_m,
                default_m: config.default_tolerance_m,
            });
        }
        if !(self.timeout_s.is_finite() && self.timeout_s >= 0.0) {
            return Err(MoveRefusal::BadTimeout(self.timeout_s));
        }
        Ok(if self.tolerance_m == 0.0 {
            config.default_tolerance_m
        } else {
            self.tolerance_m
        })
    }
}

/// How a goal ended.
#[derive(Debug, Clone, PartialEq)]
pub enum MoveEnd {
    /// Landed within the tolerance.
    Reached,
    /// Ended by the law (timeout, stall) or by the caller, with the reason.
    Aborted(String),
    /// Cancelled by the client.
    Canceled,
}

/// A goal's end: how, where, when.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveOutcome {
    /// How it ended.
    pub end: MoveEnd,
    /// Travel from the reference \[m\].
    pub travelled_m: f64,
    /// `travelled_m - distance_m` \[m\].
    pub error_m: f64,
    /// From the first sample to the last \[s\].
    pub elapsed_s: f64,
}

impl MoveOutcome {
    /// The result's message: how it ended, in words.
    pub fn message(&self, distance_m: f64) -> String {
        let travel = format!(
            "travelled {} m of {} m (error {} m) in {} s",
            short(self.travelled_m),
            short(distance_m),
            short(self.error_m),
            short(self.elapsed_s)
        );
        match &self.end {
            MoveEnd::Reached => format!("reached: {travel}"),
            MoveEnd::Aborted(why) => format!("aborted: {why}; {travel}"),
            MoveEnd::Canceled => format!("canceled: {travel}"),
        }
    }
}

/// Where a running goal is (the action's feedback).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MoveProgress {
    /// Travel so far \[m\].
    pub travelled_m: f64,
    /// Distance left \[m\], signed.
    pub remaining_m: f64,
    /// Mean speed over the last drive period [m/s].
    pub speed_m_per_s: f64,
    /// The gain held now.
    pub kp: f64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// OFF until the first section crossing (the reference).
    Starting,
    /// Driving toward the target.
    Driving,
    /// OFF, periods left before the landing is judged.
    Settling(u32),
    /// Ended.
    Done,
}

/// A running move goal.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveRun {
    request: MoveRequest,
    tolerance_m: f64,
    config: MoveConfig,
    period_s: f64,
    phase: Phase,
    /// Time of the first sample and of the last \[s\].
    first_t: Option<f64>,
    last_t: f64,
    /// Capsule position at the reference crossing, and at the last sample \[m\].
    origin: f64,
    last_x2: f64,
    /// Index of the drive period of the first sample.
    start_index: i64,
    /// Index of the last section crossed and the capsule's position there.
    section: Option<(i64, f64)>,
    kp: f64,
    /// The last period's progression \[m\].
    step: f64,
    /// The coast after OFF over the progression of the period before it.
    coast_ratio: f64,
    /// Where the last stop was decided and the step then.
    stopped_at: Option<(f64, f64)>,
    best_remaining: f64,
    stalled: u32,
    speed: f64,
    outcome: Option<MoveOutcome>,
}

impl MoveRun {
    /// Starts `request` (refused with the reason if invalid) for a drive of period `period_s`.
    pub fn start(
        request: MoveRequest,
        config: MoveConfig,
        period_s: f64,
    ) -> Result<MoveRun, MoveRefusal> {
        let tolerance_m = request.validate(&config)?;
        Ok(MoveRun {
            request,
            tolerance_m,
            config,
            period_s,
            phase: Phase::Starting,
            first_t: None,
            last_t: 0.0,
            origin: 0.0,
            last_x2: 0.0,
            start_index: i64::MAX,
            section: None,
            kp: 0.0,
            step: 0.0,
            coast_ratio: COAST_RATIO,
            stopped_at: None,
            best_remaining: f64::INFINITY,
            stalled: 0,
            speed: 0.0,
            outcome: None,
        })
    }

    /// The goal as asked.
    pub fn request(&self) -> MoveRequest {
        self.request
    }

    /// The tolerance that applies \[m\].
    pub fn tolerance_m(&self) -> f64 {
        self.tolerance_m
    }

    /// The end, once there is one.
    pub fn outcome(&self) -> Option<&MoveOutcome> {
        self.outcome.as_ref()
    }

    fn travelled(&self) -> f64 {
        match self.phase {
            Phase::Starting => 0.0,
            _ => self.last_x2 - self.origin,
        }
    }

    /// Where the goal is now.
    pub fn progress(&self) -> MoveProgress {
        let travelled_m = self.travelled();
        MoveProgress {
            travelled_m,
            remaining_m: self.request.distance_m - travelled_m,
            speed_m_per_s: self.speed,
            kp: self.kp,
        }
    }

    /// A state sample at time `t_s` with the capsule at `x2_m`: the gain to hold from it.
    pub fn sample(&mut self, t_s: f64, x2_m: f64) -> f64 {
        if self.phase == Phase::Done {
            return 0.0;
        }
        let index = (t_s / self.period_s).floor() as i64;
        let t0 = *self.first_t.get_or_insert_with(|| {
            self.start_index = index;
            t_s
        });
        self.last_t = t_s;
        self.last_x2 = x2_m;
        let crossed = index > self.section.map_or(self.start_index, |(last, _)| last);
        if crossed {
            self.on_section(index, x2_m);
        }
        let timed_out = self.request.timeout_s > 0.0 && t_s - t0 >= self.request.timeout_s;
        if self.phase != Phase::Done && timed_out {
            self.end(MoveEnd::Aborted(format!(
                "timeout: {} s passed",
                short(self.request.timeout_s)
            )));
        }
        self.kp
    }

    /// At the first sample of drive period `index`, the capsule at `x2`: the decision.
    fn on_section(&mut self, index: i64, x2: f64) {
        let previous = self.section.replace((index, x2));
        if self.phase == Phase::Starting {
            self.origin = x2;
            self.phase = Phase::Driving;
        } else if let Some((_, x_prev)) = previous {
            self.step = x2 - x_prev;
            self.speed = self.step / self.period_s;
        }
        let remaining = self.request.distance_m - (x2 - self.origin);
        match self.phase {
            Phase::Settling(left) if left > 1 => self.phase = Phase::Settling(left - 1),
            Phase::Settling(_) => self.judge(x2, remaining),
            _ => self.drive(remaining),
        }
    }

    /// After settling: reached, or approach again; the coast measured.
    fn judge(&mut self, x2: f64, remaining: f64) {
        if let Some((at, step)) = self.stopped_at.take() {
            if step.abs() > 1e-9 {
                self.coast_ratio = ((x2 - at) / step).clamp(0.0, 2.0);
            }
        }
        if remaining.abs() <= self.tolerance_m {
            self.end(MoveEnd::Reached);
        } else {
            self.best_remaining = f64::INFINITY;
            self.drive(remaining);
        }
    }

    /// Chooses the next period's gain for `remaining`, or stops to land.
    fn drive(&mut self, remaining: f64) {
        let coming = self.kp != 0.0 && remaining * self.kp > 0.0;
        let coast = self.coast_ratio * self.step.abs() + 0.5 * self.step.abs();
        if remaining.abs() <= self.config.aim * self.tolerance_m
            || (coming && remaining.abs() <= coast)
        {
            self.stopped_at = Some((self.last_x2, self.step));
            self.kp = 0.0;
            self.phase = Phase::Settling(self.config.settle_periods.max(1));
            return;
        }
        self.phase = Phase::Driving;
        if remaining.abs() < self.best_remaining * 0.99 {
            self.best_remaining = remaining.abs();
            self.stalled = 0;
        } else {
            self.stalled += 1;
            if self.stalled >= self.config.stall_periods {
                self.end(MoveEnd::Aborted(format!(
                    "no progress toward the target for {} drive periods (the capsule does not move as driven)",
                    self.stalled
                )));
                return;
            }
        }
        let magnitude = if remaining.abs() > self.config.approach_m {
            self.config.cruise_gain
        } else {
            self.config.approach_gain.min(self.config.cruise_gain)
        };
        self.kp = magnitude.copysign(remaining);
    }

    fn end(&mut self, end: MoveEnd) {
        let travelled_m = self.travelled();
        self.kp = 0.0;
        self.phase = Phase::Done;
        self.outcome = Some(MoveOutcome {
            end,
            travelled_m,
            error_m: travelled_m - self.request.distance_m,
            elapsed_s: self.first_t.map_or(0.0, |t0| self.last_t - t0),
        });
    }

    /// The client cancelled: ends now, OFF.
    pub fn cancel(&mut self) {
        if self.phase != Phase::Done {
            self.end(MoveEnd::Canceled);
        }
    }

    /// Ends now, OFF, for `reason` (a new goal, a mode request, the plant gone).
    pub fn abort(&mut self, reason: String) {
        if self.phase != Phase::Done {
            self.end(MoveEnd::Aborted(reason));
        }
    }
}

#[cfg(test)]
mod tests;
