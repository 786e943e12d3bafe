//! The capsule's equations per regime, written once: right-hand side, its Jacobian, the event
//! functions with their gradients, the transition (reset) at each event and the saltation matrix
//! that carries a perturbation across it.
//!
//! The regime is the discrete state [`Regime`]: contact on/off (`H3`), the side `sigma` of the feedback
//! kink `|x2 - x1| = sigma (x1 - x2)`, and stick or slip with its direction. In each regime the state
//! `v = [z, y1, y2, p]` (`z = x1 - x2`, `p` the pre-sliding displacement) obeys
//!
//! ```text
//! z'  = y1 - y2
//! y1' = f_a(tau, z) - F(z, y1, y2)             f_a = alpha cos(omega tau) + bias + kp sigma z
//! y2' = (F - f_s(dir, y2)) / gamma             slipping in direction dir
//! y2' = (F - k_s p) / gamma,  p' = y2          stuck on the pre-sliding spring
//! y2' = 0                                      stuck (rigid static friction)
//! ```
//!
//! with `F` the force on the capsule ([`Model::capsule_force`]) and `f_s` the friction law's
//! sliding force ([`crate::model::Friction::sliding`]). The exact solver's closed-form series
//! ([`crate::solver`]) and the Runge-Kutta right-hand side apply these same formulas; the
//! stability analysis (Floquet multipliers, Lyapunov exponents) differentiates them here.
//!
//! Every event function is linear in `v` (`g = c . v + c0`, the regime valid while `g <= 0`), so its
//! gradient is `c`. The resets are the identity except at stick entry, where the velocity is
//! pinned to zero; that projection comes out of the saltation formula by itself (Leine and
//! Nijmeijer 2004, eq. 7.9): `S = I + (f+ - f-) c^T / (c . f-)`.

use crate::law::AffineLaw;
use crate::model::Model;
use serde::{Deserialize, Serialize};

/// Continuous state in the solvers' coordinates: `[z = x1 - x2, y1, y2, p]`, `p` the pre-sliding
/// displacement (zero unless the law has pre-sliding and the capsule is stuck).
pub type Core = [f64; 4];

/// Stick or slip of the capsule.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Phase {
    /// The capsule is held by static friction (`y2 = 0`, or pre-sliding on the stiff spring).
    Stick,
    /// The capsule slides in direction `+1` or `-1`.
    Slip(f64),
}

/// The discrete part of the state: what is switched by events.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Regime {
    /// Stick or slip.
    pub phase: Phase,
    /// The mass touches the secondary spring (`H3 = 1`).
    pub contact: bool,
    /// Side of the feedback kink: `sign(x1 - x2)`, so `|x2 - x1| = sigma (x1 - x2)`.
    pub sigma: f64,
}

/// What happened at an event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum EventKind {
    /// The mass reaches the secondary spring (an impact).
    ContactOn,
    /// The mass leaves the secondary spring.
    ContactOff,
    /// The stuck capsule starts to slip in direction `dir`.
    BreakAway {
        /// Direction of the new slip.
        dir: f64,
    },
    /// The slipping capsule's velocity reaches zero and it sticks.
    SlipEnd,
    /// The slipping capsule's velocity reaches zero and it slips on in direction `dir`
    /// (normally the other way: a reversal).
    Reversal {
        /// Direction of the new slip.
        dir: f64,
    },
    /// `x1 - x2` changes sign: the kink of the feedback `k_p |x2 - x1|`.
    Kink,
}

/// A located event.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Event {
    /// When it happened.
    pub tau: f64,
    /// What happened.
    pub kind: EventKind,
}

/// An event with the regime and state on both sides (state in the solvers' coordinates).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transition {
    /// The event.
    pub event: Event,
    /// Regime before.
    pub regime_before: Regime,
    /// `[z, y1, y2, p]` before.
    pub before: Core,
    /// Regime after.
    pub regime_after: Regime,
    /// `[z, y1, y2, p]` after (the reset applied).
    pub after: Core,
}

/// A 4 x 4 matrix on [`Core`], row-major.
pub type Mat4 = [[f64; 4]; 4];

