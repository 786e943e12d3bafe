//! Pseudo-arclength continuation of periodic orbits in one scene parameter, with bifurcation
//! detection.
//!
//! A period-`k` orbit is a fixed point of `G(x, p) = P^k(x; p) - x`, `P` the Poincaré map of
//! [`crate::floquet`] on `x = [x1 - x2, y1, y2]` at drive phase 0. Newton shooting uses the exact
//! `d P^k / d x` (flow Jacobians and saltation matrices); `d P^k / d p` is a central difference.
//! Pseudo-arclength (Keller): predictor along the tangent of the branch in `(x, p)`, corrector on
//! `G = 0` plus the arclength condition, so folds are passed. Along the branch:
//!
//! - **period doubling**: `det(D + I)` changes sign (a real multiplier crosses -1);
//! - **fold**: the parameter component of the tangent changes sign (a multiplier crosses +1);
//! - **torus** (Neimark-Sacker): a complex pair crosses the unit circle;
//! - **grazing**: the number of contact events per orbit changes (a contact appears or vanishes
//!   at zero relative velocity);
//! - **sticking**: the number of stick entries or break-aways changes;
//! - **event sequence**: any other change of the event sequence (a reversal, a kink crossing).
//!
//! Each is located by bisection of the arclength step between the two points that bracket it.
//! Branch switching at a period doubling: [`switch_at_period_doubling`] (one level).

use crate::floquet::{map_only, modulus, poincare_map, StabilityError};
use crate::linear::{eigenvalues3, solve};
use crate::run::run;
use crate::sweep::Param;
use capsule_plant::scene::Scene;
use capsule_plant::EventKind;
use serde::Serialize;

/// Continuation settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuationConfig {
    /// The parameter.
    pub param: Param,
    /// Continue towards this value and stop past it.
    pub to: f64,
    /// First arclength step.
    pub step: f64,
    /// Largest arclength step.
    pub max_step: f64,
    /// Smallest arclength step before giving up.
    pub min_step: f64,
    /// Most branch points.
    pub max_points: usize,
    /// Newton tolerance on `|G|` (max norm).
    pub tol: f64,
}

impl ContinuationConfig {
    /// Defaults for continuing `param` to `to`.
    pub fn new(param: Param, to: f64) -> Self {
        ContinuationConfig {
            param,
            to,
            step: 0.01,
            max_step: 0.02,
            min_step: 1e-7,
            max_points: 5000,
            tol: 1e-10,
        }
    }
}

/// One point of the branch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct BranchPoint {
    /// Parameter value.
    pub value: f64,
    /// The orbit's section point `[x1 - x2, y1, y2]`.
    pub x: [f64; 3],
    /// Floquet multipliers `[re, im]`, largest modulus first.
    pub multipliers: Vec<[f64; 2]>,
    /// Largest multiplier modulus below 1.
    pub stable: bool,
    /// Contact onsets per orbit.
    pub impacts: usize,
    /// Stick entries per orbit.
    pub stick_entries: usize,
    /// The event sequence along the orbit, short names.
    pub events: String,
}

/// What was found between two branch points.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum SpecialKind {
    /// A real multiplier crosses -1.
    PeriodDoubling,
    /// A real multiplier crosses +1 (the branch turns back).
    Fold,
    /// A complex pair crosses the unit circle.
    Torus,
    /// A contact appears or vanishes (grazing).
    Grazing,
    /// Sticking starts or stops.
    Sticking,
    /// Another change of the event sequence.
    EventSequence,
}

/// A located special point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SpecialPoint {
    /// What.
    pub kind: SpecialKind,
    /// Parameter value.
    pub value: f64,
    /// Section point there.
    pub x: [f64; 3],
}

/// A continued branch.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Branch {
    /// The parameter's name.
    pub param: Param,
    /// Period of the orbit in drive periods.
    pub period: usize,
    /// The points in order of arclength.
    pub points: Vec<BranchPoint>,
    /// Special points in order of arclength.
    pub special: Vec<SpecialPoint>,
    /// Why the continuation stopped before reaching its end, if it did.
    pub stopped: Option<String>,
    /// The branch came back to its first point: a closed curve (an isola, as the period-3
    /// orbit of Fig 18 between its two folds), complete after one lap.
    pub closed: bool,
}

