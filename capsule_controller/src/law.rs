//! The paper's actuator force: `f_a(tau) = alpha cos(omega tau) + k_p |x2 - x1|`.

/// Harmonic drive on the inner mass plus position feedback (paper eq. 2-3), non-dimensional.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeedbackLaw {
    /// Drive amplitude `alpha = P_d / P_f`.
    pub alpha: f64,
    /// Drive frequency `omega = Omega / Omega_0`.
    pub omega: f64,
    /// Position feedback gain `k_p`; 0 switches the feedback off.
    pub kp: f64,
}

impl FeedbackLaw {
    /// The harmonic part of the force, `alpha cos(omega tau)`.
    pub fn drive(&self, tau: f64) -> f64 {
        self.alpha * (self.omega * tau).cos()
    }

    /// The feedback part of the force, `k_p |x2 - x1|`.
    pub fn feedback(&self, x1: f64, x2: f64) -> f64 {
        self.kp * (x2 - x1).abs()
    }

    /// The whole actuator force on the inner mass at time `tau` for mass and capsule positions.
    pub fn force(&self, tau: f64, x1: f64, x2: f64) -> f64 {
        self.drive(tau) + self.feedback(x1, x2)
    }

    /// The drive period `2 pi / omega`.
    pub fn period(&self) -> f64 {
        std::f64::consts::TAU / self.omega
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feedback_matches_eq3_on_both_sides_of_the_kink() {
        // eq. 3: f_p = k_p|x2-x1| + (x2-x1) = (1-k_p)(x2-x1) if x1 >= x2, (1+k_p)(x2-x1) otherwise
        let law = FeedbackLaw {
            alpha: 0.0,
            omega: 1.0,
            kp: 0.3,
        };
        for (x1, x2) in [(0.5, 0.1), (0.1, 0.5), (-0.2, -0.2)] {
            let fp = law.feedback(x1, x2) + (x2 - x1);
            let expected = if x1 >= x2 {
                (1.0 - 0.3) * (x2 - x1)
            } else {
                (1.0 + 0.3) * (x2 - x1)
            };
            assert!(
                (fp - expected).abs() < 1e-15,
                "x1={x1} x2={x2}: {fp} vs {expected}"
            );
        }
    }

    #[test]
    fn drive_is_alpha_at_phase_zero_and_period_is_two_pi_over_omega() {
        let law = FeedbackLaw {
            alpha: 1.6,
            omega: 1.1,
            kp: 0.0,
        };
        assert_eq!(law.drive(0.0), 1.6);
        assert!((law.drive(law.period()) - 1.6).abs() < 1e-12);
        assert!((law.drive(law.period() / 2.0) + 1.6).abs() < 1e-12);
    }
}
