//! The friction between capsule and ground: one trait, [`FrictionLaw`], that every law
//! implements once (threshold, sliding force and its slope, and the effects it has: pre-sliding,
//! frictional memory, a linear form), and the scene file's tag, [`Friction`], whose variants
//! each hold one law. Everything that needs friction reads it from here: the equations (events,
//! transitions, Jacobian), the exact solver's linear form, the Runge-Kutta right-hand side, the
//! published friction force, the scene reader and the command line.
//!
//! Adding a law: a type with its `impl FrictionLaw`, a variant of [`Friction`] holding it, its
//! arm in `with_law!`, and its entry in [`Friction::LAWS`]. The scene file's keys, the
//! `--friction` choices and the error messages follow from them (docs/architecture.md).
//!
//! The laws (Table 1 of the paper, garbled in the seed text; reconstructed from ref. \[14\],
//! Liu, Pavlovskaia, Wiercigroch 2013, and the seven-parameter model of ref. \[27\], Wojewoda et
//! al. 2008), plus one from the friction-compensation literature. `s = sign(y2)`, `v_s` the
//! Stribeck velocity, `y2d = y2(tau - tau_d)`:
//!
//! | law | sliding friction `f_s` | threshold `f_b` | in stick |
//! |---|---|---|---|
//! | Coulomb | `s` | 1 | `y2 = 0` |
//! | Coulomb + viscous | `s + mu_v y2` | 1 | `y2 = 0` |
//! | Coulomb + Stribeck | `s (1 + exp(-abs(y2) / v_s))` | 2 | `y2 = 0` |
//! | seven-parameter | `s + mu_v y2 + s / (1 + (y2d / v_s)^2)` | 2 | pre-sliding spring `k_s p` |
//! | Gaussian Stribeck + viscous | `s (1 + exp(-(y2 / v_s)^2)) + mu_v y2` | 2 | `y2 = 0` |
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

/// A friction law: what the equations and the solvers need of it, and how scene files and the
/// command line name it. What a law lacks is said here, by a default: no pre-sliding, no
/// memory, no linear form.
pub trait FrictionLaw: Copy {
    /// Short name in scene files and on the command line.
    const NAME: &'static str;
    /// The law as figures title it.
    const TITLE: &'static str;
    /// The law reads the delayed velocity (frictional memory); the Runge-Kutta right-hand side
    /// is compiled without the delay look-up when false.
    const MEMORY: bool = false;
    /// The stuck capsule rests on a pre-sliding spring; compiled out when false.
    const PRESLIDING: bool = false;
    /// Break-away threshold `f_b`.
    fn threshold(&self) -> f64;
    /// Sliding friction for direction `dir` (+1/-1), velocity `y2`, delayed velocity `y2d`.
    fn sliding(&self, dir: f64, y2: f64, y2d: f64) -> f64;
    /// `d sliding / d y2` with the delayed velocity held fixed (`y2` has the sign of `dir`).
    fn slope(&self, dir: f64, y2: f64) -> f64;
    /// Pre-sliding stiffness `k_s`, if the stuck capsule rests on a spring.
    fn presliding(&self) -> Option<f64> {
        None
    }
    /// Frictional-memory delay `tau_d`, if the law reads a delayed velocity.
    fn memory(&self) -> Option<f64> {
        None
    }
    /// The law as `f_s = dir coulomb + viscous y2` if it is linear in the state between events
    /// (then the exact solver applies).
    fn linear(&self) -> Option<LinearSliding> {
        None
    }
    /// Its constants, each with its slot, in [`FRICTION_CONSTANTS`] order.
    fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        Vec::new()
    }
}

/// A sliding law linear in the velocity: `f_s = dir coulomb + viscous y2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinearSliding {
    /// The dry part, times the direction.
    pub coulomb: f64,
    /// The viscous coefficient.
    pub viscous: f64,
}

/// Dry Coulomb friction: `f_s = sign(y2)`, `f_b = 1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Coulomb;

impl FrictionLaw for Coulomb {
    const NAME: &'static str = "coulomb";
    const TITLE: &'static str = "Coulomb";
    fn threshold(&self) -> f64 {
        1.0
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, _: f64, _: f64) -> f64 {
        dir
    }
    fn slope(&self, _: f64, _: f64) -> f64 {
        0.0
    }
    fn linear(&self) -> Option<LinearSliding> {
        Some(LinearSliding {
            coulomb: 1.0,
            viscous: 0.0,
        })
    }
}

