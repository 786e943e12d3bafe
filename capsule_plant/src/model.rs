//! The capsule model of Liu et al. 2014 (eq. 1-2), non-dimensional.
//!
//! State: inner mass `(x1, y1)` and capsule `(x2, y2)`. Internally the solvers integrate the
//! relative displacement `z = x1 - x2` (the dynamics are invariant under translation) and keep
//! `x2` as a compensated sum, so long runs do not lose the progression to rounding.
//!
//! Forces (paper eq. 1):
//! - on the mass from the capsule: `f_c = -z + 2 xi (y2 - y1) - H3 beta (z - delta)`,
//!   `H3 = [z >= delta]` (the secondary spring only pushes: one-sided contact);
//! - mass: `y1' = f_a(tau) + f_c`, with `f_a` the actuator force (drive + feedback, eq. 2-3);
//! - capsule, without friction: `F = -f_c`; it sticks (`y2 = 0` exactly) while `|F| <= f_b` and
//!   slips otherwise with `gamma y2' = F - f_s(y2, ...)`.
//!
//! The friction laws are in [`crate::friction`].

use serde::{Deserialize, Serialize};

pub use crate::friction::{Friction, FrictionConstant, FRICTION_CONSTANTS, K_S, MU_V, TAU_D, V_S};

/// Mechanical parameters of the capsule (paper's non-dimensional groups).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Capsule {
    /// Mass ratio `gamma = m2 / m1` (capsule over inner mass).
    pub gamma: f64,
    /// Stiffness ratio `beta = k2 / k1` of the secondary (contact) spring; 0 means none.
    pub beta: f64,
    /// Gap `delta = k1 G / P_f` before the secondary spring is touched.
    pub delta: f64,
    /// Damping ratio `xi = c / (2 m1 Omega_0)`.
    pub xi: f64,
}

impl Capsule {
    /// The paper's section-3 set: gamma 5, beta 15, delta 0.02, xi 0.01.
    pub const SECTION3: Capsule = Capsule {
        gamma: 5.0,
        beta: 15.0,
        delta: 0.02,
        xi: 0.01,
    };
}

impl std::fmt::Display for Capsule {
    /// `gamma 5, beta 15, delta 0.02, xi 0.01`, as captions and summaries print it.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let Capsule {
            gamma,
            beta,
            delta,
            xi,
        } = self;
        write!(f, "gamma {gamma}, beta {beta}, delta {delta}, xi {xi}")
    }
}

/// Capsule and friction law: everything the plant needs besides the actuator force.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Model {
    /// Mechanical parameters.
    pub capsule: Capsule,
    /// Friction law with its constants.
    pub friction: Friction,
}

impl Model {
    /// Whether the secondary (contact) spring exists; without it no contact events are checked.
    pub fn has_contact(&self) -> bool {
        self.capsule.beta > 0.0
    }

    /// The coupling of mass and capsule with the contact flag `H3` (see [`Coupling`]).
    #[inline(always)]
    pub fn coupling(&self, contact: bool) -> Coupling {
        Coupling {
            capsule: self.capsule,
            contact,
        }
    }

    /// Force on the capsule from spring, damper and contact, `F = -f_c`, for relative
    /// displacement `z = x1 - x2`, velocities, and the contact flag `H3`.
    #[inline(always)]
    pub fn capsule_force(&self, z: f64, y1: f64, y2: f64, contact: bool) -> f64 {
        self.coupling(contact).force(z, y1, y2)
    }

    /// Force of the secondary spring on the mass (positive pushes the mass back), zero out of contact.
    pub fn contact_force(&self, z: f64) -> f64 {
        self.coupling(self.has_contact() && z >= self.capsule.delta)
            .secondary_spring(z)
    }
}

