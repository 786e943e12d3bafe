//! The capsule model of Liu et al. 2014 (eq. 1-2), non-dimensional, and its four friction laws.
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
//! Friction laws (Table 1 of the paper, garbled in the seed text; reconstructed from ref. \[14\],
//! Liu, Pavlovskaia, Wiercigroch 2013, and the seven-parameter model of ref. \[27\], Wojewoda et al.
//! 2008). `s = sign(y2)`, `v_s` the Stribeck velocity, `y2d = y2(tau - tau_d)`:
//!
//! | law | sliding friction `f_s` | threshold `f_b` | in stick |
//! |---|---|---|---|
//! | Coulomb | `s` | 1 | `y2 = 0` |
//! | Coulomb + viscous | `s + mu_v y2` | 1 | `y2 = 0` |
//! | Coulomb + Stribeck | `s (1 + exp(-abs(y2) / v_s))` | 2 | `y2 = 0` |
//! | seven-parameter | `s + mu_v y2 + s / (1 + (y2d / v_s)^2)` | 2 | pre-sliding spring `k_s p` |
//!
//! Each sliding law equals its threshold at `y2 -> 0` (Stribeck: `1 + e^0 = 2`; seven-parameter
//! with the delayed velocity still zero just after break-away: `1 + 1 = 2`), so the friction
//! force is continuous at break-away. For the seven-parameter law the stuck capsule rests on a
//! stiff pre-sliding spring: `p = x2 - a` is its displacement from the anchor `a` where it last
//! stuck, the static friction force is `k_s p`, and it breaks away when `|k_s p|` reaches `f_b`
//! (the spring can hold no more). On sticking, the anchor is set so that the spring balances the
//! force at that instant (`k_s p = F`): the friction force stays continuous. The paper writes
//! this static friction `k_s x2`; with `x2` measured from the anchor that is the same law.

use serde::{Deserialize, Serialize};

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

/// The friction between capsule and environment (Table 1), with its constants.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "kebab-case")]
pub enum Friction {
    /// Dry Coulomb friction: `f_s = sign(y2)`, `f_b = 1`.
    Coulomb,
    /// Coulomb plus viscous damping: `f_s = sign(y2) + mu_v y2`, `f_b = 1`.
    Viscous {
        /// Viscous coefficient `mu_v`.
        mu_v: f64,
    },
    /// Coulomb plus Stribeck: `f_s = sign(y2) (1 + exp(-|y2| / v_s))`, `f_b = 2`.
    Stribeck {
        /// Stribeck velocity `v_s`.
        v_s: f64,
    },
    /// Seven-parameter law: Stribeck with frictional memory and pre-sliding, `f_b = 2`.
    SevenParameter {
        /// Viscous coefficient `mu_v`.
        mu_v: f64,
        /// Stribeck velocity `v_s`.
        v_s: f64,
        /// Frictional-memory delay `tau_d` of the velocity in the Stribeck term.
        tau_d: f64,
        /// Pre-sliding stiffness `k_s` while stuck.
        k_s: f64,
    },
}

impl Friction {
    /// Break-away threshold `f_b` of the law.
    pub fn threshold(&self) -> f64 {
        match self {
            Friction::Coulomb | Friction::Viscous { .. } => 1.0,
            Friction::Stribeck { .. } | Friction::SevenParameter { .. } => 2.0,
        }
    }

    /// Sliding friction force for a capsule slipping in direction `dir` (+1/-1) at velocity
    /// `y2`, with `y2_delayed = y2(tau - tau_d)` (read only by the seven-parameter law with
    /// frictional memory). The formulas live once, in the solver's friction types.
    pub fn sliding(&self, dir: f64, y2: f64, y2_delayed: f64) -> f64 {
        crate::solver::friction::with_friction!(*self, f => f.sliding(dir, y2, y2_delayed))
    }

    /// `d f_s / d y2` of the sliding force at velocity `y2` in direction `dir`, the delayed
    /// velocity held fixed (what the Jacobian of the right-hand side needs).
    pub fn sliding_slope(&self, dir: f64, y2: f64) -> f64 {
        crate::solver::friction::with_friction!(*self, f => f.slope(dir, y2))
    }