/// The identity on [`Core`].
pub const IDENTITY: Mat4 = [
    [1.0, 0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0, 0.0],
    [0.0, 0.0, 1.0, 0.0],
    [0.0, 0.0, 0.0, 1.0],
];

/// A linear event function `c . [z, y1, y2, p] + c0`: the regime is valid while it is `<= 0`; its
/// gradient is `c`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EventFn {
    /// Gradient.
    pub c: [f64; 4],
    /// Constant part.
    pub c0: f64,
    /// The event it signals.
    pub kind: EventKind,
}

impl EventFn {
    /// Value at `v` (the first four entries are read).
    #[inline]
    pub fn eval(&self, v: &[f64]) -> f64 {
        self.c[0] * v[0] + self.c[1] * v[1] + self.c[2] * v[2] + self.c[3] * v[3] + self.c0
    }
}

/// The time derivative of `[z, y1, y2, p, x2]` in `phase`, given the actuator force `fa`, the
/// force on the capsule `fcap`, the sliding friction `fs` (read only in slip) and the pre-sliding
/// stiffness if any: the one place the regime's equations are assembled, for the Runge-Kutta path
/// and for [`Equations::rhs`].
#[inline(always)]
pub(crate) fn field(
    gamma: f64,
    phase: Phase,
    presliding: Option<f64>,
    v: &Core,
    fa: f64,
    fcap: f64,
    fs: impl FnOnce(f64) -> f64,
) -> [f64; 5] {
    let [_, y1, y2, p] = *v;
    let inv_gamma = 1.0 / gamma;
    let (dy2, dp, dx) = match (phase, presliding) {
        (Phase::Stick, Some(ks)) => ((fcap - ks * p) * inv_gamma, y2, y2),
        (Phase::Stick, None) => (0.0, 0.0, 0.0),
        (Phase::Slip(d), _) => ((fcap - fs(d)) * inv_gamma, 0.0, y2),
    };
    [y1 - y2, fa - fcap, dy2, dp, dx]
}

/// The event functions of `regime`; `kink` adds the feedback's `x1 = x2`.
pub fn events(model: &Model, regime: &Regime, kink: bool, out: &mut Vec<EventFn>) {
    out.clear();
    let cap = &model.capsule;
    if model.has_contact() {
        let (d, kind) = if regime.contact {
            (-1.0, EventKind::ContactOff)
        } else {
            (1.0, EventKind::ContactOn)
        };
        out.push(EventFn {
            c: [d, 0.0, 0.0, 0.0],
            c0: -d * cap.delta,
            kind,
        });
    }
    if kink {
        out.push(EventFn {
            c: [-regime.sigma, 0.0, 0.0, 0.0],
            c0: 0.0,
            kind: EventKind::Kink,
        });
    }
    let fb = model.friction.threshold();
    match regime.phase {
        Phase::Stick => {
            let k = model.coupling(regime.contact);
            let (fz, xi2, f0) = (k.stiffness(), k.damping(), k.offset());
            for d in [1.0, -1.0] {
                // d F - fb, or d ks p - fb with pre-sliding
                let (c, c0) = match model.friction.presliding() {
                    Some(ks) => ([0.0, 0.0, 0.0, d * ks], -fb),
                    None => ([d * fz, d * xi2, -d * xi2, 0.0], d * f0 - fb),
                };
                out.push(EventFn {
                    c,
                    c0,
                    kind: EventKind::BreakAway { dir: d },
                });
            }
        }
        Phase::Slip(d) => out.push(EventFn {
            c: [0.0, 0.0, -d, 0.0],
            c0: 0.0,
            kind: EventKind::SlipEnd,
        }),
    }
}