/// Why a continuation cannot start.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum ContinuationError {
    /// The stability analysis failed.
    #[error(transparent)]
    Stability(#[from] StabilityError),
    /// The start is not periodic.
    #[error("the start ({param} = {value}) is not periodic: no period <= 64 on the Poincaré section after the scene's horizon; choose a start on a periodic attractor")]
    NotPeriodic {
        /// The parameter name.
        param: &'static str,
        /// Its value.
        value: f64,
    },
    /// Newton did not converge at the start.
    #[error("Newton does not converge on the start orbit ({param} = {value}): {reason}")]
    NoStart {
        /// The parameter name.
        param: &'static str,
        /// Its value.
        value: f64,
        /// Why.
        reason: String,
    },
}

/// Pivots of Newton's and the tangent's bordered 4 x 4 systems at most this relative to the
/// matrix's largest entry count as singular (a branch point).
const SINGULAR: f64 = 1e-13;

/// The problem: a scene, a parameter, a period.
struct Problem<'a> {
    scene: &'a Scene,
    param: Param,
    k: usize,
}

/// `G`, `dG/dx` and `dG/dp` at `(x, p)`, and the linearization for the multipliers.
struct Eval {
    g: [f64; 3],
    gx: [[f64; 3]; 3],
    gp: [f64; 3],
    lin: crate::floquet::Linearization,
}

impl Problem<'_> {
    fn eval(&self, x: [f64; 3], p: f64) -> Result<Eval, StabilityError> {
        let s = self.param.apply(self.scene, p);
        let lin = poincare_map(&s, x, self.k)?;
        let mut g = [0.0; 3];
        let mut gx = lin.jacobian;
        for i in 0..3 {
            g[i] = lin.end[i] - x[i];
            gx[i][i] -= 1.0;
        }
        let h = 1e-7 * (1.0 + p.abs());
        let fp = map_only(&self.param.apply(self.scene, p + h), x, self.k)?;
        let fm = map_only(&self.param.apply(self.scene, p - h), x, self.k)?;
        let gp = [0, 1, 2].map(|i| (fp[i] - fm[i]) / (2.0 * h));
        Ok(Eval { g, gx, gp, lin })
    }

    /// Newton on `G = 0` and `t . (u - u0) = 0` from the predictor `u0`; the solution and its
    /// evaluation, or why not.
    #[allow(clippy::needless_range_loop)]
    fn correct(
        &self,
        u0: [f64; 4],
        t: [f64; 4],
        tol: f64,
    ) -> Result<([f64; 4], Eval, usize), String> {
        let mut u = u0;
        for it in 0..12 {
            let e = self
                .eval([u[0], u[1], u[2]], u[3])
                .map_err(|e| e.to_string())?;
            let res = e.g.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if res <= tol && it > 0 {
                return Ok((u, e, it));
            }
            let mut a = [[0.0; 4]; 4];
            let mut b = [0.0; 4];
            for i in 0..3 {
                a[i] = [e.gx[i][0], e.gx[i][1], e.gx[i][2], e.gp[i]];
                b[i] = -e.g[i];
            }
            a[3] = t;
            b[3] = -(0..4).map(|i| t[i] * (u[i] - u0[i])).sum::<f64>();
            let du = solve(a, b, SINGULAR).ok_or("singular Jacobian in Newton's step")?;
            for i in 0..4 {
                u[i] += du[i];
            }
            if !u.iter().all(|v| v.is_finite()) {
                return Err("Newton diverged".into());
            }
            if du.iter().fold(0.0f64, |m, v| m.max(v.abs())) < 1e-14 {
                let e = self
                    .eval([u[0], u[1], u[2]], u[3])
                    .map_err(|e| e.to_string())?;
                return Ok((u, e, it + 1));
            }
        }
        Err("Newton did not converge in 12 iterations".into())
    }

    /// The unit tangent at a solution, oriented like `prev`.
    fn tangent(&self, e: &Eval, prev: [f64; 4]) -> Option<[f64; 4]> {
        unit_tangent(&e.gx, &e.gp, prev)
    }
}