    /// Whether the law is linear in the state between events (exact piecewise solution exists).
    pub fn is_piecewise_linear(&self) -> bool {
        matches!(self, Friction::Coulomb | Friction::Viscous { .. })
    }

    /// Viscous coefficient of the linear laws (0 for Coulomb).
    pub fn viscous(&self) -> f64 {
        match *self {
            Friction::Viscous { mu_v } | Friction::SevenParameter { mu_v, .. } => mu_v,
            _ => 0.0,
        }
    }

    /// Frictional-memory delay, if the law has one.
    pub fn memory_delay(&self) -> Option<f64> {
        match *self {
            Friction::SevenParameter { tau_d, .. } if tau_d > 0.0 => Some(tau_d),
            _ => None,
        }
    }

    /// Pre-sliding stiffness, if the law has one.
    pub fn presliding(&self) -> Option<f64> {
        match *self {
            Friction::SevenParameter { k_s, .. } if k_s > 0.0 => Some(k_s),
            _ => None,
        }
    }

    /// The law's short name (scene files, command line) and its title in the paper's figures.
    fn labels(&self) -> (&'static str, &'static str) {
        match self {
            Friction::Coulomb => ("coulomb", "Coulomb"),
            Friction::Viscous { .. } => ("viscous", "Coulomb viscous"),
            Friction::Stribeck { .. } => ("stribeck", "Coulomb Stribeck"),
            Friction::SevenParameter { .. } => ("seven-parameter", "seven-parameter"),
        }
    }

    /// Short name as used in scene files and on the command line.
    pub fn name(&self) -> &'static str {
        self.labels().0
    }

    /// The law as the paper's figures title it.
    pub fn title(&self) -> &'static str {
        self.labels().1
    }

    /// Every law with the paper's constants: the one list from which scene files, the command
    /// line, figures and error messages take the laws and their names.
    pub const LAWS: [Friction; 4] = Friction::laws_with(MU_V.paper, TAU_D.paper, K_S.paper);

    /// Every law with these constants (`v_s` the paper's); the unit tests probe other values.
    pub(crate) const fn laws_with(mu_v: f64, tau_d: f64, k_s: f64) -> [Friction; 4] {
        let v_s = V_S.paper;
        [
            Friction::Coulomb,
            Friction::Viscous { mu_v },
            Friction::Stribeck { v_s },
            Friction::SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            },
        ]
    }

    /// The law called `name` (see [`Friction::name`]) with the paper's constants.
    pub fn by_name(name: &str) -> Option<Friction> {
        Friction::LAWS.into_iter().find(|l| l.name() == name)
    }

    /// The names of all laws, `a, b, c or d`, for messages.
    pub fn names() -> String {
        one_of(Friction::LAWS.map(|l| l.name()))
    }

    /// The law's constants, each with its slot, in [`FRICTION_CONSTANTS`] order: what scene files
    /// and flags may set for this law (anything else does not apply to it).
    pub fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        match self {
            Friction::Coulomb => vec![],
            Friction::Viscous { mu_v } => vec![(&MU_V, mu_v)],
            Friction::Stribeck { v_s } => vec![(&V_S, v_s)],
            Friction::SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            } => vec![(&MU_V, mu_v), (&V_S, v_s), (&TAU_D, tau_d), (&K_S, k_s)],
        }
    }

    /// The law's constants with their values, in [`FRICTION_CONSTANTS`] order.
    pub fn constants(&self) -> Vec<(&'static FrictionConstant, f64)> {
        let mut law = *self;
        law.constants_mut()
            .into_iter()
            .map(|(c, v)| (c, *v))
            .collect()
    }

    /// Sets the constant `key` (a [`FrictionConstant::key`]); `false` if the law has no such
    /// constant.
    pub fn set_constant(&mut self, key: &str, value: f64) -> bool {
        match self.constants_mut().into_iter().find(|(c, _)| c.key == key) {
            Some((_, slot)) => {
                *slot = value;
                true
            }
            None => false,
        }
    }
}

