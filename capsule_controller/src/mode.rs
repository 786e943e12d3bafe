//! Control modes, their validation and gain selection, the stale-state decision, and the running
//! progression / efficiency estimate (paper eq. 4). Pure: times and samples are passed in.

use std::fmt;

use capsule_plant::number_text::short;

/// The controller's modes (codes as in `capsule_msgs/srv/SetMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Drive only, `k_p = 0`.
    Off,
    /// `k_p > 0`: forward motion (paper Fig. 15).
    Forward,
    /// `k_p < 0`: backward motion.
    Backward,
    /// The paper's stabilising gain (Fig. 16, `k_p = 1.0` by default).
    ChaosControl,
    /// Any finite gain within the configured limit.
    Custom,
    /// The attractor-switching action (see [`crate::switch`]): shown while it runs; not
    /// selectable with [`ModeConfig::select`], it takes the pulse fields of the request.
    SwitchAttractor,
}

impl Mode {
    /// Every mode in code order.
    pub const ALL: [Mode; 6] = [
        Mode::Off,
        Mode::Forward,
        Mode::Backward,
        Mode::ChaosControl,
        Mode::Custom,
        Mode::SwitchAttractor,
    ];

    /// The wire code (`SetMode.OFF` = 0, ...).
    pub fn code(self) -> u8 {
        match self {
            Mode::Off => 0,
            Mode::Forward => 1,
            Mode::Backward => 2,
            Mode::ChaosControl => 3,
            Mode::Custom => 4,
            Mode::SwitchAttractor => 5,
        }
    }

    /// The mode of a wire code, `None` if unknown.
    pub fn from_code(code: u8) -> Option<Mode> {
        Mode::ALL.into_iter().find(|m| m.code() == code)
    }

    /// The constant's name in `SetMode.srv`.
    pub fn name(self) -> &'static str {
        match self {
            Mode::Off => "OFF",
            Mode::Forward => "FORWARD",
            Mode::Backward => "BACKWARD",
            Mode::ChaosControl => "CHAOS_CONTROL",
            Mode::Custom => "CUSTOM",
            Mode::SwitchAttractor => "SWITCH_ATTRACTOR",
        }
    }

    /// Parses a name (case-insensitive, `-` or `_`), for command lines.
    pub fn parse_name(name: &str) -> Option<Mode> {
        let n = name.trim().to_ascii_uppercase().replace('-', "_");
        Mode::ALL
            .into_iter()
            .find(|m| m.name() == n || (n == "CHAOS" && *m == Mode::ChaosControl))
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a mode request was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ModeError {
    /// The code is none of the `SetMode` constants.
    #[error("unknown mode {0} (expected OFF=0, FORWARD=1, BACKWARD=2, CHAOS_CONTROL=3, CUSTOM=4, SWITCH_ATTRACTOR=5)")]
    UnknownMode(u8),
    /// SWITCH_ATTRACTOR where a mode is wanted (a ROS parameter, a schedule).
    #[error("SWITCH_ATTRACTOR is an action with pulse fields, not a mode to stay in: request it through set_mode")]
    NotAMode,
    /// NaN or infinite gain.
    #[error("gain {} is not finite", short(*.0))]
    NonFiniteGain(f64),
    /// |gain| beyond the configured limit.
    #[error("gain {} is beyond the configured limit |k_p| <= {}", short(*.gain), short(*.limit))]
    BeyondLimit {
        /// The gain that would result.
        gain: f64,
        /// The limit.
        limit: f64,
    },
}

/// The gains a controller is configured with.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ModeConfig {
    /// |k_p| for FORWARD / BACKWARD when the request gives 0.
    pub direction_gain: f64,
    /// k_p for CHAOS_CONTROL when the request gives 0.
    pub chaos_gain: f64,
    /// Largest |k_p| any mode may use.
    pub gain_limit: f64,
}