/// The unit null vector of `[gx | gp]` oriented like `prev` (bordered by `prev`); `None` where
/// the bordered matrix is singular (a branch point, or `prev` orthogonal to the branch).
#[allow(clippy::needless_range_loop)]
fn unit_tangent(gx: &[[f64; 3]; 3], gp: &[f64; 3], prev: [f64; 4]) -> Option<[f64; 4]> {
    let mut a = [[0.0; 4]; 4];
    for i in 0..3 {
        a[i] = [gx[i][0], gx[i][1], gx[i][2], gp[i]];
    }
    a[3] = prev;
    let t = solve(a, [0.0, 0.0, 0.0, 1.0], SINGULAR)?;
    let n = t.iter().map(|v| v * v).sum::<f64>().sqrt();
    Some(t.map(|v| v / n))
}

fn point(value: f64, x: [f64; 3], lin: &crate::floquet::Linearization) -> BranchPoint {
    let mut multipliers = eigenvalues3(&lin.jacobian).to_vec();
    multipliers.sort_by(|a, b| modulus(b).total_cmp(&modulus(a)));
    let count = |f: fn(&EventKind) -> bool| lin.events.iter().filter(|e| f(e)).count();
    let events: Vec<&str> = lin
        .events
        .iter()
        .map(|e| match e {
            EventKind::ContactOn => "C",
            EventKind::ContactOff => "c",
            EventKind::BreakAway { dir } if *dir > 0.0 => "B+",
            EventKind::BreakAway { .. } => "B-",
            EventKind::SlipEnd => "S",
            EventKind::Reversal { .. } => "R",
            EventKind::Kink => "K",
        })
        .collect();
    BranchPoint {
        value,
        x,
        stable: modulus(&multipliers[0]) < 1.0,
        multipliers,
        impacts: count(|e| matches!(e, EventKind::ContactOn)),
        stick_entries: count(|e| matches!(e, EventKind::SlipEnd)),
        events: events.join(" "),
    }
}

/// Test functions whose sign changes mark bifurcations: `det(D + I)`, the tangent's parameter
/// component, and `|mu|^2 - 1` of a complex pair (NaN if none).
fn tests(p: &BranchPoint, tangent_p: f64) -> [f64; 3] {
    let pd: f64 = p
        .multipliers
        .iter()
        .map(|m| (m[0] + 1.0).hypot(m[1]))
        .product::<f64>()
        * p.multipliers
            .iter()
            .filter(|m| m[1] == 0.0)
            .map(|m| (m[0] + 1.0).signum())
            .product::<f64>();
    let torus = p
        .multipliers
        .iter()
        .find(|m| m[1] != 0.0)
        .map_or(f64::NAN, |m| m[0] * m[0] + m[1] * m[1] - 1.0);
    [pd, tangent_p, torus]
}

/// What changed between two points, if anything.
fn changes(a: &BranchPoint, ta: [f64; 3], b: &BranchPoint, tb: [f64; 3]) -> Vec<SpecialKind> {
    let mut out = Vec::new();
    if ta[0] * tb[0] < 0.0 {
        out.push(SpecialKind::PeriodDoubling);
    }
    if ta[1] * tb[1] < 0.0 {
        out.push(SpecialKind::Fold);
    }
    if ta[2] * tb[2] < 0.0 {
        out.push(SpecialKind::Torus);
    }
    if a.impacts != b.impacts {
        out.push(SpecialKind::Grazing);
    } else if a.stick_entries != b.stick_entries {
        out.push(SpecialKind::Sticking);
    } else if a.events != b.events {
        out.push(SpecialKind::EventSequence);
    }
    out
}

/// Continue the periodic orbit the scene settles on (at its own parameter value) towards
/// `settings.to`. An error before the first point; after it, a branch with `stopped` saying
/// where and why it ended early.
pub fn continue_branch(
    scene: &Scene,
    settings: &ContinuationConfig,
) -> Result<Branch, ContinuationError> {
    continue_branch_observed(scene, settings, &mut |_| true)
}

