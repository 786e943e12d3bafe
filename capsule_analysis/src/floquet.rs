//! The Poincaré map, its exact Jacobian, and the Floquet multipliers of a periodic orbit.
//!
//! **Section and coordinates.** The drive makes the system periodic in time, so the section is
//! drive phase 0 (`tau = n T`) and the map is the flow over one period. The capsule position
//! `x2` drifts and the dynamics do not depend on it (translation invariance), so the map acts on
//! `x = [z = x1 - x2, y1, y2]`: the reduced state a periodic orbit actually repeats in. Laws with
//! frictional memory (a delay: an infinite-dimensional state) or a pre-sliding spring are not
//! covered.
//!
//! **Jacobian.** Along one period the trajectory is a chain of smooth segments joined at events
//! (contact on and off, the kink of `|x2 - x1|`, break-away, slip end or reversal). The Jacobian is
//! the product, in order, of each segment's flow Jacobian and each event's saltation matrix
//! (Müller 1995; Leine and Nijmeijer 2004, ch. 7), both from [`Equations`]. A linear regime's flow
//! Jacobian is its matrix exponential (exact); a nonlinear regime (Stribeck slip) integrates the
//! variational equation along the segment with classical RK4 at a step of at most [`VAR_STEP`].
//!
//! **Sticking.** The stuck capsule has `y2 = 0`: the stick-entry saltation projects the `y2`
//! direction out (a multiplier exactly 0 for any orbit that sticks). If the orbit is stuck at the
//! section, perturbations live on `y2 = 0` only and the `y2` column of the Jacobian is zeroed.

use capsule_plant::equations::{expm, mat_mul, Core, Equations, Mat4, IDENTITY};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{EventKind, Phase, Regime, SimError, Simulator, State, Transition};
use serde::Serialize;
use std::ops::ControlFlow;
use std::sync::atomic::{AtomicU64, Ordering};
use thiserror::Error;

/// Largest RK4 step for the variational equation of a nonlinear regime.
pub const VAR_STEP: f64 = 1e-3;