impl ModeConfig {
    /// 0.2 for direction control (the edge of the paper's Fig. 15 sweep), 1.0 for chaos control
    /// (Fig. 16), and a limit of 2.
    pub const DEFAULT: ModeConfig = ModeConfig {
        direction_gain: 0.2,
        chaos_gain: 1.0,
        gain_limit: 2.0,
    };
}

impl Default for ModeConfig {
    fn default() -> Self {
        ModeConfig::DEFAULT
    }
}

/// Why a configuration is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("controller gain setting `{name}` = {}: {reason}", short(*.value))]
pub struct ConfigError {
    /// The setting.
    pub name: &'static str,
    /// Its value.
    pub value: f64,
    /// What is wrong.
    pub reason: &'static str,
}

impl ModeConfig {
    /// Checks that all gains are finite, the limit positive, and the defaults within it.
    pub fn validate(&self) -> Result<(), ConfigError> {
        let check = |name, value: f64| {
            if !value.is_finite() {
                Err(ConfigError {
                    name,
                    value,
                    reason: "not finite",
                })
            } else if value < 0.0 {
                Err(ConfigError {
                    name,
                    value,
                    reason: "negative",
                })
            } else {
                Ok(())
            }
        };
        check("gain_limit", self.gain_limit)?;
        check("direction_gain", self.direction_gain)?;
        if !self.chaos_gain.is_finite() {
            return Err(ConfigError {
                name: "chaos_gain",
                value: self.chaos_gain,
                reason: "not finite",
            });
        }
        for (name, v) in [
            ("direction_gain", self.direction_gain),
            ("chaos_gain", self.chaos_gain),
        ] {
            if v.abs() > self.gain_limit {
                return Err(ConfigError {
                    name,
                    value: v,
                    reason: "beyond gain_limit",
                });
            }
        }
        Ok(())
    }

    /// Validates a request (wire code and gain) and returns the mode and the `k_p` it means.
    ///
    /// FORWARD / BACKWARD take the request's |gain| (0 = the configured default) with the sign
    /// of the direction; CHAOS_CONTROL takes the gain (0 = configured); CUSTOM takes the gain
    /// as is; OFF is `k_p = 0` whatever the gain (but a non-finite gain is still refused).
    pub fn select(&self, code: u8, gain: f64) -> Result<(Mode, f64), ModeError> {
        let mode = Mode::from_code(code).ok_or(ModeError::UnknownMode(code))?;
        if !gain.is_finite() {
            return Err(ModeError::NonFiniteGain(gain));
        }
        let or_default = |d: f64| if gain == 0.0 { d } else { gain };
        let kp = match mode {
            Mode::Off => 0.0,
            Mode::Forward => or_default(self.direction_gain).abs(),
            Mode::Backward => -or_default(self.direction_gain).abs(),
            Mode::ChaosControl => or_default(self.chaos_gain),
            Mode::Custom => gain,
            Mode::SwitchAttractor => return Err(ModeError::NotAMode),
        };
        if kp.abs() > self.gain_limit {
            return Err(ModeError::BeyondLimit {
                gain: kp,
                limit: self.gain_limit,
            });
        }
        Ok((mode, kp))
    }
}

/// Decides whether the last state sample is too old to act on (plant gone).
///
/// Times are seconds on any monotonic clock; the node uses a steady clock, because sim time
/// stops when the plant does.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Staleness {
    /// How long without a sample before the state counts as stale \[s\].
    pub timeout: f64,
    last: Option<f64>,
}

impl Staleness {
    /// A watchdog that has not seen a sample yet (and so is stale).
    pub fn new(timeout: f64) -> Self {
        Staleness {
            timeout,
            last: None,
        }
    }

    /// Notes a sample received at `now`.
    pub fn seen(&mut self, now: f64) {
        self.last = Some(now);
    }

    /// True when no sample came within `timeout` before `now` (or none ever).
    pub fn is_stale(&self, now: f64) -> bool {
        match self.last {
            None => true,
            Some(t) => now - t > self.timeout,
        }
    }
}