/// `a, b or c`: a list of names for messages.
pub(crate) fn one_of<const N: usize>(names: [&str; N]) -> String {
    match names.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => names.join(""),
    }
}

/// A constant of a friction law: its key in scene files (`--mu-v` style on the command line),
/// the paper's section-3 value, and its range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrictionConstant {
    /// Key in the scene file's `[friction]` table.
    pub key: &'static str,
    /// What it is.
    pub meaning: &'static str,
    /// The paper's section-3 value, taken where a scene leaves the constant out.
    pub paper: f64,
    /// Must be positive (else non-negative).
    pub positive: bool,
}

impl FrictionConstant {
    const fn new(key: &'static str, meaning: &'static str, paper: f64, positive: bool) -> Self {
        FrictionConstant {
            key,
            meaning,
            paper,
            positive,
        }
    }

    /// The command-line flag, without the dashes (`mu-v`).
    pub fn flag(&self) -> String {
        self.key.replace('_', "-")
    }
}

/// Viscous coefficient `mu_v` (paper: 0.1).
pub const MU_V: FrictionConstant = FrictionConstant::new("mu_v", "viscous coefficient", 0.1, false);
/// Stribeck velocity `v_s` (paper: 0.1).
pub const V_S: FrictionConstant = FrictionConstant::new("v_s", "Stribeck velocity", 0.1, true);
/// Frictional-memory delay `tau_d` (paper: 0.05).
pub const TAU_D: FrictionConstant =
    FrictionConstant::new("tau_d", "frictional-memory delay", 0.05, false);
/// Pre-sliding stiffness `k_s` (paper: 4e4).
pub const K_S: FrictionConstant = FrictionConstant::new("k_s", "pre-sliding stiffness", 4e4, true);
pub const FRICTION_CONSTANTS: [FrictionConstant; 4] = [MU_V, V_S, TAU_D, K_S];

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

    /// Force on the capsule from spring, damper and contact, `F = -f_c`, for relative
    /// displacement `z = x1 - x2`, velocities, and the contact flag `H3`.
    #[inline]
    pub fn capsule_force(&self, z: f64, y1: f64, y2: f64, contact: bool) -> f64 {
        let c = &self.capsule;
        let mut f = z + 2.0 * c.xi * (y1 - y2);
        if contact {
            f += c.beta * (z - c.delta);
        }
        f
    }

    /// Force of the secondary spring on the mass (positive pushes the mass back), zero out of contact.
    pub fn contact_force(&self, z: f64) -> f64 {
        let c = &self.capsule;
        if self.has_contact() && z >= c.delta {
            c.beta * (z - c.delta)
        } else {
            0.0
        }
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
    fn sliding_friction_is_continuous_with_the_threshold_at_zero_velocity() {
        for law in Friction::LAWS {
            for dir in [1.0, -1.0] {
                let f = law.sliding(dir, 0.0, 0.0);
                assert_eq!(f, dir * law.threshold(), "{law:?} dir {dir}");
            }
        }
    }

    #[test]
    fn stribeck_friction_decays_to_coulomb_at_high_speed() {
        let law = Friction::Stribeck { v_s: 0.1 };
        assert!((law.sliding(1.0, 5.0, 0.0) - 1.0).abs() < 1e-20);
        let seven = Friction::SevenParameter {
            mu_v: 0.0,
            v_s: 0.1,
            tau_d: 0.05,
            k_s: 4e4,
        };
        // memory: the Stribeck term follows the delayed velocity, not the current one
        assert!((seven.sliding(1.0, 5.0, 0.0) - 2.0).abs() < 1e-15);
        assert!((seven.sliding(1.0, 0.0, 5.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn capsule_force_includes_contact_only_past_the_gap() {
        let m = Model {
            capsule: Capsule::SECTION3,
            friction: Friction::Coulomb,
        };
        assert_eq!(m.contact_force(0.01), 0.0);
        assert!((m.contact_force(0.03) - 0.15).abs() < 1e-12);
        let f = m.capsule_force(0.03, 0.0, 0.0, true);
        assert!((f - (0.03 + 0.15)).abs() < 1e-12);
    }
}
