//! Exact piecewise solution for the linear regimes (the piecewise-linear friction laws:
//! [`crate::friction::FrictionLaw::linear`]).
//!
//! In every regime the state `v = [z, y1, y2, p, dx2]` obeys `v' = A v + b0 + e1 f(tau)` with a
//! constant matrix `A`, a constant `b0` and the harmonic drive `f(tau) = alpha cos(omega tau)` on
//! the mass. Over a step of length `h` the flow is its Taylor series `v(t0 + t) = sum V_k t^k`,
//! with `V_{k+1} = (A V_k + B_k) / (k + 1)` and `B_k` the Taylor coefficients of the forcing.
//! The coefficients do not depend on the step, so the step is chosen after them: as long as
//! the last two terms stay below `1e-17` of the state (truncation below rounding) and no term
//! exceeds 8 times the state (no digits lost to cancellation). The result is the matrix
//! exponential's flow to machine precision, not an approximation of a given order.
//! Every event function is linear in `v`, so along the step it is the scalar polynomial
//! `sum (c . V_k) t^k`, whose first crossing is located to rounding.

use super::{EventKind, Phase, Regime, SimError, Simulator, Stop, Transition};
use crate::equations::{Core, EventFn};
use crate::law::AffineLaw;
use crate::roots::first_crossing;
use std::ops::ControlFlow;

/// Series terms kept per step.
const K: usize = 30;
/// Truncation bound on the last terms, relative to the state.
const TRUNCATION: f64 = 1e-17;
/// Cancellation bound on any term, relative to the state.
const GROWTH: f64 = 8.0;

/// The linear dynamics of one regime.
#[derive(Debug, Clone, Copy)]
struct Linear {
    /// Stiffness on the mass, `kp sigma - 1 - H3 beta`.
    az: f64,
    /// Constant force on the mass, `bias + H3 beta delta`.
    c1: f64,
    /// `2 xi`.
    xi2: f64,
    /// Stiffness felt by the capsule, `1 + H3 beta`.
    bz: f64,
    /// The capsule moves (slip, or pre-sliding in stick).
    moves: bool,
    /// Viscous friction coefficient (slip only).
    mu: f64,
    /// Pre-sliding stiffness (stick with pre-sliding only).
    ks: f64,
    /// Constant force on the capsule: `-H3 beta delta - dir coulomb` in slip.
    c2: f64,
    /// `1 / gamma`.
    inv_gamma: f64,
}

impl Linear {
    /// The regime's linear form; `None` when the friction law has none (`Simulator::new` refuses
    /// the exact method for such a law, so this is not reached).
    fn new(sim: &Simulator, regime: &Regime, drive: &AffineLaw) -> Option<Self> {
        let k = sim.model.coupling(regime.contact);
        let presliding = sim.model.friction.presliding();
        let sliding = sim.model.friction.linear()?;
        let (moves, mu, ks, c2) = match regime.phase {
            Phase::Slip(d) => (true, sliding.viscous, 0.0, k.offset() - d * sliding.coulomb),
            Phase::Stick => match presliding {
                Some(ks) => (true, 0.0, ks, k.offset()),
                None => (false, 0.0, 0.0, 0.0),
            },
        };
        // F's own coefficients, moved to the mass's side with the feedback's stiffness; `- 1.0 -
        // H3 beta` rather than `- stiffness()`: the same rounding as before the refactor
        let az = drive.kp * regime.sigma - 1.0 - k.contact_stiffness();
        Some(Linear {
            az,
            c1: drive.bias - k.offset(),
            xi2: k.damping(),
            bz: k.stiffness(),
            moves,
            mu,
            ks,
            c2,
            inv_gamma: 1.0 / sim.model.capsule.gamma,
        })
    }

    /// `A v`.
    #[inline(always)]
    fn apply(&self, v: &[f64; 5]) -> [f64; 5] {
        let [z, y1, y2, p, _] = *v;
        let dy1 = self.az * z - self.xi2 * (y1 - y2);
        if self.moves {
            let dy2 =
                (self.bz * z + self.xi2 * (y1 - y2) - self.mu * y2 - self.ks * p) * self.inv_gamma;
            let dp = if self.ks > 0.0 { y2 } else { 0.0 };
            [y1 - y2, dy1, dy2, dp, y2]
        } else {
            [y1, dy1, 0.0, 0.0, 0.0]
        }
    }
}

/// Horner evaluation of one scalar series.
#[inline]
fn horner(g: &[f64], t: f64) -> f64 {
    g.iter().rev().fold(0.0, |acc, &c| acc * t + c)
}

