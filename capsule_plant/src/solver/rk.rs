//! Runge-Kutta methods: adaptive Dormand-Prince 5(4) with located events, and fixed-step RK4.
//!
//! Both integrate `v = [z, y1, y2, p, dx2, w]`: the relative state, the capsule's displacement
//! over the step and the actuator work over the step (increments, added to compensated sums).
//! Dormand-Prince coefficients and the continuous extension are those of Hairer, Norsett and
//! Wanner, *Solving ODEs I*, sec. II.5-6 (the `dopri5` code).

use super::history::Piece;
use super::{EventKind, Phase, SimError, Simulator, Stop, Transition, MAX_STEPS_PER_TIME};
use crate::equations::{field, EventFn};
use crate::friction::FrictionLaw;
use crate::law::{ActuatorLaw, LawShape};
use crate::model::State;
use crate::roots::{first_crossing, BOUNDARY};
use std::ops::ControlFlow;

type V = [f64; 6];

/// Nodes `c` of stages 2 to 6 (stage 7, the FSAL stage, is at `t + h`).
const C: [f64; 5] = [1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0];
/// Rows of `a` for stages 2 to 7 (the last row is the fifth-order solution, `b`; `b_2 = 0`).
const A: [&[f64]; 6] = [
    &[1.0 / 5.0],
    &[3.0 / 40.0, 9.0 / 40.0],
    &[44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0],
    &[
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
    ],
    &[
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
    ],
    &[
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
/// Error weights `b - b*` of the seven stages.
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];
/// Weights of the continuous extension's last coefficient.
const D: [f64; 7] = [
    -12715105075.0 / 11282082432.0,
    0.0,
    87487479700.0 / 32700410799.0,
    -10690763975.0 / 1880347072.0,
    701980252875.0 / 199316789632.0,
    -1453857185.0 / 822651844.0,
    69997945.0 / 29380423.0,
];

/// `y + h * sum a k` over `terms` (the fixed-step RK4's stages).
#[inline(always)]
fn axpy(y: &V, h: f64, terms: &[(f64, &V)]) -> V {
    let mut out = *y;
    for (i, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for (a, k) in terms {
            acc += a * k[i];
        }
        *o += h * acc;
    }
    out
}

/// `y + h * sum_j w_j k_j` over the stages with a non-zero weight (the zeros of the tableau
/// skipped, so the sums are those of the published `dopri5` code).
#[inline(always)]
fn combine(y: &V, h: f64, w: &[f64], k: &[V; 7]) -> V {
    let mut out = *y;
    for (i, o) in out.iter_mut().enumerate() {
        let mut acc = 0.0;
        for (a, kj) in w.iter().zip(k) {
            if *a != 0.0 {
                acc += a * kj[i];
            }
        }
        *o += h * acc;
    }
    out
}

/// One Dormand-Prince step: the new state, its derivative (FSAL), the error estimate and the
/// continuous extension coefficients.
struct DopriStep {
    y: V,
    k7: V,
    err: V,
    cont: [V; 5],
}

/// What the right-hand side needs besides the state.
struct Rhs<'a, L, F> {
    law: &'a L,
    friction: F,
    shape: LawShape,
    /// Use the regime's contact flag and kink side (event-located), or the state's (fixed step).
    located: bool,
    x2_base: f64,
}

/// One Runge-Kutta leg to `tau_end`: what its right-hand side is made of, whether the feedback's
/// kink is an event, and the event functions' buffer.
struct Leg<'a, L, F> {
    law: &'a L,
    friction: F,
    shape: LawShape,
    located: bool,
    kink: bool,
    events: Vec<EventFn>,
    tau_end: f64,
}

impl<'a, L, F: Copy> Leg<'a, L, F> {
    /// The right-hand side for a step from a capsule at `x2_base`.
    fn rhs(&self, x2_base: f64) -> Rhs<'a, L, F> {
        Rhs {
            law: self.law,
            friction: self.friction,
            shape: self.shape,
            located: self.located,
            x2_base,
        }
    }
}

/// Continuous extension at `theta` in `[0, 1]` and its derivative with respect to `theta`.
#[inline]
fn dense(c: &[V; 5], i: usize, th: f64) -> (f64, f64) {
    let [r1, r2, r3, r4, r5] = [c[0][i], c[1][i], c[2][i], c[3][i], c[4][i]];
    let th1 = 1.0 - th;
    let a = r4 + th1 * r5;
    let da = -r5;
    let b = r3 + th * a;
    let db = a + th * da;
    let cc = th1 * b;
    let dc = -b + th1 * db;
    let d = r2 + cc;
    (r1 + th * d, d + th * dc)
}