/// [`continue_branch`], handing each new point to `on_point` (progress); when it answers
/// `false` (the user interrupted), the branch so far is returned with `stopped` saying so.
pub fn continue_branch_observed(
    scene: &Scene,
    settings: &ContinuationConfig,
    on_point: &mut dyn FnMut(&BranchPoint) -> bool,
) -> Result<Branch, ContinuationError> {
    let param = settings.param;
    let p0 = param.value(scene);
    let r = run(scene).map_err(StabilityError::from)?;
    let Some(k) = r.period else {
        return Err(ContinuationError::NotPeriodic {
            param: param.name(),
            value: p0,
        });
    };
    let f = r.final_state;
    continue_observed(scene, settings, k, [f.x1 - f.x2, f.y1, f.y2], p0, on_point)
}

/// Continue the period-`k` orbit through (approximately) `x` at parameter value `p0` towards
/// `settings.to`.
pub fn continue_from(
    scene: &Scene,
    settings: &ContinuationConfig,
    k: usize,
    x: [f64; 3],
    p0: f64,
) -> Result<Branch, ContinuationError> {
    continue_observed(scene, settings, k, x, p0, &mut |_| true)
}

/// [`continue_from`] with [`continue_branch_observed`]'s `on_point`.
fn continue_observed(
    scene: &Scene,
    settings: &ContinuationConfig,
    k: usize,
    x: [f64; 3],
    p0: f64,
    on_point: &mut dyn FnMut(&BranchPoint) -> bool,
) -> Result<Branch, ContinuationError> {
    let param = settings.param;
    let prob = Problem { scene, param, k };
    let dir = if settings.to >= p0 { 1.0 } else { -1.0 };
    let t_fix = [0.0, 0.0, 0.0, 1.0];
    let (u, e, _) = prob
        .correct([x[0], x[1], x[2], p0], t_fix, settings.tol)
        .map_err(|reason| ContinuationError::NoStart {
            param: param.name(),
            value: p0,
            reason,
        })?;
    let mut t =
        prob.tangent(&e, [0.0, 0.0, 0.0, dir])
            .ok_or_else(|| ContinuationError::NoStart {
                param: param.name(),
                value: p0,
                reason: "singular Jacobian at the start".into(),
            })?;
    let mut branch = Branch {
        param,
        period: k,
        points: vec![point(u[3], [u[0], u[1], u[2]], &e.lin)],
        special: Vec::new(),
        stopped: None,
        closed: false,
    };
    let (u0, t0) = (u, t);
    let mut left_start = false;
    let mut u = u;
    let mut test = tests(&branch.points[0], t[3]);
    let mut h = settings.step;
    while branch.points.len() < settings.max_points {
        let pred: [f64; 4] = [0, 1, 2, 3].map(|i| u[i] + h * t[i]);
        match prob.correct(pred, t, settings.tol) {
            Err(reason) => {
                h *= 0.5;
                if h < settings.min_step {
                    branch.stopped = Some(format!(
                        "{} = {}: {reason} (step below {:e})",
                        param.name(),
                        u[3],
                        settings.min_step
                    ));
                    break;
                }
            }
            Ok((un, en, iters)) => {
                let Some(tn) = prob.tangent(&en, t) else {
                    branch.stopped = Some(format!(
                        "{} = {}: singular Jacobian (tangent)",
                        param.name(),
                        un[3]
                    ));
                    break;
                };
                let pt = point(un[3], [un[0], un[1], un[2]], &en.lin);
                let tn_test = tests(&pt, tn[3]);
                let prev = branch.points.last().cloned();
                if let Some(prev) = prev {
                    for kind in changes(&prev, test, &pt, tn_test) {
                        let sp = locate(&prob, settings, kind, u, t, &prev, test, h);
                        branch.special.push(sp);
                    }
                }
                let go_on = on_point(&pt);
                branch.points.push(pt);
                if !go_on {
                    branch.stopped = Some(format!("{} = {}: interrupted", param.name(), un[3]));
                    break;
                }
                u = un;
                t = tn;
                test = tn_test;
                if iters <= 3 {
                    h = (h * 1.3).min(settings.max_step);
                }
                if (u[3] - settings.to) * dir >= 0.0 {
                    break;
                }
                // back at the start, heading the same way, after having left it: one lap done
                let from_start = (0..4).map(|i| (u[i] - u0[i]).powi(2)).sum::<f64>().sqrt();
                left_start |= from_start > 3.0 * settings.max_step;
                let same_way = (0..4).map(|i| t[i] * t0[i]).sum::<f64>() > 0.0;
                if left_start && same_way && from_start < settings.max_step {
                    branch.closed = true;
                    break;
                }
            }
        }
    }
    Ok(branch)
}