/// Horner evaluation of one scalar series and its derivative at each of the points `ts`; the
/// points go through the loop together (the same operations per point as one at a time, but
/// `N` chains that overlap instead of one that waits on each multiply and add).
#[inline]
fn horner2<const N: usize>(g: &[f64], ts: &[f64; N]) -> [(f64, f64); N] {
    let n = g.len() - 1;
    let mut acc = [g[n]; N];
    let mut dacc = [0.0; N];
    for &c in g[..n].iter().rev() {
        for j in 0..N {
            dacc[j] = dacc[j] * ts[j] + acc[j];
            acc[j] = acc[j] * ts[j] + c;
        }
    }
    std::array::from_fn(|j| (acc[j], dacc[j]))
}

/// The first event in `(0, h]` of a step whose series is `series` (degree `n` =
/// `series.len() - 1`): where and which (`h` and none when no event function crosses zero);
/// `gser` is room for an event function's series.
fn first_event(
    events: &[EventFn],
    series: &[[f64; 5]],
    gser: &mut [f64; K + 1],
    h: f64,
) -> (f64, Option<EventKind>) {
    let n = series.len() - 1;
    let mut t_hit = h;
    let mut hit: Option<EventKind> = None;
    for ev in events {
        for (g, v) in gser.iter_mut().zip(series) {
            *g = ev.c[0] * v[0] + ev.c[1] * v[1] + ev.c[2] * v[2] + ev.c[3] * v[3];
        }
        gser[0] += ev.c0;
        // |g(t) - g(0)| <= sum |G_k| t^k: if that cannot reach zero, no crossing.
        // Terms below rounding over this step are left out of the evaluations.
        let mut reach = 0.0;
        let mut tk = 1.0;
        let mut degree = 0;
        let negligible = TRUNCATION * (1.0 + gser[0].abs());
        for (k, gk) in gser.iter().enumerate().take(n + 1).skip(1) {
            tk *= t_hit;
            let term = gk.abs() * tk;
            reach += term;
            if term > negligible {
                degree = k;
            }
        }
        if gser[0] + reach <= crate::roots::NOISE {
            continue;
        }
        let g = &gser[..=degree];
        let crossing = first_crossing(
            |t| horner(g, t),
            |t| horner2(g, &[t])[0],
            |ts| horner2(g, ts),
            t_hit,
        );
        if let Some(t) = crossing {
            if hit.is_none() || t < t_hit {
                t_hit = t;
                hit = Some(ev.kind);
            }
        }
    }
    (t_hit, hit)
}

/// The state at `t` into a step from its Taylor series (Horner, the five components together:
/// their chains overlap).
fn sum_at(series: &[[f64; 5]], t: f64) -> [f64; 5] {
    let n = series.len() - 1;
    let mut v = series[n];
    for vk in series[..n].iter().rev() {
        for (acc, c) in v.iter_mut().zip(vk) {
            *acc = *acc * t + c;
        }
    }
    v
}