/// The switching rule: the regime and state after event `kind` in `regime` at state `v`, and what
/// the event turned out to be (a slip end becomes a reversal when the force exceeds the threshold).
pub fn transition(
    model: &Model,
    regime: Regime,
    v: Core,
    kind: EventKind,
) -> (Regime, Core, EventKind) {
    let mut regime = regime;
    let mut v = v;
    let kind = match kind {
        EventKind::ContactOn | EventKind::ContactOff => {
            regime.contact = !regime.contact;
            if regime.contact {
                EventKind::ContactOn
            } else {
                EventKind::ContactOff
            }
        }
        EventKind::Kink => {
            regime.sigma = -regime.sigma;
            EventKind::Kink
        }
        EventKind::BreakAway { dir } => {
            regime.phase = Phase::Slip(dir);
            v[3] = 0.0;
            EventKind::BreakAway { dir }
        }
        EventKind::SlipEnd | EventKind::Reversal { .. } => {
            v[2] = 0.0;
            let f = model.capsule_force(v[0], v[1], 0.0, regime.contact);
            let (phase, p) = phase_at_rest(model, f);
            regime.phase = phase;
            match phase {
                Phase::Stick => {
                    v[3] = p;
                    EventKind::SlipEnd
                }
                Phase::Slip(dir) => EventKind::Reversal { dir },
            }
        }
    };
    (regime, v, kind)
}

/// The stick/slip rule of a capsule at rest (`y2 = 0`) under the force `f` (a start, a slip's
/// end): stuck while `|f|` is within the threshold, held by the pre-sliding deflection
/// `p = f / ks` where the law has one (else `p = 0`); beyond it, sliding in `f`'s direction.
pub fn phase_at_rest(model: &Model, f: f64) -> (Phase, f64) {
    if f.abs() <= model.friction.threshold() {
        let p = model.friction.presliding().map_or(0.0, |ks| f / ks);
        (Phase::Stick, p)
    } else {
        (Phase::Slip(f.signum()), 0.0)
    }
}

/// A model under a piecewise-affine drive: everything the stability analysis differentiates.
/// Frictional memory is not part of it (a delay makes the state infinite-dimensional): the
/// sliding force reads the current velocity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Equations {
    /// Capsule and friction law.
    pub model: Model,
    /// Actuator law.
    pub drive: AffineLaw,
}

impl Equations {
    /// The equations of `model` under `drive`.
    pub fn new(model: Model, drive: AffineLaw) -> Self {
        Equations { model, drive }
    }

    /// `v'` in `regime` at time `tau` (without the capsule position).
    pub fn rhs(&self, tau: f64, regime: &Regime, v: &Core) -> Core {
        let m = &self.model;
        let fa = self.drive.force_on_side(tau, v[0], regime.sigma);
        let fcap = m.capsule_force(v[0], v[1], v[2], regime.contact);
        let f = field(
            m.capsule.gamma,
            regime.phase,
            m.friction.presliding(),
            v,
            fa,
            fcap,
            |d| m.friction.sliding(d, v[2], v[2]),
        );
        [f[0], f[1], f[2], f[3]]
    }

    /// `d v' / d v` in `regime` at state `v` (the time enters only the drive, which is additive).
    pub fn jacobian(&self, regime: &Regime, v: &Core) -> Mat4 {
        let m = &self.model;
        let k = m.coupling(regime.contact);
        // d F / d [z, y1, y2]
        let (fz, xi2) = (k.stiffness(), k.damping());
        let mut j = [[0.0; 4]; 4];
        j[0] = [0.0, 1.0, -1.0, 0.0];
        j[1] = [self.drive.kp * regime.sigma - fz, -xi2, xi2, 0.0];
        let g = 1.0 / m.capsule.gamma;
        match (regime.phase, m.friction.presliding()) {
            (Phase::Stick, Some(ks)) => {
                j[2] = [fz * g, xi2 * g, -xi2 * g, -ks * g];
                j[3] = [0.0, 0.0, 1.0, 0.0];
            }
            (Phase::Stick, None) => {}
            (Phase::Slip(d), _) => {
                let slope = m.friction.sliding_slope(d, v[2]);
                j[2] = [fz * g, xi2 * g, (-xi2 - slope) * g, 0.0];
            }
        }
        j
    }

    /// Whether the flow in `regime` is linear (constant Jacobian): the law is piecewise linear, or
    /// the capsule is stuck.
    pub fn is_linear(&self, regime: &Regime) -> bool {
        self.model.friction.is_piecewise_linear() || regime.phase == Phase::Stick
    }

    /// The event functions of `regime`, the kink included when the drive has feedback.
    pub fn events(&self, regime: &Regime, out: &mut Vec<EventFn>) {
        events(&self.model, regime, self.drive.kp != 0.0, out)
    }