/// Coulomb plus viscous damping: `f_s = sign(y2) + mu_v y2`, `f_b = 1`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Viscous {
    /// Viscous coefficient `mu_v`.
    pub mu_v: f64,
}

impl FrictionLaw for Viscous {
    const NAME: &'static str = "viscous";
    const TITLE: &'static str = "Coulomb viscous";
    fn threshold(&self) -> f64 {
        1.0
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, _: f64) -> f64 {
        dir + self.mu_v * y2
    }
    fn slope(&self, _: f64, _: f64) -> f64 {
        self.mu_v
    }
    fn linear(&self) -> Option<LinearSliding> {
        Some(LinearSliding {
            coulomb: 1.0,
            viscous: self.mu_v,
        })
    }
    fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        vec![(&MU_V, &mut self.mu_v)]
    }
}

/// Coulomb plus Stribeck: `f_s = sign(y2) (1 + exp(-|y2| / v_s))`, `f_b = 2`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Stribeck {
    /// Stribeck velocity `v_s`.
    pub v_s: f64,
}

impl FrictionLaw for Stribeck {
    const NAME: &'static str = "stribeck";
    const TITLE: &'static str = "Coulomb Stribeck";
    fn threshold(&self) -> f64 {
        2.0
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, _: f64) -> f64 {
        dir * (1.0 + (-y2.abs() / self.v_s).exp())
    }
    fn slope(&self, _: f64, y2: f64) -> f64 {
        // dir sign(y2) = 1 while slipping
        -(-y2.abs() / self.v_s).exp() / self.v_s
    }
    fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        vec![(&V_S, &mut self.v_s)]
    }
}

/// The seven-parameter law: Stribeck with frictional memory and pre-sliding, `f_b = 2`. A zero
/// `tau_d` or `k_s` switches that effect off (the solvers then compile it out:
/// `SevenParameterWith`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SevenParameter {
    /// Viscous coefficient `mu_v`.
    pub mu_v: f64,
    /// Stribeck velocity `v_s`.
    pub v_s: f64,
    /// Frictional-memory delay `tau_d` of the velocity in the Stribeck term.
    pub tau_d: f64,
    /// Pre-sliding stiffness `k_s` while stuck.
    pub k_s: f64,
}

impl SevenParameter {
    /// The law with its effects fixed at compile time: `MEM` memory, `PRE` pre-sliding.
    pub(crate) fn with<const MEM: bool, const PRE: bool>(self) -> SevenParameterWith<MEM, PRE> {
        SevenParameterWith { law: self }
    }
}

impl FrictionLaw for SevenParameter {
    const NAME: &'static str = "seven-parameter";
    const TITLE: &'static str = "seven-parameter";
    const MEMORY: bool = true;
    const PRESLIDING: bool = true;
    fn threshold(&self) -> f64 {
        2.0
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, y2d: f64) -> f64 {
        // without memory the Stribeck term follows the current velocity
        let r = if self.tau_d > 0.0 { y2d } else { y2 } / self.v_s;
        dir + self.mu_v * y2 + dir / (1.0 + r * r)
    }
    fn slope(&self, dir: f64, y2: f64) -> f64 {
        if self.tau_d > 0.0 {
            return self.mu_v;
        }
        let r = y2 / self.v_s;
        let q = 1.0 + r * r;
        self.mu_v - dir * 2.0 * r / (self.v_s * q * q)
    }
    fn presliding(&self) -> Option<f64> {
        (self.k_s > 0.0).then_some(self.k_s)
    }
    fn memory(&self) -> Option<f64> {
        (self.tau_d > 0.0).then_some(self.tau_d)
    }
    fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        vec![
            (&MU_V, &mut self.mu_v),
            (&V_S, &mut self.v_s),
            (&TAU_D, &mut self.tau_d),
            (&K_S, &mut self.k_s),
        ]
    }
}

/// [`SevenParameter`] with memory (`MEM`) and pre-sliding (`PRE`) known at compile time, for
/// the Runge-Kutta right-hand side; the formulas are the law's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SevenParameterWith<const MEM: bool, const PRE: bool> {
    law: SevenParameter,
}