/// Why the stability analysis cannot be done.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum StabilityError {
    /// The simulation failed.
    #[error(transparent)]
    Sim(#[from] SimError),
    /// The friction law has memory or pre-sliding.
    #[error("the stability analysis needs a friction law without frictional memory or pre-sliding (tau_d = 0, k_s = 0); {0} has them")]
    UnsupportedLaw(&'static str),
    /// An event was crossed tangentially: no saltation matrix exists.
    #[error("grazing {kind:?} at tau = {tau}: the event is crossed tangentially, the Poincaré map is not differentiable there")]
    Grazing {
        /// When.
        tau: f64,
        /// Which event.
        kind: EventKind,
    },
    /// The orbit is not periodic.
    #[error("{0}")]
    NotPeriodic(String),
}

/// The Poincaré map over some drive periods and its Jacobian.
#[derive(Debug, Clone, PartialEq)]
pub struct Linearization {
    /// `[z, y1, y2]` at the end.
    pub end: [f64; 3],
    /// `d end / d start`.
    pub jacobian: [[f64; 3]; 3],
    /// The events crossed, in order.
    pub events: Vec<EventKind>,
    /// The capsule was stuck at the start (the `y2` column is zero).
    pub stuck_at_start: bool,
    /// Smallest `|c . f-| / (|c| |f-|)` over the events: how transversal the crossings were
    /// (0 at grazing).
    pub min_transversality: f64,
}

/// The equations of a scene, or why the analysis does not apply.
pub fn equations_of(scene: &Scene) -> Result<Equations, StabilityError> {
    let f = &scene.model.friction;
    if f.memory_delay().is_some() || f.presliding().is_some() {
        return Err(StabilityError::UnsupportedLaw(f.name()));
    }
    let shape = capsule_plant::ActuatorLaw::shape(&scene.law());
    let capsule_plant::LawShape::PiecewiseAffine(drive) = shape else {
        return Err(StabilityError::UnsupportedLaw(f.name()));
    };
    Ok(Equations::new(scene.model, drive))
}

/// The flow Jacobian of `regime` from state `v` at `tau` over `dt`.
fn flow_jacobian(eq: &Equations, regime: &Regime, tau: f64, v: &Core, dt: f64) -> Mat4 {
    if dt <= 0.0 {
        return IDENTITY;
    }
    if eq.is_linear(regime) {
        return expm(&eq.jacobian(regime, v), dt);
    }
    // RK4 on the state and the variational equation Phi' = J(v) Phi
    let n = (dt / VAR_STEP).ceil().max(1.0);
    let h = dt / n;
    let mut x = *v;
    let mut phi = IDENTITY;
    let deriv = |t: f64, x: &Core, phi: &Mat4| {
        (eq.rhs(t, regime, x), mat_mul(&eq.jacobian(regime, x), phi))
    };
    let add = |x: &Core, k: &Core, a: f64| {
        let mut o = *x;
        for (oi, ki) in o.iter_mut().zip(k) {
            *oi += a * ki;
        }
        o
    };
    let addm = |p: &Mat4, k: &Mat4, a: f64| {
        let mut o = *p;
        for (or, kr) in o.iter_mut().zip(k) {
            for (oi, ki) in or.iter_mut().zip(kr) {
                *oi += a * ki;
            }
        }
        o
    };
    for i in 0..n as usize {
        let t = tau + i as f64 * h;
        let (k1, m1) = deriv(t, &x, &phi);
        let (k2, m2) = deriv(
            t + 0.5 * h,
            &add(&x, &k1, 0.5 * h),
            &addm(&phi, &m1, 0.5 * h),
        );
        let (k3, m3) = deriv(
            t + 0.5 * h,
            &add(&x, &k2, 0.5 * h),
            &addm(&phi, &m2, 0.5 * h),
        );
        let (k4, m4) = deriv(t + h, &add(&x, &k3, h), &addm(&phi, &m3, h));
        for j in 0..4 {
            x[j] += h / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
            for k in 0..4 {
                phi[j][k] += h / 6.0 * (m1[j][k] + 2.0 * m2[j][k] + 2.0 * m3[j][k] + m4[j][k]);
            }
        }
    }
    phi
}

/// Calls of [`advance_linearized`] in this process: every Floquet multiplier, Lyapunov exponent
/// and Newton step on the Poincaré map goes through it, so zero means no such analysis ran.
static LINEARIZED: AtomicU64 = AtomicU64::new(0);

/// How many stretches of trajectory this process has linearized ([`advance_linearized`]) so
/// far: a counter of the stability analyses' work, for checking that an unrequested one did
/// not run.
pub fn linearizations() -> u64 {
    LINEARIZED.load(Ordering::Relaxed)
}

/// Advance `sim` to `tau_end` and return the Jacobian of its `[z, y1, y2, p]` at `tau_end` with
/// respect to that at the start; the events crossed are appended to `events` and the smallest
/// transversality is folded into `transversality`.
pub fn advance_linearized(
    sim: &mut Simulator,
    eq: &Equations,
    law: &AffineLaw,
    tau_end: f64,
    events: &mut Vec<EventKind>,
    transversality: &mut f64,
) -> Result<Mat4, StabilityError> {
    LINEARIZED.fetch_add(1, Ordering::Relaxed);
    let mut trace: Vec<Transition> = Vec::new();
    let (mut t, mut regime, mut core) = (sim.time(), sim.regime(), sim.core());
    sim.advance_until(law, tau_end, &mut |tr| {
        trace.push(*tr);
        ControlFlow::Continue(())
    })?;
    let mut j = IDENTITY;
    for tr in &trace {
        let tau = tr.event.tau;
        j = mat_mul(&flow_jacobian(eq, &regime, t, &core, tau - t), &j);
        let grazing = StabilityError::Grazing {
            tau,
            kind: tr.event.kind,
        };
        let ev = eq
            .event(&tr.regime_before, tr.event.kind)
            .ok_or(grazing.clone())?;
        let f0 = eq.rhs(tau, &tr.regime_before, &tr.before);
        let dot: f64 = ev.c.iter().zip(&f0).map(|(a, b)| a * b).sum();
        let nc = ev.c.iter().map(|x| x * x).sum::<f64>().sqrt();
        let nf = f0.iter().map(|x| x * x).sum::<f64>().sqrt();
        if nc > 0.0 && nf > 0.0 {
            *transversality = transversality.min(dot.abs() / (nc * nf));
        }
        let s = eq
            .saltation(
                tau,
                &ev,
                &tr.regime_before,
                &tr.before,
                &tr.regime_after,
                &tr.after,
            )
            .ok_or(grazing)?;
        j = mat_mul(&s, &j);
        events.push(tr.event.kind);
        (t, regime, core) = (tau, tr.regime_after, tr.after);
    }
    Ok(mat_mul(
        &flow_jacobian(eq, &regime, t, &core, sim.time() - t),
        &j,
    ))
}

/// The top-left 3 x 3 block (the `p` coordinate is unused here); with `stuck`, the `y2` column
/// zeroed (perturbations start on the stick manifold).
fn reduce(j: &Mat4, stuck: bool) -> [[f64; 3]; 3] {
    let mut r = [[0.0; 3]; 3];
    for i in 0..3 {
        for k in 0..3 {
            r[i][k] = if stuck && k == 2 { 0.0 } else { j[i][k] };
        }
    }
    r
}

/// A simulator of `scene` at `tau0` in reduced state `x` (capsule at 0).
fn start(scene: &Scene, x: [f64; 3], tau0: f64) -> Result<Simulator, SimError> {
    let s = State {
        x1: x[0],
        y1: x[1],
        x2: 0.0,
        y2: x[2],
    };
    Simulator::new(scene.model, s, tau0, scene.solver)
}

/// The Poincaré map over `periods` drive periods from `x = [z, y1, y2]` at `tau = 0`, with its
/// Jacobian.
pub fn poincare_map(
    scene: &Scene,
    x: [f64; 3],
    periods: usize,
) -> Result<Linearization, StabilityError> {
    let eq = equations_of(scene)?;
    let law = scene.law();
    let mut sim = start(scene, x, 0.0)?;
    let stuck = sim.regime().phase == Phase::Stick;
    let mut events = Vec::new();
    let mut transversality = f64::INFINITY;
    let tau_end = periods as f64 * scene.drive.period();
    let j = advance_linearized(
        &mut sim,
        &eq,
        &law,
        tau_end,
        &mut events,
        &mut transversality,
    )?;
    let c = sim.core();
    Ok(Linearization {
        end: [c[0], c[1], c[2]],
        jacobian: reduce(&j, stuck),
        events,
        stuck_at_start: stuck,
        min_transversality: transversality,
    })
}

/// The Poincaré map alone (no Jacobian), for finite differences and Newton residuals.
pub fn map_only(scene: &Scene, x: [f64; 3], periods: usize) -> Result<[f64; 3], SimError> {
    let law = scene.law();
    let mut sim = start(scene, x, 0.0)?;
    sim.advance(&law, periods as f64 * scene.drive.period())?;
    let c = sim.core();
    Ok([c[0], c[1], c[2]])
}

/// Floquet multipliers of a periodic orbit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Floquet {
    /// The multipliers as `[re, im]`, largest modulus first.
    pub multipliers: Vec<[f64; 2]>,
    /// The largest modulus (below 1: asymptotically stable).
    pub largest_modulus: f64,
    /// Drive periods of the orbit (the map is iterated that often).
    pub period: usize,
    /// The orbit's point on the section, `[z, y1, y2]`.
    pub section_point: [f64; 3],
    /// How far the map moved the point (a check that it is on the orbit).
    pub closure: f64,
    /// Smallest transversality of an event crossing along the orbit (0 at grazing).
    pub min_transversality: f64,
    /// The events along the orbit, in order.
    pub events: Vec<EventKind>,
}

