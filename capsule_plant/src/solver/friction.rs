//! The friction table: each law's sliding force and its slope, written once, resolved at compile
//! time for the Runge-Kutta right-hand side.
//!
//! The scene's [`Friction`](crate::model::Friction) is data; [`Friction::sliding`](crate::model::Friction::sliding)
//! (the published friction force) and the solvers both go through [`with_friction!`], which turns
//! it into one of these types, so the right-hand side is compiled once per type. An effect a scene leaves out
//! is then a constant `false` the compiler removes: no delay look-up without frictional memory,
//! no pre-sliding spring without `k_s`, no viscous term in Coulomb friction.

/// A sliding-friction law with its effects known at compile time.
pub(crate) trait SlidingLaw: Copy {
    /// The law reads the delayed velocity (frictional memory).
    const MEMORY: bool = false;
    /// The stuck capsule rests on a pre-sliding spring.
    const PRESLIDING: bool = false;
    /// Sliding friction for direction `dir`, velocity `y2`, delayed velocity `y2d`.
    fn sliding(&self, dir: f64, y2: f64, y2d: f64) -> f64;
    /// `d sliding / d y2` with the delayed velocity held fixed (`y2` has the sign of `dir`).
    fn slope(&self, dir: f64, y2: f64) -> f64;
    /// Pre-sliding stiffness (only read when `PRESLIDING`).
    fn k_s(&self) -> f64 {
        0.0
    }
}

#[derive(Clone, Copy)]
pub(crate) struct Coulomb;

impl SlidingLaw for Coulomb {
    #[inline(always)]
    fn sliding(&self, dir: f64, _: f64, _: f64) -> f64 {
        dir
    }
    fn slope(&self, _: f64, _: f64) -> f64 {
        0.0
    }
}

#[derive(Clone, Copy)]
pub(crate) struct Viscous {
    pub mu_v: f64,
}

impl SlidingLaw for Viscous {
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, _: f64) -> f64 {
        dir + self.mu_v * y2
    }
    fn slope(&self, _: f64, _: f64) -> f64 {
        self.mu_v
    }
}

#[derive(Clone, Copy)]
pub(crate) struct Stribeck {
    pub v_s: f64,
}

impl SlidingLaw for Stribeck {
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, _: f64) -> f64 {
        dir * (1.0 + (-y2.abs() / self.v_s).exp())
    }
    fn slope(&self, _: f64, y2: f64) -> f64 {
        // dir sign(y2) = 1 while slipping
        -(-y2.abs() / self.v_s).exp() / self.v_s
    }
}

/// The seven-parameter law; `MEM` and `PRE` say whether memory and pre-sliding are present.
#[derive(Clone, Copy)]
pub(crate) struct SevenParameter<const MEM: bool, const PRE: bool> {
    pub mu_v: f64,
    pub v_s: f64,
    pub k_s: f64,
}

impl<const MEM: bool, const PRE: bool> SlidingLaw for SevenParameter<MEM, PRE> {
    const MEMORY: bool = MEM;
    const PRESLIDING: bool = PRE;
    #[inline(always)]
    fn sliding(&self, dir: f64, y2: f64, y2d: f64) -> f64 {
        // without memory the Stribeck term follows the current velocity
        let r = if MEM { y2d } else { y2 } / self.v_s;
        dir + self.mu_v * y2 + dir / (1.0 + r * r)
    }
    fn slope(&self, dir: f64, y2: f64) -> f64 {
        if MEM {
            return self.mu_v;
        }
        let r = y2 / self.v_s;
        let q = 1.0 + r * r;
        self.mu_v - dir * 2.0 * r / (self.v_s * q * q)
    }
    fn k_s(&self) -> f64 {
        self.k_s
    }
}

/// Evaluate `$body` with `$f` bound to the compile-time form of the friction law `$friction`.
macro_rules! with_friction {
    ($friction:expr, $f:ident => $body:expr) => {{
        use $crate::model::Friction as F;
        use $crate::solver::friction as fr;
        #[allow(unused_imports)]
        use $crate::solver::friction::SlidingLaw as _;
        match $friction {
            F::Coulomb => {
                let $f = fr::Coulomb;
                $body
            }
            F::Viscous { mu_v } => {
                let $f = fr::Viscous { mu_v };
                $body
            }
            F::Stribeck { v_s } => {
                let $f = fr::Stribeck { v_s };
                $body
            }
            F::SevenParameter {
                mu_v,
                v_s,
                tau_d,
                k_s,
            } => match (tau_d > 0.0, k_s > 0.0) {
                (true, true) => {
                    let $f = fr::SevenParameter::<true, true> { mu_v, v_s, k_s };
                    $body
                }
                (true, false) => {
                    let $f = fr::SevenParameter::<true, false> { mu_v, v_s, k_s };
                    $body
                }
                (false, true) => {
                    let $f = fr::SevenParameter::<false, true> { mu_v, v_s, k_s };
                    $body
                }
                (false, false) => {
                    let $f = fr::SevenParameter::<false, false> { mu_v, v_s, k_s };
                    $body
                }
            },
        }
    }};
}

pub(crate) use with_friction;

#[cfg(test)]
mod tests {
    use crate::model::Friction;

    #[test]
    fn slopes_agree_with_central_differences() {
        let no_memory = Friction::SevenParameter {
            mu_v: 0.1,
            v_s: 0.2,
            tau_d: 0.0,
            k_s: 0.0,
        };
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
}