/// Branch switching at a period doubling `sp` of a period-`k` branch: the doubled orbit is sought
/// next to it, at parameter offsets of 1e-3 to 1e-2 (first towards `settings.to`, then away), by
/// Newton on `P^(2k)` from the period-`k` point displaced along the eigenvector of the multiplier
/// -1; the period-`2k` branch found is continued towards `settings.to`.
pub fn switch_at_period_doubling(
    scene: &Scene,
    settings: &ContinuationConfig,
    k: usize,
    sp: &SpecialPoint,
) -> Result<Branch, ContinuationError> {
    let param = settings.param;
    let lin = poincare_map(&param.apply(scene, sp.value), sp.x, k)?;
    // null vector of D + I: the cross product of its two most independent rows
    let mut a = lin.jacobian;
    for (i, row) in a.iter_mut().enumerate() {
        row[i] += 1.0;
    }
    let cross = |u: [f64; 3], w: [f64; 3]| {
        [
            u[1] * w[2] - u[2] * w[1],
            u[2] * w[0] - u[0] * w[2],
            u[0] * w[1] - u[1] * w[0],
        ]
    };
    let norm = |v: &[f64; 3]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let v = [(0, 1), (0, 2), (1, 2)]
        .map(|(i, j)| cross(a[i], a[j]))
        .into_iter()
        .max_by(|u, w| norm(u).total_cmp(&norm(w)))
        .unwrap_or([1.0, 0.0, 0.0]);
    let nv = norm(&v).max(f64::MIN_POSITIVE);
    let v = v.map(|x| x / nv);
    let prob = Problem {
        scene,
        param,
        k: 2 * k,
    };
    let towards = if settings.to >= sp.value { 1.0 } else { -1.0 };
    for side in [towards, -towards] {
        for dp in [1e-3, 3e-3, 1e-2] {
            let p0 = sp.value + side * dp;
            for amp in [1e-3, 3e-3, 1e-2, 3e-2, 1e-1] {
                for sign in [1.0, -1.0] {
                    let x0 = [0, 1, 2].map(|i| sp.x[i] + sign * amp * v[i]);
                    let Ok((u, _, _)) = prob.correct(
                        [x0[0], x0[1], x0[2], p0],
                        [0.0, 0.0, 0.0, 1.0],
                        settings.tol,
                    ) else {
                        continue;
                    };
                    let x = [u[0], u[1], u[2]];
                    // a genuine period-2k orbit: one period does not close it
                    let once =
                        map_only(&param.apply(scene, u[3]), x, k).map_err(StabilityError::from)?;
                    if (0..3).any(|i| (once[i] - x[i]).abs() > 1e-6) {
                        return continue_from(scene, settings, 2 * k, x, u[3]);
                    }
                }
            }
        }
    }
    Err(ContinuationError::NoStart {
        param: param.name(),
        value: sp.value,
        reason: format!(
            "no period-{} orbit found next to the period doubling",
            2 * k
        ),
    })
}

