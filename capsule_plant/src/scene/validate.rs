//! Validation of a scene: every value checked, the first bad one refused with its key.

use super::error::{Fault, Invalid};
use super::rule::{Rule, KEY_RULES};
use super::types::Scene;
use crate::solver::Method;

impl Scene {
    /// Check every value; the first bad one is refused with its key and the reason.
    pub fn validate(&self) -> Result<(), Invalid> {
        // every fixed key names a number (a unit test of `number.rs` holds it)
        for (key, rule) in KEY_RULES {
            if let Ok(v) = self.number(key) {
                rule.check(key, v)?;
            }
        }
        let mut checks: Vec<(&str, f64, Rule)> = vec![
            ("initial.state[0] (x1)", self.initial.x1, Rule::Finite),
            ("initial.state[1] (y1)", self.initial.y1, Rule::Finite),
            ("initial.state[2] (x2)", self.initial.x2, Rule::Finite),
            ("initial.state[3] (y2)", self.initial.y2, Rule::Finite),
        ];
        let friction = self.model.friction.constants();
        let keys: Vec<String> = friction
            .iter()
            .map(|(c, _)| format!("friction.{}", c.key))
            .collect();
        for ((c, v), key) in friction.iter().zip(&keys) {
            let rule = if c.positive {
                Rule::Positive
            } else {
                Rule::NonNegative
            };
            checks.push((key, *v, rule));
        }
        match self.solver.method {
            Method::Adaptive => checks.push(("solver.tol", self.solver.tol, Rule::Tolerance)),
            Method::Fixed => checks.push(("solver.step", self.solver.step, Rule::Positive)),
            Method::Exact => {}
        }
        for (key, v, rule) in checks {
            rule.check(key, v)?;
        }
        if let Some(d) = &self.device {
            for (key, v, positive) in d.numbers() {
                let rule = if positive {
                    Rule::Positive
                } else {
                    Rule::NonNegative
                };
                rule.check(&format!("device.{key}"), v)?;
            }
        }
        let h = self.horizon;
        if h.periods == 0 {
            return Err(Invalid::new(
                "horizon.periods",
                Fault::NotACount {
                    got: "0".into(),
                    min: 1,
                    max: u32::MAX,
                },
            ));
        }
        if h.transient >= h.periods {
            return Err(Invalid::new(
                "horizon.transient",
                Fault::TransientNotBelowPeriods {
                    transient: h.transient,
                    periods: h.periods,
                },
            ));
        }
        if self.solver.method == Method::Exact && !self.model.friction.is_piecewise_linear() {
            return Err(Invalid::new(
                "solver.method",
                Fault::ExactNeedsPiecewiseLinear(self.model.friction.name()),
            ));
        }
        Ok(())
    }
}