/// The first event in a step, on its dense output: where (a fraction of the step) and which.
fn first_event(events: &[EventFn], step: &DopriStep) -> Option<(f64, EventFn)> {
    let mut hit: Option<(f64, EventFn)> = None;
    for ev in events {
        let gd = |th: f64| {
            let mut v = [0.0; 4];
            let mut d = [0.0; 4];
            for i in 0..4 {
                (v[i], d[i]) = dense(&step.cont, i, th);
            }
            (ev.eval(&v), ev.eval(&d) - ev.c0)
        };
        let limit = hit.map_or(1.0, |(t, _)| t);
        if let Some(th) = first_crossing(|th| gd(th).0, gd, |ts| ts.map(gd), limit) {
            if hit.is_none_or(|(t, _)| th < t) {
                hit = Some((th, *ev));
            }
        }
    }
    hit
}

impl Simulator {
    fn rk_rhs<L: ActuatorLaw, F: FrictionLaw>(&self, ctx: &Rhs<'_, L, F>, tau: f64, v: &V) -> V {
        let [z, y1, y2, p, dx2, _] = *v;
        let model = &self.model;
        let (contact, sigma) = if ctx.located {
            (self.regime.contact, self.regime.sigma)
        } else {
            (
                model.has_contact() && z >= model.capsule.delta,
                if z < 0.0 { -1.0 } else { 1.0 },
            )
        };
        let fa = match ctx.shape {
            LawShape::PiecewiseAffine(drive) => drive.force_on_side(tau, z, sigma),
            LawShape::General => {
                let x2 = ctx.x2_base + dx2;
                ctx.law.force(
                    tau,
                    &State {
                        x1: x2 + z,
                        y1,
                        x2,
                        y2,
                    },
                )
            }
        };
        let fcap = model.capsule_force(z, y1, y2, contact);
        let presliding = if F::PRESLIDING {
            ctx.friction.presliding()
        } else {
            None
        };
        let [dz, dy1, dy2, dp, dx] = field(
            model.capsule.gamma,
            self.regime.phase,
            presliding,
            &[z, y1, y2, p],
            fa,
            fcap,
            |d| {
                let y2d = match &self.history {
                    Some(h) if F::MEMORY => h.delayed(tau),
                    _ => y2,
                };
                ctx.friction.sliding(d, y2, y2d)
            },
        );
        [dz, dy1, dy2, dp, dx, fa * y1]
    }