impl<const MEM: bool, const PRE: bool> FrictionLaw for SevenParameterWith<MEM, PRE> {
    const NAME: &'static str = SevenParameter::NAME;
    const TITLE: &'static str = SevenParameter::TITLE;
    const MEMORY: bool = MEM;
    const PRESLIDING: bool = PRE;
    fn threshold(&self) -> f64 {
        self.law.threshold()
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, y2d: f64) -> f64 {
        let r = if MEM { y2d } else { y2 } / self.law.v_s;
        dir + self.law.mu_v * y2 + dir / (1.0 + r * r)
    }
    fn slope(&self, dir: f64, y2: f64) -> f64 {
        self.law.slope(dir, y2)
    }
    #[inline(always)]
    fn presliding(&self) -> Option<f64> {
        // known at compile time: the right-hand side reads it every evaluation
        PRE.then_some(self.law.k_s)
    }
    fn memory(&self) -> Option<f64> {
        MEM.then_some(self.law.tau_d)
    }
}

/// Coulomb plus a Gaussian Stribeck curve plus viscous damping:
/// `f_s = sign(y2) (1 + exp(-(y2 / v_s)^2)) + mu_v y2`, `f_b = 2`: the Stribeck-friction model
/// `F_C + (F_S - F_C) exp(-(v / v_s)^2) + F_v v` with the Gaussian exponent 2 discussed by
/// Armstrong-Helouvry, Dupont and Canudas de Wit, "A survey of models, analysis tools and
/// compensation methods for the control of machines with friction", Automatica 30(7), 1994,
/// 1083-1138, with the static level twice the kinetic one as in the paper's Stribeck law. Unlike
/// that law's exponent 1, the Gaussian curve is flat at zero velocity: it falls off only once
/// the capsule slides at about `v_s`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GaussianStribeck {
    /// Viscous coefficient `mu_v`.
    pub mu_v: f64,
    /// Stribeck velocity `v_s`.
    pub v_s: f64,
}

impl FrictionLaw for GaussianStribeck {
    const NAME: &'static str = "gaussian-stribeck";
    const TITLE: &'static str = "Gaussian Stribeck viscous";
    fn threshold(&self) -> f64 {
        2.0
    }
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, _: f64) -> f64 {
        let r = y2 / self.v_s;
        dir * (1.0 + (-r * r).exp()) + self.mu_v * y2
    }
    fn slope(&self, dir: f64, y2: f64) -> f64 {
        let r = y2 / self.v_s;
        self.mu_v - dir * 2.0 * r * (-r * r).exp() / self.v_s
    }
    fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        vec![(&MU_V, &mut self.mu_v), (&V_S, &mut self.v_s)]
    }
}

/// The friction law of a scene, with its constants: the scene file's `[friction] law = "..."`
/// tag. Each variant holds one [`FrictionLaw`]; everything else is asked of the law.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "law", rename_all = "kebab-case")]
pub enum Friction {
    /// [`Coulomb`].
    Coulomb(Coulomb),
    /// [`Viscous`].
    Viscous(Viscous),
    /// [`Stribeck`].
    Stribeck(Stribeck),
    /// [`SevenParameter`].
    SevenParameter(SevenParameter),
    /// [`GaussianStribeck`].
    GaussianStribeck(GaussianStribeck),
}

/// `$body` with `$f` bound to the law a [`Friction`] holds (by reference, as `$friction` is).
macro_rules! with_law {
    ($friction:expr, $f:ident => $body:expr) => {{
        use $crate::friction::Friction as F;
        #[allow(unused_imports)]
        use $crate::friction::FrictionLaw as _;
        match $friction {
            F::Coulomb($f) => $body,
            F::Viscous($f) => $body,
            F::Stribeck($f) => $body,
            F::SevenParameter($f) => $body,
            F::GaussianStribeck($f) => $body,
        }
    }};
}
pub(crate) use with_law;