/// Running progression per drive period and control efficiency (paper eq. 4), non-dimensional.
///
/// Fed with every state sample and the actuator force held from that sample on. Under a
/// zero-order hold the actuator's work over one step is exactly `f_k (x1_{k+1} - x1_k)`,
/// so the work sums those. Progression counts whole drive periods since the last reset: the
/// capsule position at the first sample at or after each period boundary. Efficiency is the
/// progression over complete periods divided by the work over the same periods (eq. 4 summed
/// over periods).
#[derive(Debug, Clone, PartialEq)]
pub struct ProgressMeter {
    period: f64,
    start: Option<(f64, f64)>,
    last: Option<(f64, f64)>,
    held_force: f64,
    work: f64,
    periods: u32,
    x2_at_period: f64,
    work_at_period: f64,
}

impl ProgressMeter {
    /// A meter for a drive of period `period` (non-dim time), starting at the next sample.
    pub fn new(period: f64) -> Self {
        ProgressMeter {
            period,
            start: None,
            last: None,
            held_force: 0.0,
            work: 0.0,
            periods: 0,
            x2_at_period: 0.0,
            work_at_period: 0.0,
        }
    }

    /// Starts counting afresh from the next sample (e.g. after a mode change).
    pub fn reset(&mut self) {
        *self = ProgressMeter::new(self.period);
    }

    /// Adds a sample at `tau` with mass position `x1` and capsule position `x2`, and the force
    /// `force` the actuator holds from now to the next sample.
    pub fn sample(&mut self, tau: f64, x1: f64, x2: f64, force: f64) {
        if let Some((_, x1_prev)) = self.last {
            self.work += self.held_force * (x1 - x1_prev);
        }
        match self.start {
            None => {
                self.start = Some((tau, x2));
                self.x2_at_period = x2;
            }
            Some((tau0, _)) => {
                let n = ((tau - tau0) / self.period).floor();
                if n.is_finite() && n >= f64::from(self.periods) + 1.0 {
                    self.periods = n as u32;
                    self.x2_at_period = x2;
                    self.work_at_period = self.work;
                }
            }
        }
        self.last = Some((tau, x1));
        self.held_force = force;
    }

    /// Complete drive periods so far.
    pub fn periods(&self) -> u32 {
        self.periods
    }

    /// Mean progression per period over the complete periods (0 before the first).
    pub fn progression_per_period(&self) -> f64 {
        match (self.start, self.periods) {
            (Some((_, x2_0)), n) if n > 0 => (self.x2_at_period - x2_0) / f64::from(n),
            _ => 0.0,
        }
    }

