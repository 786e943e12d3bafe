//! Actuator force laws: the force the actuator applies to the inner mass.
//!
//! The simulator takes any law. A law that can say it is *piecewise affine and harmonic*
//! (`alpha cos(omega tau) + bias + k_p |x2 - x1|`, the paper's eq. 2-3 and a held command are of
//! this kind) gets the exact integrator and a located event at the kink `x1 = x2`; any other law is
//! integrated by the Runge-Kutta methods as a black box.

use crate::model::State;

/// The structure of a law, so that solvers can exploit it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LawShape {
    /// `alpha cos(omega tau) + bias + kp |x2 - x1|`.
    PiecewiseAffine(AffineLaw),
    /// Anything else: evaluated through [`ActuatorLaw::force`] only.
    General,
}

/// Piecewise-affine actuator law `alpha cos(omega tau) + bias + kp |x2 - x1|`: the paper's
/// harmonic drive plus position feedback (eq. 2-3, `bias` 0), and a held command (`bias`
/// alone). The one actuator-law type from the command line to the solver: the controller node
/// computes its commands with it, the analyses simulate it, the exact solver and the equations
/// read its coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineLaw {
    /// Drive amplitude `alpha = P_d / P_f`.
    pub alpha: f64,
    /// Drive frequency `omega = Omega / Omega_0`.
    pub omega: f64,
    /// Constant part.
    pub bias: f64,
    /// Position feedback gain `k_p` on `|x2 - x1|`; 0 switches the feedback off.
    pub kp: f64,
}

impl AffineLaw {
    /// The paper's law (eq. 2-3): drive `alpha cos(omega tau)` plus `k_p |x2 - x1|`.
    pub const fn paper(alpha: f64, omega: f64, kp: f64) -> AffineLaw {
        AffineLaw {
            alpha,
            omega,
            bias: 0.0,
            kp,
        }
    }

    /// The harmonic part of the force, `alpha cos(omega tau)`.
    #[inline]
    pub fn drive(&self, tau: f64) -> f64 {
        self.alpha * (self.omega * tau).cos()
    }

    /// The feedback part of the force, `k_p |x2 - x1|`.
    #[inline]
    pub fn feedback(&self, x1: f64, x2: f64) -> f64 {
        self.kp * (x2 - x1).abs()
    }

    /// The actuator force on the inner mass at `tau` for mass and capsule positions.
    #[inline]
    pub fn force_at(&self, tau: f64, x1: f64, x2: f64) -> f64 {
        self.drive(tau) + self.feedback(x1, x2) + self.bias
    }

    /// The same force in the equations' coordinates: relative displacement `z = x1 - x2` on
    /// side `sigma = sign(z)` of the kink, where `|x2 - x1| = sigma z` is linear.
    #[inline]
    pub fn force_on_side(&self, tau: f64, z: f64, sigma: f64) -> f64 {
        self.alpha * (self.omega * tau).cos() + self.bias + self.kp * sigma * z
    }

    /// The drive period `2 pi / omega`.
    pub fn period(&self) -> f64 {
        std::f64::consts::TAU / self.omega
    }
}

impl ActuatorLaw for AffineLaw {
    fn force(&self, tau: f64, s: &State) -> f64 {
        self.force_at(tau, s.x1, s.x2)
    }

    fn shape(&self) -> LawShape {
        LawShape::PiecewiseAffine(*self)
    }
}

/// A force law acting on the inner mass.
pub trait ActuatorLaw {
    /// The force at time `tau` in state `s`.
    fn force(&self, tau: f64, s: &State) -> f64;

    /// The law's structure; [`LawShape::General`] unless the law says more.
    fn shape(&self) -> LawShape {
        LawShape::General
    }
}

/// A constant force, e.g. a command held by a zero-order hold between samples.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConstantForce(pub f64);

impl ActuatorLaw for ConstantForce {
    fn force(&self, _tau: f64, _s: &State) -> f64 {
        self.0
    }

    fn shape(&self) -> LawShape {
        LawShape::PiecewiseAffine(AffineLaw {
            alpha: 0.0,
            omega: 0.0,
            bias: self.0,
            kp: 0.0,
        })
    }
}

impl<L: ActuatorLaw + ?Sized> ActuatorLaw for &L {
    fn force(&self, tau: f64, s: &State) -> f64 {
        (**self).force(tau, s)
    }
    fn shape(&self) -> LawShape {
        (**self).shape()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn feedback_matches_eq3_on_both_sides_of_the_kink() {
        // eq. 3: f_p = k_p|x2-x1| + (x2-x1) = (1-k_p)(x2-x1) if x1 >= x2, (1+k_p)(x2-x1) otherwise
        let law = AffineLaw::paper(0.0, 1.0, 0.3);
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
            // the equations' form on the side of the kink gives the same force
            let z = x1 - x2;
            let sigma = if z < 0.0 { -1.0 } else { 1.0 };
            let on_side = law.force_on_side(0.0, z, sigma);
            assert!((law.force_at(0.0, x1, x2) - on_side).abs() < 1e-15);
        }
    }

    #[test]
    fn drive_is_alpha_at_phase_zero_and_period_is_two_pi_over_omega() {
        let law = AffineLaw::paper(1.6, 1.1, 0.0);
        assert_eq!(law.drive(0.0), 1.6);
        assert!((law.drive(law.period()) - 1.6).abs() < 1e-12);
        assert!((law.drive(law.period() / 2.0) + 1.6).abs() < 1e-12);
    }
}