    fn dopri_step<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        ctx: &Rhs<'_, L, F>,
        y: &V,
        k1: &V,
        h: f64,
    ) -> DopriStep {
        let t = self.tau;
        let mut k = [*k1; 7];
        // stage by stage with constant rows: `combine` is unrolled and the zeros dropped
        k[1] = self.rk_rhs(ctx, t + C[0] * h, &combine(y, h, A[0], &k));
        k[2] = self.rk_rhs(ctx, t + C[1] * h, &combine(y, h, A[1], &k));
        k[3] = self.rk_rhs(ctx, t + C[2] * h, &combine(y, h, A[2], &k));
        k[4] = self.rk_rhs(ctx, t + C[3] * h, &combine(y, h, A[3], &k));
        k[5] = self.rk_rhs(ctx, t + C[4] * h, &combine(y, h, A[4], &k));
        let ynew = combine(y, h, A[5], &k);
        let k7 = self.rk_rhs(ctx, t + h, &ynew);
        k[6] = k7;
        self.work.rhs_evals += 6;
        let err = combine(&[0.0; 6], h, &E, &k);
        let mut cont = [[0.0; 6]; 5];
        for i in 0..6 {
            let ydiff = ynew[i] - y[i];
            let bspl = h * k1[i] - ydiff;
            cont[0][i] = y[i];
            cont[1][i] = ydiff;
            cont[2][i] = bspl;
            cont[3][i] = ydiff - h * k7[i] - bspl;
            cont[4][i] = h * D
                .iter()
                .zip(&k)
                .filter(|(d, _)| **d != 0.0)
                .map(|(d, kj)| d * kj[i])
                .fold(0.0, |acc, x| acc + x);
        }
        DopriStep {
            y: ynew,
            k7,
            err,
            cont,
        }
    }

    fn error_norm(&self, y0: &V, s: &DopriStep) -> f64 {
        let tol = self.config.tol;
        let mut sum = 0.0;
        for ((y0, y1), err) in y0.iter().zip(&s.y).zip(&s.err) {
            let e = err / (tol + tol * y0.abs().max(y1.abs()));
            sum += e * e;
        }
        (sum / 6.0).sqrt()
    }

    fn start_vector(&self) -> V {
        let [z, y1, y2, p] = self.core;
        [z, y1, y2, p, 0.0, 0.0]
    }

    /// Runge-Kutta to `tau_end`: adaptive Dormand-Prince with located events (`located`), or
    /// fixed-step RK4 with the events noticed at step ends.
    pub(super) fn advance_rk<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        law: &L,
        friction: F,
        located: bool,
        tau_end: f64,
        on_event: &mut impl FnMut(&Transition) -> ControlFlow<()>,
    ) -> Result<Stop, SimError> {
        let mut leg = Leg {
            law,
            friction,
            shape: law.shape(),
            located,
            kink: Self::kink_gain(law) != 0.0,
            events: Vec::with_capacity(5),
            tau_end,
        };
        if located {
            self.advance_adaptive(&mut leg, on_event)
        } else {
            self.advance_fixed(&mut leg, on_event)
        }
    }

    fn advance_adaptive<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        leg: &mut Leg<'_, L, F>,
        on_event: &mut impl FnMut(&Transition) -> ControlFlow<()>,
    ) -> Result<Stop, SimError> {
        let tau_end = leg.tau_end;
        let h_cap = self.history.as_ref().map_or(f64::INFINITY, |h| h.delay());
        // first-same-as-last: the last stage of a step is the first of the next, unless a
        // switch changed the right-hand side in between
        let mut fsal: Option<V> = None;
        let (tau0, tried0) = (self.tau, self.work.steps + self.work.rejected);
        while self.tau < tau_end {
            // the envelope: a scene whose steps collapse (absurd stiffness) stops here instead
            // of grinding on for hours
            let tried = self.work.steps + self.work.rejected - tried0;
            if tried as f64 > MAX_STEPS_PER_TIME * (self.tau - tau0 + 1.0) {
                return Err(SimError::StepEnvelope {
                    tau: self.tau,
                    steps: tried,
                });
            }
            let ctx = leg.rhs(self.x2.value());
            let y0 = self.start_vector();
            let k1 = match fsal.take() {
                Some(k) => k,
                None => {
                    self.work.rhs_evals += 1;
                    self.rk_rhs(&ctx, self.tau, &y0)
                }
            };
            if self.rk_step <= 0.0 {
                self.rk_step = initial_step(&y0, &k1, self.config.tol);
            }
            let stop = match self
                .history
                .as_mut()
                .and_then(|h| h.next_breakpoint(self.tau))
            {
                Some(b) => b.min(tau_end),
                None => tau_end,
            };
            // one accepted step
            let (mut h, mut step) = self.accepted_step(&ctx, &y0, &k1, h_cap, stop)?;
            // first event in the step, on the dense output
            self.event_functions(leg.kink, &mut leg.events);
            let hit = first_event(&leg.events, &step);
            if let Some((th, ev)) = hit {
                if th == 0.0 {
                    let e = self.cross(ev.kind)?;
                    if on_event(&e).is_break() {
                        return Ok(Stop::Requested(e.event));
                    }
                    self.rk_step = self.rk_step.max(h * 0.1);
                    continue;
                }
                (h, step) = self.land_on_event(&ctx, &y0, &k1, (h, &step), th, &ev);
                self.finish_rk_step(h, &step)?;
                let e = self.cross(ev.kind)?;
                if on_event(&e).is_break() {
                    return Ok(Stop::Requested(e.event));
                }
            } else {
                self.finish_rk_step(h, &step)?;
                // the derivative does not depend on the increments dx2 and w, which restart at 0
                fsal = Some(step.k7);
            }
        }
        Ok(Stop::Horizon)
    }

    /// One accepted Dormand-Prince step from `y0` (derivative `k1`), at most `h_cap` long and
    /// not past `stop`: its length and the step; the next step's length stays in `rk_step`.
    fn accepted_step<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        ctx: &Rhs<'_, L, F>,
        y0: &V,
        k1: &V,
        h_cap: f64,
        stop: f64,
    ) -> Result<(f64, DopriStep), SimError> {
        loop {
            let h = self.rk_step.min(h_cap).min(stop - self.tau);
            if h <= f64::EPSILON * self.tau.abs().max(1.0) * 4.0 && self.tau + h < stop {
                return Err(SimError::StepUnderflow { tau: self.tau });
            }
            let s = self.dopri_step(ctx, y0, k1, h);
            let err = self.error_norm(y0, &s);
            let fac = if err == 0.0 {
                5.0
            } else if err.is_nan() {
                // a NaN error estimate must shrink the step, not keep it (that spun forever)
                0.2
            } else {
                (0.9 * err.powf(-0.2)).clamp(0.2, 5.0)
            };
            if err <= 1.0 {
                if h == self.rk_step.min(h_cap) || fac < 1.0 {
                    self.rk_step = h * fac;
                }
                return Ok((h, s));
            }
            self.work.rejected += 1;
            self.rk_step = h * fac.min(1.0);
        }
    }

    /// Re-takes the step `taken` (its length and step) with the length that puts `ev`'s
    /// function at zero, the crossing found at `th` of it: the length and the step.
    fn land_on_event<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        ctx: &Rhs<'_, L, F>,
        y0: &V,
        k1: &V,
        taken: (f64, &DopriStep),
        th: f64,
        ev: &EventFn,
    ) -> (f64, DopriStep) {
        let (h, step) = taken;
        let mut hs = th * h;
        let dgdh = |s: &DopriStep, th: f64| {
            let mut d = [0.0; 4];
            for (i, di) in d.iter_mut().enumerate() {
                *di = dense(&s.cont, i, th).1;
            }
            (ev.eval(&d) - ev.c0) / h
        };
        let slope0 = dgdh(step, th);
        let mut step = self.dopri_step(ctx, y0, k1, hs);
        for _ in 0..8 {
            let gv = ev.eval(&step.y);
            if gv.abs() <= BOUNDARY * 1e-2 || slope0 == 0.0 {
                break;
            }
            let hn = (hs - gv / slope0).clamp(0.0, h);
            if hn == hs {
                break;
            }
            hs = hn;
            step = self.dopri_step(ctx, y0, k1, hs);
        }
        (hs, step)
    }

    fn finish_rk_step(&mut self, h: f64, s: &DopriStep) -> Result<(), SimError> {
        let t0 = self.tau;
        if let Some(hist) = self.history.as_mut() {
            let mut c = [0.0; 5];
            for (j, cj) in c.iter_mut().enumerate() {
                *cj = s.cont[j][2];
            }
            hist.push(t0, h, Piece::Dopri(c));
        }
        let [z, y1, y2, p, dx2, dw] = s.y;
        let y2 = self.rigid_stick(y2);
        self.work.steps += 1;
        self.commit(h, [z, y1, y2, p], dx2, dw)
    }

    /// The capsule's velocity `y2` at a step's end: exactly 0 while it sticks without
    /// presliding (rigid stick).
    fn rigid_stick(&self, y2: f64) -> f64 {
        if self.regime.phase == Phase::Stick && self.model.friction.presliding().is_none() {
            0.0
        } else {
            y2
        }
    }

    fn advance_fixed<L: ActuatorLaw, F: FrictionLaw>(
        &mut self,
        leg: &mut Leg<'_, L, F>,
        on_event: &mut impl FnMut(&Transition) -> ControlFlow<()>,
    ) -> Result<Stop, SimError> {
        while self.tau < leg.tau_end {
            let h = self.config.step.min(leg.tau_end - self.tau);
            let ctx = leg.rhs(self.x2.value());
            let t = self.tau;
            let y = self.start_vector();
            let k1 = self.rk_rhs(&ctx, t, &y);
            let k2 = self.rk_rhs(&ctx, t + 0.5 * h, &axpy(&y, h, &[(0.5, &k1)]));
            let k3 = self.rk_rhs(&ctx, t + 0.5 * h, &axpy(&y, h, &[(0.5, &k2)]));
            let k4 = self.rk_rhs(&ctx, t + h, &axpy(&y, h, &[(1.0, &k3)]));
            self.work.rhs_evals += 4;
            let yn = axpy(
                &y,
                h,
                &[
                    (1.0 / 6.0, &k1),
                    (1.0 / 3.0, &k2),
                    (1.0 / 3.0, &k3),
                    (1.0 / 6.0, &k4),
                ],
            );
            let y2_start = y[2];
            let [z, y1, y2, p, dx2, dw] = yn;
            let y2 = self.rigid_stick(y2);
            if let Some(hist) = self.history.as_mut() {
                hist.push(t, h, Piece::Line(y2_start, y2));
            }
            self.work.steps += 1;
            self.commit(h, [z, y1, y2, p], dx2, dw)?;
            // switches noticed at the step end only, not located
            self.event_functions(leg.kink, &mut leg.events);
            let pending: Vec<EventKind> = leg
                .events
                .iter()
                .filter(|ev| ev.eval(&self.core) > 0.0)
                .map(|ev| ev.kind)
                .collect();
            for kind in pending {
                let e = self.cross(kind)?;
                if on_event(&e).is_break() {
                    return Ok(Stop::Requested(e.event));
                }
            }
        }
        Ok(Stop::Horizon)
    }
}

/// Hairer's starting step heuristic, simplified: `h = 0.01 (tol / |f|)^(1/5)`, capped.
fn initial_step(y: &V, f: &V, tol: f64) -> f64 {
    let mut d0: f64 = 0.0;
    let mut d1: f64 = 0.0;
    for i in 0..4 {
        let sc = tol + tol * y[i].abs();
        d0 = d0.max((y[i] / sc).abs());
        d1 = d1.max((f[i] / sc).abs());
    }
    let h = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    h.clamp(1e-8, 0.1)
}
