//! The plant's bounds on a command, besides its order: an actuator force limit and a horizon
//! for the command's stamp.
//!
//! - **Force limit**: a finite command beyond `max_force_n` is *saturated* to it (as a real
//!   actuator's amplifier clips), counted and logged (rate-limited). Saturating rather than
//!   refusing keeps a controller whose law briefly exceeds the limit in control, and a
//!   command of 1e308 N can no longer drive the simulation to a non-finite state (issue 12:
//!   it ended the plant). The default is [`DEFAULT_MAX_FORCE_PF`] times the scene's friction
//!   threshold `P_f`.
//! - **Stamp horizon**: a command answers a published sample, so its stamp cannot be later
//!   than the newest sample's. One stamped beyond that (plus one sample period of rounding) is
//!   refused as from the future: otherwise a single command stamped `sec = 2^31 - 1` became the
//!   newest accepted one and every later, correct command was refused as late.

use tracing::warn;

use capsule_hardware::throttle::Throttle;

/// The default force limit in units of the friction threshold `P_f`: 100 `P_f` (10 N at the
/// scenes' scale), more than ten times what the paper's law asks at the control point (drive
/// alpha = 1.6 plus feedback at the gain limit |k_p| = 2 over |x2 - x1| of a few units); the
/// largest drive a scene may ask is this limit, so it is never saturated alone.
pub const DEFAULT_MAX_FORCE_PF: f64 = capsule_plant::scene::MAX_DRIVE_ALPHA;

/// Saturates commanded forces at a limit and counts the saturated ones.
#[derive(Debug, Clone)]
pub struct CommandGate {
    max_force_n: f64,
    log: Throttle,
}

impl CommandGate {
    /// A gate saturating at `max_force_n` (finite, > 0: the caller validates).
    pub fn new(max_force_n: f64) -> Self {
        CommandGate {
            max_force_n,
            log: Throttle::default(),
        }
    }

    /// The force limit \[N\].
    pub fn max_force_n(&self) -> f64 {
        self.max_force_n
    }

    /// Commands saturated so far.
    pub fn saturated(&self) -> u64 {
        self.log.seen()
    }

    /// The force to apply for a finite command of `force_n` \[N\] answering `seq`: itself, or
    /// saturated at the limit (counted, logged rate-limited).
    pub fn limit(&mut self, force_n: f64, seq: u64) -> f64 {
        if force_n.abs() <= self.max_force_n {
            return force_n;
        }
        let applied = self.max_force_n.copysign(force_n);
        if self.log.tick() {
            warn!(
                "command for seq {seq}: {force_n} N is beyond the force limit {} N: applying {applied} N ({} saturated so far)",
                self.max_force_n,
                self.log.seen()
            );
        }
        applied
    }
}

/// True if a command stamped `stamp_ns` is later than the newest published sample
/// (`newest_ns`) by more than `tolerance_ns`: it cannot answer any sample of this plant.
pub fn from_the_future(stamp_ns: i64, newest_ns: i64, tolerance_ns: i64) -> bool {
    stamp_ns > newest_ns.saturating_add(tolerance_ns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn huge_forces_saturate_with_their_sign_and_are_counted() {
        let mut g = CommandGate::new(10.0);
        assert_eq!(g.limit(3.5, 0), 3.5);
        assert_eq!(g.limit(-10.0, 1), -10.0);
        assert_eq!(g.saturated(), 0);
        assert_eq!(g.limit(1e308, 2), 10.0);
        assert_eq!(g.limit(-1e308, 3), -10.0);
        assert_eq!(g.limit(1000.0, 4), 10.0);
        assert_eq!(g.saturated(), 3);
    }

    #[test]
    fn stamps_beyond_the_newest_sample_are_from_the_future() {
        assert!(!from_the_future(5, 5, 0));
        assert!(!from_the_future(6, 5, 1));
        assert!(from_the_future(7, 5, 1));
        assert!(from_the_future(i64::MAX, i64::MAX - 1, 0));
        assert!(!from_the_future(i64::MAX, i64::MAX - 1, 5), "no overflow");
    }
}