/// Bisect the arclength step from `(u, t)` until the change `kind` is bracketed within `1e-9`
/// of arclength; the special point at the end of the bracket.
#[allow(clippy::too_many_arguments)]
fn locate(
    prob: &Problem<'_>,
    settings: &ContinuationConfig,
    kind: SpecialKind,
    u: [f64; 4],
    t: [f64; 4],
    prev: &BranchPoint,
    prev_test: [f64; 3],
    h: f64,
) -> SpecialPoint {
    let (mut lo, mut hi) = (0.0, h);
    let mut best = None;
    for _ in 0..40 {
        if hi - lo < 1e-9 {
            break;
        }
        let mid = 0.5 * (lo + hi);
        let pred: [f64; 4] = [0, 1, 2, 3].map(|i| u[i] + mid * t[i]);
        let Ok((um, em, _)) = prob.correct(pred, t, settings.tol) else {
            break;
        };
        let tm = prob.tangent(&em, t).map_or(f64::NAN, |v| v[3]);
        let pm = point(um[3], [um[0], um[1], um[2]], &em.lin);
        let changed = changes(prev, prev_test, &pm, tests(&pm, tm)).contains(&kind);
        if changed {
            hi = mid;
            best = Some(um);
        } else {
            lo = mid;
        }
    }
    let um = best.unwrap_or_else(|| [0, 1, 2, 3].map(|i| u[i] + hi * t[i]));
    SpecialPoint {
        kind,
        value: um[3],
        x: [um[0], um[1], um[2]],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tangent_is_the_null_vector_and_none_at_a_branch_point() {
        // G = (x0 - p, x1, x2): the branch is x0 = p, its tangent (1, 0, 0, 1) / sqrt 2
        let gx = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let gp = [-1.0, 0.0, 0.0];
        let t = unit_tangent(&gx, &gp, [0.0, 0.0, 0.0, 1.0]).unwrap_or_else(|| panic!("singular?"));
        let h = std::f64::consts::FRAC_1_SQRT_2;
        for (got, want) in t.iter().zip([h, 0.0, 0.0, h]) {
            assert!((got - want).abs() < 1e-15, "{t:?}");
        }
        // a rank-2 [gx | gp] (a branch point: two rows alike): no tangent, and the
        // continuation stops there with "singular Jacobian (tangent)" and the branch so far
        let gx = [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]];
        let gp = [-1.0, -1.0, 0.0];
        assert_eq!(unit_tangent(&gx, &gp, [0.0, 0.0, 0.0, 1.0]), None);
    }

    #[test]
    fn a_step_that_never_converges_stops_with_where_and_keeps_the_branch_so_far() {
        // Coulomb, section-3 set at alpha 1.6 (period 1), continued in gamma (5) downwards in
        // steps of 10 and 5: the predictor lands at a mass ratio of about -5 and 0, where there
        // is no orbit to correct to, and the smallest step allowed (3) is passed at once
        let mut scene = Scene::default();
        scene.drive.alpha = 1.6;
        let settings = ContinuationConfig {
            step: 10.0,
            max_step: 10.0,
            min_step: 3.0,
            ..ContinuationConfig::new(Param::Gamma, -100.0)
        };
        let branch = continue_branch(&scene, &settings).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(branch.points.len(), 1, "{:?}", branch.stopped);
        let why = branch.stopped.unwrap_or_default();
        assert!(why.starts_with("gamma = 5"), "{why}");
        assert!(why.contains("step below 3e0"), "{why}");
    }

    #[test]
    fn the_period_3_isola_of_fig_18_passes_both_folds_and_closes_after_one_lap() {
        // Coulomb, section-3 set, alpha 1.5, k_p 0, from (-1.5, 0, 0, 0): the period-3 orbit
        // that coexists with period 1 (scenes/switch_alpha15.toml). Fig 18: period 3 emerges at
        // alpha 0.682 and disappears at 1.654 (the paper, read off a brute-force diagram)
        let mut scene = Scene::default();
        scene.drive.alpha = 1.5;
        scene.initial = capsule_plant::State::from_array([-1.5, 0.0, 0.0, 0.0]);
        let branch = continue_branch(&scene, &ContinuationConfig::new(Param::Alpha, 1.75))
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(branch.period, 3);
        assert_eq!(branch.stopped, None);
        assert!(branch.closed, "{} points", branch.points.len());
        assert!(branch.points.len() < 400, "{} points", branch.points.len());
        let folds: Vec<f64> = branch
            .special
            .iter()
            .filter(|s| s.kind == SpecialKind::Fold)
            .map(|s| s.value)
            .collect();
        assert_eq!(folds.len(), 2, "{folds:?}");
        assert!((folds[0] - 1.654).abs() < 0.01, "{folds:?}");
        assert!((folds[1] - 0.682).abs() < 0.01, "{folds:?}");
        // through the upper fold: the stable side turns back unstable (a multiplier passes +1)
        let top = (0..branch.points.len())
            .max_by(|&a, &b| branch.points[a].value.total_cmp(&branch.points[b].value))
            .unwrap_or(0);
        let (before, after) = (&branch.points[top - 3], &branch.points[top + 3]);
        assert!(before.stable && !after.stable, "{before:?} {after:?}");
        let peak = branch.points[top].value;
        assert!(before.value < peak && after.value < peak, "{peak}");
    }
}