    /// Progression over the complete periods divided by the actuator work over them (0 if none).
    pub fn efficiency(&self) -> f64 {
        match self.start {
            Some((_, x2_0)) if self.periods > 0 && self.work_at_period != 0.0 => {
                (self.x2_at_period - x2_0) / self.work_at_period
            }
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direction_modes_pick_the_sign_and_default_magnitude() {
        let c = ModeConfig::default();
        assert_eq!(c.select(1, 0.0), Ok((Mode::Forward, 0.2)));
        assert_eq!(c.select(1, -0.15), Ok((Mode::Forward, 0.15)));
        assert_eq!(c.select(2, 0.0), Ok((Mode::Backward, -0.2)));
        assert_eq!(c.select(2, 0.1), Ok((Mode::Backward, -0.1)));
        assert_eq!(c.select(0, 0.7), Ok((Mode::Off, 0.0)));
        assert_eq!(c.select(3, 0.0), Ok((Mode::ChaosControl, 1.0)));
        assert_eq!(c.select(3, 0.5), Ok((Mode::ChaosControl, 0.5)));
        assert_eq!(c.select(4, -1.25), Ok((Mode::Custom, -1.25)));
        assert_eq!(c.select(4, 0.0), Ok((Mode::Custom, 0.0)));
    }

    #[test]
    fn bad_requests_are_refused_with_a_reason() {
        let c = ModeConfig::default();
        assert_eq!(c.select(9, 0.1), Err(ModeError::UnknownMode(9)));
        assert!(matches!(c.select(4, f64::NAN), Err(ModeError::NonFiniteGain(g)) if g.is_nan()));
        assert_eq!(
            c.select(1, f64::INFINITY),
            Err(ModeError::NonFiniteGain(f64::INFINITY))
        );
        assert_eq!(
            c.select(0, f64::NEG_INFINITY),
            Err(ModeError::NonFiniteGain(f64::NEG_INFINITY))
        );
        assert_eq!(
            c.select(4, 2.5),
            Err(ModeError::BeyondLimit {
                gain: 2.5,
                limit: 2.0
            })
        );
        assert_eq!(
            c.select(2, 3.0),
            Err(ModeError::BeyondLimit {
                gain: -3.0,
                limit: 2.0
            })
        );
        assert!(c
            .select(9, 0.1)
            .unwrap_err()
            .to_string()
            .contains("unknown mode 9"));
        assert!(c.select(4, 2.5).unwrap_err().to_string().contains("limit"));
    }

    #[test]
    fn configs_are_validated() {
        assert!(ModeConfig::default().validate().is_ok());
        let bad = ModeConfig {
            chaos_gain: 3.0,
            ..ModeConfig::default()
        };
        assert_eq!(bad.validate().map_err(|e| e.name), Err("chaos_gain"));
        let bad = ModeConfig {
            gain_limit: f64::NAN,
            ..ModeConfig::default()
        };
        assert_eq!(bad.validate().map_err(|e| e.name), Err("gain_limit"));
        let bad = ModeConfig {
            direction_gain: -0.1,
            ..ModeConfig::default()
        };
        assert_eq!(bad.validate().map_err(|e| e.name), Err("direction_gain"));
    }

    #[test]
    fn codes_and_names_round_trip() {
        for m in Mode::ALL {
            assert_eq!(Mode::from_code(m.code()), Some(m));
            assert_eq!(Mode::parse_name(&m.name().to_lowercase()), Some(m));
        }
        assert_eq!(Mode::parse_name("chaos-control"), Some(Mode::ChaosControl));
        assert_eq!(Mode::parse_name("sideways"), None);
        assert_eq!(Mode::from_code(6), None);
        assert_eq!(
            ModeConfig::default().select(5, 0.3),
            Err(ModeError::NotAMode)
        );
    }

    #[test]
    fn staleness_follows_the_timeout() {
        let mut w = Staleness::new(0.5);
        assert!(w.is_stale(0.0));
        w.seen(1.0);
        assert!(!w.is_stale(1.4));
        assert!(w.is_stale(1.6));
        w.seen(1.6);
        assert!(!w.is_stale(1.7));
    }

    #[test]
    fn meter_measures_drift_per_period_and_work_under_zero_order_hold() {
        // capsule drifts 0.3 per period; mass moves as sin(tau); force held = 2 (constant)
        let period = 2.0 * std::f64::consts::PI;
        let mut m = ProgressMeter::new(period);
        let dt = period / 100.0;
        for k in 0..=1000 {
            let tau = k as f64 * dt;
            m.sample(tau, tau.sin(), 0.3 * tau / period, 2.0);
        }
        assert_eq!(m.periods(), 10);
        assert!(
            (m.progression_per_period() - 0.3).abs() < 1e-9,
            "{}",
            m.progression_per_period()
        );
        // work of a constant force over whole periods of sin is ~0 -> tiny; use a force in phase
        let mut m = ProgressMeter::new(period);
        for k in 0..=1000 {
            let tau = k as f64 * dt;
            m.sample(tau, tau.sin(), 0.3 * tau / period, tau.cos());
        }
        // integral of cos * d(sin) over 10 periods = 10 * pi
        let expected = 3.0 / (10.0 * std::f64::consts::PI);
        assert!(
            (m.efficiency() - expected).abs() < 0.01 * expected,
            "{} vs {expected}",
            m.efficiency()
        );
        m.reset();
        assert_eq!(m.periods(), 0);
        assert_eq!(m.progression_per_period(), 0.0);
    }
}
