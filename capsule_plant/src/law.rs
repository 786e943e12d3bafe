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

/// Piecewise-affine actuator law `alpha cos(omega tau) + bias + kp |x2 - x1|` (the paper's
/// eq. 2-3; a held command is `bias` alone): the one form in which solvers, the equations and
/// the analyses take it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AffineLaw {
    /// Harmonic amplitude.
    pub alpha: f64,
    /// Harmonic frequency.
    pub omega: f64,
    /// Constant part.
    pub bias: f64,
    /// Gain on `|x2 - x1|`.
    pub kp: f64,
}

impl AffineLaw {
    /// The actuator force at `tau` for relative displacement `z` on side `sigma` of the kink.
    #[inline]
    pub fn force(&self, tau: f64, z: f64, sigma: f64) -> f64 {
        self.alpha * (self.omega * tau).cos() + self.bias + self.kp * sigma * z
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