/// The force between mass and capsule in one contact state: the spring, the damper and, in
/// contact, the secondary spring, `F = z + 2 xi (y1 - y2) + H3 beta (z - delta)` with
/// `z = x1 - x2`. The one definition of that force: its value for the Runge-Kutta right-hand
/// side, the transitions and the published forces, and its coefficients for the linear forms
/// (the exact solver, the break-away events' gradients, the Jacobian).
///
/// It holds the capsule's constants and works the coefficients out when asked, so the
/// Runge-Kutta right-hand side, which calls [`Coupling::force`] at every stage, compiles to the
/// bare arithmetic. Measured with `capsule bench speed` (best of 4 x 40 runs): storing `H3 beta`
/// and `2 xi` precomputed made the adaptive runs 9 % slower, and holding a reference to the
/// capsule made the exact run 4 % slower; this form is as fast as the hand-written one was.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coupling {
    capsule: Capsule,
    /// `H3`: the secondary spring is touched.
    pub contact: bool,
}

impl Coupling {
    /// `F` at relative displacement `z` and velocities `y1`, `y2`.
    #[inline(always)]
    pub fn force(&self, z: f64, y1: f64, y2: f64) -> f64 {
        let c = &self.capsule;
        let mut f = z + 2.0 * c.xi * (y1 - y2);
        if self.contact {
            f += c.beta * (z - c.delta);
        }
        f
    }

    /// The secondary spring's part of `F`, `H3 beta (z - delta)`.
    #[inline(always)]
    pub fn secondary_spring(&self, z: f64) -> f64 {
        if self.contact {
            self.capsule.beta * (z - self.capsule.delta)
        } else {
            0.0
        }
    }

    /// `H3 beta`: the secondary spring's stiffness in contact, 0 out of it.
    #[inline(always)]
    pub fn contact_stiffness(&self) -> f64 {
        if self.contact {
            self.capsule.beta
        } else {
            0.0
        }
    }

    /// `2 xi`: the damper's coefficient on `y1 - y2`.
    #[inline(always)]
    pub fn damping(&self) -> f64 {
        2.0 * self.capsule.xi
    }

    /// `dF/dz`, `1 + H3 beta`.
    #[inline(always)]
    pub fn stiffness(&self) -> f64 {
        1.0 + self.contact_stiffness()
    }

    /// `F` at `z = 0` and no relative velocity, `-H3 beta delta`.
    #[inline(always)]
    pub fn offset(&self) -> f64 {
        -self.contact_stiffness() * self.capsule.delta
    }
}

/// Mass and capsule state `(x1, y1, x2, y2)`, non-dimensional.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct State {
    /// Inner mass position.
    pub x1: f64,
    /// Inner mass velocity.
    pub y1: f64,
    /// Capsule position.
    pub x2: f64,
    /// Capsule velocity.
    pub y2: f64,
}

impl State {
    /// The state as `[x1, y1, x2, y2]`.
    pub fn to_array(self) -> [f64; 4] {
        [self.x1, self.y1, self.x2, self.y2]
    }

    /// A state from `[x1, y1, x2, y2]`.
    pub fn from_array(a: [f64; 4]) -> Self {
        State {
            x1: a[0],
            y1: a[1],
            x2: a[2],
            y2: a[3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capsule_force_includes_contact_only_past_the_gap() {
        let m = Model {
            capsule: Capsule::SECTION3,
            friction: Friction::COULOMB,
        };
        assert_eq!(m.contact_force(0.01), 0.0);
        assert!((m.contact_force(0.03) - 0.15).abs() < 1e-12);
        let f = m.capsule_force(0.03, 0.0, 0.0, true);
        assert!((f - (0.03 + 0.15)).abs() < 1e-12);
    }

    #[test]
    fn the_couplings_linear_coefficients_are_its_force() {
        let m = Model {
            capsule: Capsule::SECTION3,
            friction: Friction::COULOMB,
        };
        for contact in [false, true] {
            let k = m.coupling(contact);
            for (z, y1, y2) in [(0.0, 0.0, 0.0), (0.03, -0.4, 0.2), (-1.5, 2.0, -0.7)] {
                let linear = k.stiffness() * z + k.damping() * (y1 - y2) + k.offset();
                let f = k.force(z, y1, y2);
                assert!((f - linear).abs() < 1e-14, "{contact} {z}: {f} vs {linear}");
            }
        }
        assert_eq!(m.coupling(true).stiffness(), 16.0);
        assert_eq!(m.coupling(false).offset(), 0.0);
    }
}