/// `$body` with `$f` the law a [`Friction`] holds, by value, with the seven-parameter law's
/// effects fixed at compile time: the Runge-Kutta right-hand side is compiled once per type,
/// and an effect a scene leaves out (no delay look-up without memory, no pre-sliding spring
/// without `k_s`) is a constant `false` the compiler removes.
macro_rules! with_friction {
    ($friction:expr, $f:ident => $body:expr) => {{
        use $crate::friction::Friction as F;
        match $friction {
            F::SevenParameter(law) => match (law.tau_d > 0.0, law.k_s > 0.0) {
                (true, true) => {
                    let $f = law.with::<true, true>();
                    $body
                }
                (true, false) => {
                    let $f = law.with::<true, false>();
                    $body
                }
                (false, true) => {
                    let $f = law.with::<false, true>();
                    $body
                }
                (false, false) => {
                    let $f = law.with::<false, false>();
                    $body
                }
            },
            other => $crate::friction::with_law!(other, law => {
                let $f = law;
                $body
            }),
        }
    }};
}
pub(crate) use with_friction;

impl Friction {
    /// Coulomb friction.
    pub const COULOMB: Friction = Friction::Coulomb(Coulomb);

    /// Break-away threshold `f_b` of the law.
    pub fn threshold(&self) -> f64 {
        with_law!(self, f => f.threshold())
    }

    /// Sliding friction force for a capsule slipping in direction `dir` (+1/-1) at velocity
    /// `y2`, with `y2_delayed = y2(tau - tau_d)` (read only by a law with frictional memory).
    pub fn sliding(&self, dir: f64, y2: f64, y2_delayed: f64) -> f64 {
        with_law!(self, f => f.sliding(dir, y2, y2_delayed))
    }

    /// `d f_s / d y2` of the sliding force at velocity `y2` in direction `dir`, the delayed
    /// velocity held fixed (what the Jacobian of the right-hand side needs).
    pub fn sliding_slope(&self, dir: f64, y2: f64) -> f64 {
        with_law!(self, f => f.slope(dir, y2))
    }

    /// The law's linear form, if it is linear in the state between events (exact solution).
    pub fn linear(&self) -> Option<LinearSliding> {
        with_law!(self, f => f.linear())
    }

    /// Whether the law is linear in the state between events (exact piecewise solution exists).
    pub fn is_piecewise_linear(&self) -> bool {
        self.linear().is_some()
    }

    /// Frictional-memory delay, if the law has one.
    pub fn memory_delay(&self) -> Option<f64> {
        with_law!(self, f => f.memory())
    }

    /// Pre-sliding stiffness, if the law has one.
    pub fn presliding(&self) -> Option<f64> {
        with_law!(self, f => f.presliding())
    }

    /// The law's short name (scene files, command line) and its title in figures.
    fn labels(&self) -> (&'static str, &'static str) {
        fn of<L: FrictionLaw>(_: &L) -> (&'static str, &'static str) {
            (L::NAME, L::TITLE)
        }
        with_law!(self, f => of(f))
    }

