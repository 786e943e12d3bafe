//! A feedback-gain schedule over drive periods: a gain before, an optional pulse of another gain
//! for some periods, and a gain after (the paper's Fig 20 and intermittent control, its ref. \[21\]).

use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use serde::Serialize;

/// A pulse of gain `kp` for `periods` drive periods starting at period `at` (0-based).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Pulse {
    /// Gain during the pulse.
    pub kp: f64,
    /// First period of the pulse.
    pub at: u32,
    /// Length in drive periods.
    pub periods: u32,
}

/// Gain per drive period: `before` until the pulse, the pulse's gain during it, `after` from its
/// end on. Without a pulse the gain is `before` throughout.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GainSchedule {
    /// Gain before the pulse (or throughout without one).
    pub before: f64,
    /// The pulse, if any.
    pub pulse: Option<Pulse>,
    /// Gain after the pulse.
    pub after: f64,
}

impl GainSchedule {
    /// One gain throughout.
    pub fn constant(kp: f64) -> Self {
        GainSchedule {
            before: kp,
            pulse: None,
            after: kp,
        }
    }

    /// The gain in drive period `n` (0-based).
    pub fn kp_at(&self, n: u32) -> f64 {
        match self.pulse {
            None => self.before,
            Some(p) if n < p.at => self.before,
            Some(p) if n - p.at < p.periods => p.kp,
            Some(_) => self.after,
        }
    }

    /// The same schedule with the pulse (if any) moved to start at period `at`.
    pub fn with_pulse_at(&self, at: u32) -> Self {
        GainSchedule {
            pulse: self.pulse.map(|p| Pulse { at, ..p }),
            ..*self
        }
    }

    /// The gain no longer changes from period `n` on.
    pub fn is_constant_from(&self, n: u32) -> bool {
        self.pulse
            .is_none_or(|p| u64::from(n) >= u64::from(p.at) + u64::from(p.periods))
    }

    /// The paper's law (the scene's drive) with the gain of period `n`: the actuator law the
    /// simulator integrates over that period, piecewise affine, so the exact method applies.
    pub fn law(&self, scene: &Scene, n: u32) -> AffineLaw {
        AffineLaw::paper(scene.drive.alpha, scene.drive.omega, self.kp_at(n))
    }

    /// Check the schedule against a run of `periods` drive periods: finite gains, a pulse of at
    /// least one period that ends within the run. Errors name the setting and the reason.
    pub fn validate(&self, periods: u32) -> Result<(), (&'static str, String)> {
        for (name, v) in [("kp", self.before), ("kp-after", self.after)] {
            if !v.is_finite() {
                return Err((name, format!("{v} is not a finite number")));
            }
        }
        if let Some(p) = self.pulse {
            if !p.kp.is_finite() {
                return Err(("pulse-kp", format!("{} is not a finite number", p.kp)));
            }
            if p.periods == 0 {
                return Err(("pulse-periods", "must be at least 1".into()));
            }
            let end = u64::from(p.at) + u64::from(p.periods);
            if end > u64::from(periods) {
                return Err((
                    "pulse-at",
                    format!(
                        "the pulse (periods {} to {}) ends after the run's {periods} periods",
                        p.at,
                        end - 1
                    ),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gain_follows_the_schedule() {
        let s = GainSchedule {
            before: 0.0,
            pulse: Some(Pulse {
                kp: 0.3,
                at: 10,
                periods: 2,
            }),
            after: 0.05,
        };
        let got: Vec<f64> = (8..14).map(|n| s.kp_at(n)).collect();
        assert_eq!(got, [0.0, 0.0, 0.3, 0.3, 0.05, 0.05]);
        assert_eq!(GainSchedule::constant(0.1).kp_at(1000), 0.1);
    }

    #[test]
    fn bad_schedules_are_refused() {
        let pulse = |kp, at, periods| GainSchedule {
            before: 0.0,
            pulse: Some(Pulse { kp, at, periods }),
            after: 0.0,
        };
        assert_eq!(pulse(0.3, 298, 2).validate(300), Ok(()));
        assert_eq!(
            pulse(0.3, 299, 2).validate(300).map_err(|e| e.0),
            Err("pulse-at")
        );
        assert_eq!(
            pulse(f64::NAN, 1, 1).validate(300).map_err(|e| e.0),
            Err("pulse-kp")
        );
        assert_eq!(
            pulse(0.3, 1, 0).validate(300).map_err(|e| e.0),
            Err("pulse-periods")
        );
        let nan_after = GainSchedule {
            after: f64::NAN,
            ..GainSchedule::constant(0.0)
        };
        assert_eq!(nan_after.validate(300).map_err(|e| e.0), Err("kp-after"));
    }
}