impl Simulator {
    pub(super) fn advance_exact(
        &mut self,
        drive: &AffineLaw,
        tau_end: f64,
        on_event: &mut impl FnMut(&Transition) -> ControlFlow<()>,
    ) -> Result<Stop, SimError> {
        let mut series = [[0.0f64; 5]; K + 1];
        let mut gser = [0.0f64; K + 1];
        let mut events: Vec<EventFn> = Vec::with_capacity(5);
        let linear = |sim: &Simulator| {
            Linear::new(sim, &sim.regime, drive)
                .ok_or(SimError::ExactNeedsLinearLaw(sim.model.friction.name()))
        };
        let mut lin = linear(self)?;
        let mut lin_regime = self.regime;
        // the step the series allowed last time: terms are summed only as far as that needs
        let mut h_natural = f64::INFINITY;
        while self.tau < tau_end {
            if lin_regime != self.regime {
                lin = linear(self)?;
                lin_regime = self.regime;
            }
            // Taylor coefficients of the state over the step
            let [z, y1, y2, p] = self.core;
            series[0] = [z, y1, y2, p, 0.0];
            let phase = drive.omega * self.tau;
            let (s, c) = phase.sin_cos();
            let trig = [c, -s, -c, s];
            let mut drive_k = drive.alpha; // alpha omega^k / k!
            let mut forcing = [0.0f64; K + 1];
            let target = (tau_end - self.tau).min(h_natural);
            let scale = 1.0 + norm(&series[0]);
            let mut n = K;
            let mut target_k = 1.0;
            for k in 0..K {
                forcing[k] = drive_k * trig[k % 4];
                let mut d = lin.apply(&series[k]);
                d[1] += forcing[k];
                if k == 0 {
                    d[1] += lin.c1;
                    if lin.moves {
                        d[2] += lin.c2 * lin.inv_gamma;
                    }
                }
                let inv = 1.0 / (k + 1) as f64;
                for (dst, v) in series[k + 1].iter_mut().zip(d) {
                    *dst = v * inv;
                }
                drive_k *= drive.omega * inv;
                target_k *= target;
                // enough terms once two in a row are below rounding over the target step
                if k >= 8
                    && norm(&series[k + 1]) * target_k * target < TRUNCATION * scale
                    && norm(&series[k]) * target_k < TRUNCATION * scale
                {
                    n = k + 1;
                    break;
                }
            }
            forcing[n] = drive_k * trig[n % 4];
            self.work.rhs_evals += n as u64;
            let h = if n < K {
                h_natural = 1.5 * target;
                growth_limit(&series, target)
            } else {
                let h = step_length(&series, tau_end - self.tau);
                h_natural = h;
                h
            };
            let series = &series[..=n];
            // first event in (0, h]
            self.event_functions(drive.kp != 0.0, &mut events);
            let (t_hit, hit) = first_event(&events, series, &mut gser, h);
            // state at the end of the (possibly shortened) step
            let v = sum_at(series, t_hit);
            let dw = if self.track_work {
                self.step_work(series, &forcing[..=n], drive, t_hit)
            } else {
                0.0
            };
            let core: Core = [v[0], v[1], if lin.moves { v[2] } else { 0.0 }, v[3]];
            self.commit(t_hit, core, v[4], dw)?;
            self.work.steps += 1;
            if let Some(kind) = hit {
                let ev = self.cross(kind)?;
                if on_event(&ev).is_break() {
                    return Ok(Stop::Requested(ev.event));
                }
            }
        }
        Ok(Stop::Horizon)
    }

    /// `integral_0^t f_a y1` over a step from the series of `z`, `y1` and the drive: the product
    /// of two degree-`K` series, integrated term by term (all `2K` degrees kept: the product
    /// varies twice as fast as its factors).
    fn step_work(&self, series: &[[f64; 5]], forcing: &[f64], drive: &AffineLaw, t: f64) -> f64 {
        let ks = drive.kp * self.regime.sigma;
        let n = series.len() - 1;
        let mut fa = [0.0f64; K + 1];
        let mut y1 = [0.0f64; K + 1];
        for k in 0..=n {
            fa[k] = forcing[k] + ks * series[k][0];
            y1[k] = series[k][1];
        }
        fa[0] += drive.bias;
        let mut prod = [0.0f64; 2 * K + 1];
        for (j, &a) in fa[..=n].iter().enumerate() {
            for (p, &b) in prod[j..=j + n].iter_mut().zip(&y1[..=n]) {
                *p += a * b;
            }
        }
        // integral of sum prod_k t^k = sum prod_k t^(k+1) / (k+1), by Horner
        let mut acc = 0.0;
        for k in (0..=2 * n).rev() {
            acc = acc * t + prod[k] / (k + 1) as f64;
        }
        acc * t
    }
}

/// The longest step (at most `max`) over which the series is accurate to rounding: its last two
/// terms below [`TRUNCATION`] and no term above [`GROWTH`] times the state.
fn step_length(series: &[[f64; 5]; K + 1], max: f64) -> f64 {
    let scale = 1.0 + norm(&series[0]);
    let mut h = max;
    for k in [K - 1, K] {
        let c = norm(&series[k]);
        if c > 0.0 {
            h = h.min((TRUNCATION * scale / c).powf(1.0 / k as f64));
        }
    }
    growth_limit(series, h)
}

/// `max`, shortened so that no term exceeds [`GROWTH`] times the state.
fn growth_limit(series: &[[f64; 5]; K + 1], max: f64) -> f64 {
    let scale = 1.0 + norm(&series[0]);
    let mut h = max;
    for k in [2, 4, 8] {
        let c = norm(&series[k]);
        if c * h.powi(k as i32) > GROWTH * scale {
            h = h.min((GROWTH * scale / c).powf(1.0 / k as f64));
        }
    }
    h
}

#[inline]
fn norm(v: &[f64; 5]) -> f64 {
    v.iter().fold(0.0f64, |m, x| m.max(x.abs()))
}