    /// Short name as used in scene files and on the command line.
    pub fn name(&self) -> &'static str {
        self.labels().0
    }

    /// The law as figures title it.
    pub fn title(&self) -> &'static str {
        self.labels().1
    }

    /// Every law with the default constants (the paper's): the one list from which scene files,
    /// the command line and error messages take the laws and their names.
    pub const LAWS: [Friction; 5] = Friction::laws_with(MU_V.paper, TAU_D.paper, K_S.paper);

    /// The paper's four laws (its Table 1), as its figures show them.
    pub const PAPER_LAWS: [Friction; 4] = [
        Friction::LAWS[0],
        Friction::LAWS[1],
        Friction::LAWS[2],
        Friction::LAWS[3],
    ];

    /// Every law with these constants (`v_s` the paper's); the unit tests probe other values.
    pub(crate) const fn laws_with(mu_v: f64, tau_d: f64, k_s: f64) -> [Friction; 5] {
        let v_s = V_S.paper;
        [
            Friction::Coulomb(Coulomb),
            Friction::Viscous(Viscous { mu_v }),
            Friction::Stribeck(Stribeck { v_s }),
            Friction::SevenParameter(SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            }),
            Friction::GaussianStribeck(GaussianStribeck { mu_v, v_s }),
        ]
    }

    /// The law called `name` (see [`Friction::name`]) with the default constants.
    pub fn by_name(name: &str) -> Option<Friction> {
        Friction::LAWS.into_iter().find(|l| l.name() == name)
    }

    /// The names of all laws, `a, b, c or d`, for messages.
    pub fn names() -> String {
        crate::choices::one_of(Friction::LAWS.map(|l| l.name()))
    }

    /// The law's constants, each with its slot, in [`FRICTION_CONSTANTS`] order: what scene files
    /// and flags may set for this law (anything else does not apply to it).
    pub fn constants_mut(&mut self) -> Vec<(&'static FrictionConstant, &mut f64)> {
        with_law!(self, f => f.constants_mut())
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
/// Every friction constant, in the order laws list theirs.
pub const FRICTION_CONSTANTS: [FrictionConstant; 4] = [MU_V, V_S, TAU_D, K_S];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slopes_agree_with_central_differences() {
        let no_memory = Friction::SevenParameter(SevenParameter {
            mu_v: 0.1,
            v_s: 0.2,
            tau_d: 0.0,
            k_s: 0.0,
        });
        let laws = Friction::laws_with(0.3, 0.05, 4e4)
            .into_iter()
            .chain([no_memory]);
        for law in laws {
            for (dir, y2, y2d) in [(1.0, 0.3, 0.1), (-1.0, -0.7, -0.2), (1.0, 0.02, 0.0)] {
                let h = 1e-7;
                let fd =
                    (law.sliding(dir, y2 + h, y2d) - law.sliding(dir, y2 - h, y2d)) / (2.0 * h);
                let got = law.sliding_slope(dir, y2);
                assert!((got - fd).abs() < 1e-6, "{law:?} at {y2}: {got} vs {fd}");
            }
        }
    }

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
        let law = Friction::Stribeck(Stribeck { v_s: 0.1 });
        assert!((law.sliding(1.0, 5.0, 0.0) - 1.0).abs() < 1e-20);
        let seven = Friction::SevenParameter(SevenParameter {
            mu_v: 0.0,
            v_s: 0.1,
            tau_d: 0.05,
            k_s: 4e4,
        });
        // memory: the Stribeck term follows the delayed velocity, not the current one
        assert!((seven.sliding(1.0, 5.0, 0.0) - 2.0).abs() < 1e-15);
        assert!((seven.sliding(1.0, 0.0, 5.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn the_gaussian_curve_is_flat_at_rest_and_falls_past_v_s() {
        let g = GaussianStribeck {
            mu_v: 0.0,
            v_s: 0.1,
        };
        let s = Stribeck { v_s: 0.1 };
        // at a tenth of v_s the Gaussian curve has lost 1 %, the exponential one 10 %
        assert!((g.sliding(1.0, 0.01, 0.0) - (1.0 + (-0.01f64).exp())).abs() < 1e-15);
        assert!(g.sliding(1.0, 0.01, 0.0) > s.sliding(1.0, 0.01, 0.0));
        // at 3 v_s it is Coulomb to 1e-4, the exponential one to 5e-2
        assert!((g.sliding(1.0, 0.3, 0.0) - 1.0).abs() < 2e-4);
        assert_eq!(g.slope(1.0, 0.0), 0.0);
        assert_eq!(
            Friction::by_name("gaussian-stribeck").map(|l| l.threshold()),
            Some(2.0)
        );
        assert!(!Friction::GaussianStribeck(g).is_piecewise_linear());
    }

    #[test]
    fn every_law_has_its_own_name_and_the_compiled_forms_agree_with_the_law() {
        let names: std::collections::BTreeSet<&str> =
            Friction::LAWS.iter().map(|l| l.name()).collect();
        assert_eq!(names.len(), Friction::LAWS.len());
        for law in
            Friction::laws_with(0.3, 0.05, 4e4)
                .into_iter()
                .chain([Friction::SevenParameter(SevenParameter {
                    mu_v: 0.1,
                    v_s: 0.2,
                    tau_d: 0.0,
                    k_s: 0.0,
                })])
        {
            for (dir, y2, y2d) in [(1.0, 0.3, 0.1), (-1.0, -0.7, -0.2)] {
                let compiled = with_friction!(law, f => f.sliding(dir, y2, y2d));
                assert_eq!(compiled, law.sliding(dir, y2, y2d), "{law:?}");
            }
        }
    }
}