/// The Floquet multipliers of the period-`period` orbit through `x` at drive phase 0.
pub fn floquet(scene: &Scene, x: [f64; 3], period: usize) -> Result<Floquet, StabilityError> {
    let lin = poincare_map(scene, x, period)?;
    let closure = lin
        .end
        .iter()
        .zip(&x)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    let mut multipliers = crate::linear::eigenvalues3(&lin.jacobian).to_vec();
    multipliers.sort_by(|a, b| modulus(b).total_cmp(&modulus(a)));
    Ok(Floquet {
        largest_modulus: modulus(&multipliers[0]),
        multipliers,
        period,
        section_point: x,
        closure,
        min_transversality: lin.min_transversality,
        events: lin.events,
    })
}

/// `|z|` for `z = [re, im]`.
pub fn modulus(z: &[f64; 2]) -> f64 {
    z[0].hypot(z[1])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_multipliers_are_the_jacobians_eigenvalues_largest_first() {
        // the section-5 period-1 orbit at k_p = 0.1 (stable, sticks once per period)
        let mut s = Scene::default();
        s.control.kp = 0.1;
        let r = crate::run(&s).unwrap_or_else(|e| panic!("{e}"));
        let f = r.final_state;
        let fl = floquet(&s, [f.x1 - f.x2, f.y1, f.y2], 1).unwrap_or_else(|e| panic!("{e}"));
        let mods: Vec<f64> = fl.multipliers.iter().map(modulus).collect();
        assert!(mods.windows(2).all(|w| w[0] >= w[1]), "{mods:?}");
        assert_eq!(fl.largest_modulus, mods[0]);
        assert!(fl.largest_modulus < 1.0 && fl.closure < 1e-9, "{fl:?}");
        // sticking projects one direction out: a multiplier at rounding
        assert!(mods[2] < 1e-12, "{mods:?}");
    }
}