    /// The event function of `kind` in `regime` (its gradient and constant).
    pub fn event(&self, regime: &Regime, kind: EventKind) -> Option<EventFn> {
        let mut all = Vec::with_capacity(4);
        self.events(regime, &mut all);
        all.into_iter().find(|e| match (e.kind, kind) {
            (EventKind::BreakAway { dir: a }, EventKind::BreakAway { dir: b }) => a == b,
            (EventKind::SlipEnd, EventKind::SlipEnd | EventKind::Reversal { .. }) => true,
            (a, b) => a == b,
        })
    }

    /// The saltation matrix of an event: a perturbation `dv` just before the event at time `tau`
    /// (state `before` in regime `m0`, crossing the event function `ev`) is `S dv` just after
    /// (state `after` in regime `m1`). With the reset the identity on the flow's directions,
    /// `S = I + (f+ - f-) c^T / (c . f-)`; `None` when the crossing is tangent (`c . f- = 0`,
    /// grazing), where no linear map exists.
    pub fn saltation(
        &self,
        tau: f64,
        ev: &EventFn,
        m0: &Regime,
        before: &Core,
        m1: &Regime,
        after: &Core,
    ) -> Option<Mat4> {
        let f0 = self.rhs(tau, m0, before);
        let f1 = self.rhs(tau, m1, after);
        let dot: f64 = ev.c.iter().zip(&f0).map(|(a, b)| a * b).sum();
        if dot == 0.0 || !dot.is_finite() {
            return None;
        }
        let mut s = IDENTITY;
        for (i, row) in s.iter_mut().enumerate() {
            let df = (f1[i] - f0[i]) / dot;
            for (k, x) in row.iter_mut().enumerate() {
                *x += df * ev.c[k];
            }
        }
        Some(s)
    }
}

/// `a b` for 4 x 4 matrices.
pub fn mat_mul(a: &Mat4, b: &Mat4) -> Mat4 {
    let mut out = [[0.0; 4]; 4];
    for i in 0..4 {
        for k in 0..4 {
            let aik = a[i][k];
            if aik != 0.0 {
                for j in 0..4 {
                    out[i][j] += aik * b[k][j];
                }
            }
        }
    }
    out
}

/// `exp(a t)` by scaling and squaring of the Taylor series (terms kept until below rounding):
/// the flow Jacobian of a linear regime over a segment of length `t`.
pub fn expm(a: &Mat4, t: f64) -> Mat4 {
    let norm = a
        .iter()
        .map(|r| r.iter().map(|x| x.abs()).sum::<f64>())
        .fold(0.0f64, f64::max)
        * t.abs();
    // scale until the norm is below 1/2
    let mut squarings = 0u32;
    let mut scale = t;
    let mut n = norm;
    while n > 0.5 {
        n *= 0.5;
        scale *= 0.5;
        squarings += 1;
    }
    let mut m = [[0.0; 4]; 4];
    for (mr, ar) in m.iter_mut().zip(a) {
        for (x, y) in mr.iter_mut().zip(ar) {
            *x = y * scale;
        }
    }
    let mut sum = IDENTITY;
    let mut term = IDENTITY;
    for k in 1..=24 {
        term = mat_mul(&term, &m);
        let inv = 1.0 / k as f64;
        let mut biggest = 0.0f64;
        for row in term.iter_mut() {
            for x in row.iter_mut() {
                *x *= inv;
                biggest = biggest.max(x.abs());
            }
        }
        for (sr, tr) in sum.iter_mut().zip(&term) {
            for (s, x) in sr.iter_mut().zip(tr) {
                *s += x;
            }
        }
        if biggest < 1e-18 {
            break;
        }
    }
    for _ in 0..squarings {
        sum = mat_mul(&sum, &sum);
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Capsule, Friction};

    fn model(friction: Friction) -> Model {
        Model {
            capsule: Capsule {
                gamma: 0.235,
                beta: 3.05,
                delta: 0.02,
                xi: 0.05,
            },
            friction,
        }
    }

    const DRIVE: AffineLaw = AffineLaw {
        alpha: 1.6,
        omega: 1.1,
        bias: 0.1,
        kp: -0.3,
    };

    fn regimes() -> Vec<Regime> {
        let mut out = Vec::new();
        for contact in [false, true] {
            for sigma in [1.0, -1.0] {
                for phase in [Phase::Stick, Phase::Slip(1.0), Phase::Slip(-1.0)] {
                    out.push(Regime {
                        phase,
                        contact,
                        sigma,
                    });
                }
            }
        }
        out
    }

    #[test]
    fn jacobian_agrees_with_central_differences_in_every_mode() {
        for law in Friction::laws_with(0.3, 0.0, 4e2) {
            let eq = Equations::new(model(law), DRIVE);
            for regime in regimes() {
                let y2 = match regime.phase {
                    Phase::Slip(d) => 0.07 * d,
                    Phase::Stick => 0.0,
                };
                let v = [0.013, -0.4, y2, 1e-3];
                let j = eq.jacobian(&regime, &v);
                for k in 0..4 {
                    let h = 1e-6;
                    let mut vp = v;
                    let mut vm = v;
                    vp[k] += h;
                    vm[k] -= h;
                    let fp = eq.rhs(0.7, &regime, &vp);
                    let fm = eq.rhs(0.7, &regime, &vm);
                    for i in 0..4 {
                        let fd = (fp[i] - fm[i]) / (2.0 * h);
                        assert!(
                            (fd - j[i][k]).abs() < 1e-6 * (1.0 + fd.abs()),
                            "{law:?} {regime:?} d{i}/d{k}: {fd} vs {}",
                            j[i][k]
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn expm_solves_the_linear_flow() {
        // a damped oscillator: exp(A t) against the closed form
        let (w, z) = (1.3f64, 0.1f64);
        let mut a = [[0.0; 4]; 4];
        a[0][1] = 1.0;
        a[1][0] = -w * w;
        a[1][1] = -2.0 * z * w;
        let t = 7.5;
        let e = expm(&a, t);
        let wd = w * (1.0 - z * z).sqrt();
        let decay = (-z * w * t).exp();
        let x00 = decay * ((wd * t).cos() + z * w / wd * (wd * t).sin());
        let x01 = decay * (wd * t).sin() / wd;
        assert!((e[0][0] - x00).abs() < 1e-13, "{} vs {x00}", e[0][0]);
        assert!((e[0][1] - x01).abs() < 1e-13, "{} vs {x01}", e[0][1]);
        assert_eq!(e[3][3], 1.0);
    }

    #[test]
    fn stick_entry_saltation_removes_the_velocity() {
        let eq = Equations::new(model(Friction::COULOMB), DRIVE);
        let slip = Regime {
            phase: Phase::Slip(1.0),
            contact: false,
            sigma: 1.0,
        };
        // F = z + 2 xi y1 well below the threshold: the capsule sticks
        let before = [0.01, 0.2, 0.0, 0.0];
        let (stuck, after, kind) = transition(&eq.model, slip, before, EventKind::SlipEnd);
        assert_eq!(kind, EventKind::SlipEnd);
        assert_eq!(stuck.phase, Phase::Stick);
        let ev = eq
            .event(&slip, EventKind::SlipEnd)
            .unwrap_or_else(|| panic!());
        let s = eq
            .saltation(0.3, &ev, &slip, &before, &stuck, &after)
            .unwrap_or_else(|| panic!("transversal"));
        // the velocity direction is projected out, the rest is untouched
        assert!(s[2].iter().all(|x| x.abs() < 1e-15), "{s:?}");
        assert_eq!(s[0], [1.0, 0.0, 0.0, 0.0]);
        // contact and kink events join continuous fields: the identity
        let on = eq
            .event(&slip, EventKind::ContactOn)
            .unwrap_or_else(|| panic!());
        let v = [0.02, 0.5, 0.1, 0.0];
        let contact = Regime {
            contact: true,
            ..slip
        };
        let s = eq
            .saltation(0.3, &on, &slip, &v, &contact, &v)
            .unwrap_or_else(|| panic!());
        for (i, row) in s.iter().enumerate() {
            for (k, x) in row.iter().enumerate() {
                let id = if i == k { 1.0 } else { 0.0 };
                assert!((x - id).abs() < 1e-15, "{s:?}");
            }
        }
    }
}
