//! The simulator: one capsule, one clock, three integration methods sharing one switching logic.
//!
//! - [`Method::Exact`]: between events the Coulomb and viscous models are linear ODEs with
//!   harmonic forcing; the flow is evaluated by its power series (the matrix exponential applied
//!   to the state, truncated below rounding, with the step bounded so the series converges fast),
//!   and events are roots of the series of each event function. Exact to rounding.
//! - [`Method::Adaptive`]: Dormand-Prince 5(4) with step-size control, dense output, located
//!   events and a history of the capsule velocity for frictional memory. Any friction law.
//! - [`Method::Fixed`]: classical RK4 with a fixed step and no event location (switches are
//!   noticed at step ends, discontinuities are stepped over): the baseline that shows what
//!   skipping event location costs.
//!
//! The regime (stick or slip and its direction, contact, side of the feedback kink) changes only
//! at events; [`Simulator`] applies the same switching rules whichever method found the event.

mod exact;
mod history;
mod rk;

use crate::equations::{self, phase_at_rest, Core, EventFn};
pub use crate::equations::{Event, EventKind, Phase, Regime, Transition};
use crate::law::{ActuatorLaw, LawShape};
use crate::model::{Model, State};
use serde::{Deserialize, Serialize};
use std::ops::ControlFlow;
use thiserror::Error;

/// Integration method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Exact piecewise solution (Coulomb and viscous friction only).
    Exact,
    /// Adaptive Dormand-Prince 5(4) with event location.
    Adaptive,
    /// Fixed-step RK4 without event location.
    Fixed,
}

impl Method {
    /// Name as used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Method::Exact => "exact",
            Method::Adaptive => "adaptive",
            Method::Fixed => "fixed",
        }
    }

    /// Every method, in the order the command line lists them.
    pub const ALL: [Method; 3] = [Method::Exact, Method::Adaptive, Method::Fixed];

    /// The method called `name` (see [`Method::name`]).
    pub fn by_name(name: &str) -> Option<Method> {
        Method::ALL.into_iter().find(|m| m.name() == name)
    }

    /// The names of all methods, `a, b or c`, for messages.
    pub fn names() -> String {
        crate::choices::one_of(Method::ALL.map(Method::name))
    }
}

/// How to integrate.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SolverConfig {
    /// The method.
    pub method: Method,
    /// Relative and absolute tolerance of the adaptive method.
    pub tol: f64,
    /// Step of the fixed method (non-dimensional time).
    pub step: f64,
}

impl SolverConfig {
    /// The most accurate method for a model: exact where the law is piecewise linear, else
    /// adaptive at a tight tolerance.
    pub fn most_accurate_for(model: &Model) -> Self {
        let method = if model.friction.is_piecewise_linear() {
            Method::Exact
        } else {
            Method::Adaptive
        };
        SolverConfig {
            method,
            tol: 1e-10,
            step: 1e-3,
        }
    }
}

/// Why a simulation cannot go on.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SimError {
    /// The exact method was asked for a law that is not piecewise linear.
    #[error("the exact method needs a piecewise-linear friction law (coulomb or viscous), not {0}; use adaptive")]
    ExactNeedsLinearLaw(&'static str),
    /// The exact method was given a force law of unknown structure.
    #[error("the exact method needs a piecewise-affine actuator law (harmonic drive, feedback, constant)")]
    ExactNeedsAffineLaw,
    /// A bad solver setting.
    #[error("solver setting {name} = {value}: {reason}")]
    BadSetting {
        /// The setting.
        name: &'static str,
        /// Its value.
        value: f64,
        /// Why it is refused.
        reason: &'static str,
    },
    /// The state became non-finite.
    #[error("the state became non-finite at tau = {tau}")]
    NonFinite {
        /// When.
        tau: f64,
    },
    /// The motion runs away: the relative displacement or a velocity passed [`RUNAWAY`]. With
    /// `|k_p| > 1` the feedback turns the spring's stiffness negative on one side of the kink.
    #[error("the motion diverges at tau = {tau} (|x1 - x2| or a velocity above {RUNAWAY:e}; with |k_p| > 1 the effective stiffness 1 - |k_p| is negative)")]
    Diverged {
        /// When.
        tau: f64,
    },
    /// Events accumulate (Zeno behaviour) and the run cannot progress.
    #[error("events accumulate at tau = {tau} ({count} switches without progress)")]
    Zeno {
        /// When.
        tau: f64,
        /// Switches counted without time advancing.
        count: u32,
    },
    /// The adaptive method left its envelope: more than [`MAX_STEPS_PER_TIME`] steps per unit
    /// of non-dimensional time (the paper's scenes take 30 to 550, at tolerances 1e-10 to 1e-13).
    #[error("the adaptive method left its envelope at tau = {tau}: {steps} steps, more than {MAX_STEPS_PER_TIME:e} per unit of time (a stiff or absurd scene: check the friction constants and the tolerance)")]
    StepEnvelope {
        /// When.
        tau: f64,
        /// Steps tried (accepted and rejected) in this advance.
        steps: u64,
    },
    /// The adaptive step size underflowed.
    #[error("step size underflow at tau = {tau}")]
    StepUnderflow {
        /// When.
        tau: f64,
    },
}

/// The adaptive method's envelope: most steps (accepted and rejected) per unit of
/// non-dimensional time, plus this many at the start of every advance.
pub const MAX_STEPS_PER_TIME: f64 = 2e4;

/// Why [`Simulator::advance_until`] (and the other advances) returned.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Stop {
    /// It reached `tau_end`.
    Horizon,
    /// The observer asked to stop at this event.
    Requested(Event),
}

/// Work done by an integrator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Work {
    /// Accepted steps.
    pub steps: u64,
    /// Rejected steps (adaptive only).
    pub rejected: u64,
    /// Right-hand-side evaluations (for the exact method: series terms, each one
    /// matrix-vector product).
    pub rhs_evals: u64,
    /// Located (or, for the fixed method, noticed) events.
    pub events: u64,
}

/// What the plant shows the world at an instant.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Time.
    pub tau: f64,
    /// Mass and capsule state.
    pub state: State,
    /// The capsule is stuck.
    pub stuck: bool,
    /// The mass touches the secondary spring.
    pub contact: bool,
    /// Friction force on the capsule (positive opposes forward motion).
    pub friction_force: f64,
    /// Force of the secondary spring (positive pushes the mass back).
    pub contact_force: f64,
    /// Actuator force applied to the mass at this instant.
    pub actuator_force: f64,
}

/// Bound on `|x1 - x2|` and the velocities beyond which a run counts as diverging.
pub const RUNAWAY: f64 = 1e8;

/// Compensated (Kahan) sum, for quantities that grow over long runs (capsule position, work).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Sum {
    hi: f64,
    lo: f64,
}

impl Sum {
    fn new(v: f64) -> Self {
        Sum { hi: v, lo: 0.0 }
    }
    fn add(&mut self, v: f64) {
        let y = v - self.lo;
        let t = self.hi + y;
        self.lo = (t - self.hi) - y;
        self.hi = t;
    }
    fn value(&self) -> f64 {
        self.hi - self.lo
    }
}

/// The capsule simulator.
#[derive(Debug, Clone)]
pub struct Simulator {
    model: Model,
    config: SolverConfig,
    tau: f64,
    core: Core,
    x2: Sum,
    regime: Regime,
    work: Work,
    actuator_work: Sum,
    track_work: bool,
    history: Option<history::History>,
    rk_step: f64,
    zeno: u32,
    last_force: f64,
}

impl Simulator {
    /// A simulator at time `tau0` in state `s0`. The regime is chosen from the state: stuck if
    /// `y2 = 0` and the spring force is below the threshold (with no actuator force yet known,
    /// the first step corrects it at once if not), in contact if `x1 - x2 >= delta`.
    pub fn new(model: Model, s0: State, tau0: f64, config: SolverConfig) -> Result<Self, SimError> {
        match config.method {
            Method::Exact if !model.friction.is_piecewise_linear() => {
                return Err(SimError::ExactNeedsLinearLaw(model.friction.name()));
            }
            Method::Adaptive if !(config.tol > 0.0 && config.tol < 1.0) => {
                return Err(SimError::BadSetting {
                    name: "tol",
                    value: config.tol,
                    reason: "must be in (0, 1)",
                });
            }
            Method::Fixed if !(config.step > 0.0 && config.step.is_finite()) => {
                return Err(SimError::BadSetting {
                    name: "step",
                    value: config.step,
                    reason: "must be positive and finite",
                });
            }
            _ => {}
        }
        for v in s0.to_array().into_iter().chain([tau0]) {
            if !v.is_finite() {
                return Err(SimError::NonFinite { tau: tau0 });
            }
        }
        let z = s0.x1 - s0.x2;
        let contact = model.has_contact() && z >= model.capsule.delta;
        let sigma = if z < 0.0 { -1.0 } else { 1.0 };
        let (phase, p) = if s0.y2 != 0.0 {
            (Phase::Slip(s0.y2.signum()), 0.0)
        } else {
            phase_at_rest(&model, model.capsule_force(z, s0.y1, s0.y2, contact))
        };
        let history = model
            .friction
            .memory_delay()
            .map(|d| history::History::new(d, tau0, s0.y2));
        Ok(Simulator {
            model,
            config,
            tau: tau0,
            core: [z, s0.y1, s0.y2, p],
            x2: Sum::new(s0.x2),
            regime: Regime {
                phase,
                contact,
                sigma,
            },
            work: Work::default(),
            actuator_work: Sum::new(0.0),
            track_work: false,
            history,
            rk_step: 0.0,
            zeno: 0,
            last_force: 0.0,
        })
    }

    /// Current time.
    pub fn time(&self) -> f64 {
        self.tau
    }

    /// Current state.
    pub fn state(&self) -> State {
        let x2 = self.x2.value();
        State {
            x1: x2 + self.core[0],
            y1: self.core[1],
            x2,
            y2: self.core[2],
        }
    }

    /// Current `[z = x1 - x2, y1, y2, p]`.
    pub fn core(&self) -> Core {
        self.core
    }

    /// Current regime.
    pub fn regime(&self) -> Regime {
        self.regime
    }

    /// The model being simulated.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// The solver settings.
    pub fn config(&self) -> &SolverConfig {
        &self.config
    }

    /// Work done so far.
    pub fn work(&self) -> Work {
        self.work
    }

    /// Start or stop accumulating the actuator's work on the mass, `integral f_a y1 dtau`.
    pub fn track_actuator_work(&mut self, on: bool) {
        self.track_work = on;
    }

    /// Actuator work accumulated while tracking was on.
    pub fn actuator_work(&self) -> f64 {
        self.actuator_work.value()
    }

    /// What the plant shows at this instant; the actuator force is the one applied at the end
    /// of the last [`Simulator::advance`] (zero before the first).
    pub fn snapshot(&self) -> Snapshot {
        let [z, y1, y2, p] = self.core;
        let state = self.state();
        let m = &self.model;
        let f = m.capsule_force(z, y1, y2, self.regime.contact);
        let friction_force = match self.regime.phase {
            Phase::Stick => match m.friction.presliding() {
                Some(ks) => ks * p,
                None => f, // static friction balances the force on the capsule
            },
            Phase::Slip(d) => {
                // without frictional memory the Stribeck term follows the current velocity
                let y2d = self.history.as_ref().map_or(y2, |h| h.delayed(self.tau));
                m.friction.sliding(d, y2, y2d)
            }
        };
        Snapshot {
            tau: self.tau,
            state,
            stuck: self.regime.phase == Phase::Stick,
            contact: self.regime.contact,
            friction_force,
            contact_force: m.contact_force(z),
            actuator_force: self.last_force,
        }
    }

    /// Integrate to `tau_end` under the actuator law `law`.
    pub fn advance(&mut self, law: &impl ActuatorLaw, tau_end: f64) -> Result<Stop, SimError> {
        self.advance_until(law, tau_end, &mut |_| ControlFlow::Continue(()))
    }

    /// Integrate to `tau_end`, calling `on_event` for every event.
    pub fn advance_observed(
        &mut self,
        law: &impl ActuatorLaw,
        tau_end: f64,
        on_event: &mut impl FnMut(&Event),
    ) -> Result<Stop, SimError> {
        self.advance_until(law, tau_end, &mut |t| {
            on_event(&t.event);
            ControlFlow::Continue(())
        })
    }

    /// Integrate to `tau_end` or until `on_event` breaks at an event (the state is then just
    /// after that event's reset); says which. Every event is handed over with the regime and
    /// state on both sides of it.
    pub fn advance_until(
        &mut self,
        law: &impl ActuatorLaw,
        tau_end: f64,
        on_event: &mut impl FnMut(&Transition) -> ControlFlow<()>,
    ) -> Result<Stop, SimError> {
        if !tau_end.is_finite() {
            return Err(SimError::NonFinite { tau: self.tau });
        }
        let result = match self.config.method {
            Method::Exact => match law.shape() {
                LawShape::PiecewiseAffine(drive) => self.advance_exact(&drive, tau_end, on_event),
                LawShape::General => Err(SimError::ExactNeedsAffineLaw),
            },
            Method::Adaptive | Method::Fixed => {
                let located = self.config.method == Method::Adaptive;
                crate::friction::with_friction!(self.model.friction, f => {
                    self.advance_rk(law, f, located, tau_end, on_event)
                })
            }
        };
        self.last_force = law.force(self.tau, &self.state());
        result
    }

    /// The event functions of the current regime; `kink` adds the feedback's `x1 = x2`.
    fn event_functions(&self, kink: bool, out: &mut Vec<EventFn>) {
        equations::events(&self.model, &self.regime, kink, out)
    }

    /// The feedback gain if the law has a kink that must be located.
    fn kink_gain(law: &impl ActuatorLaw) -> f64 {
        match law.shape() {
            LawShape::PiecewiseAffine(drive) => drive.kp,
            LawShape::General => 0.0,
        }
    }

    /// Move the clock and the capsule position after a step of length `dt` that moved the
    /// capsule by `dx2` and did actuator work `dw`.
    fn commit(&mut self, dt: f64, core: Core, dx2: f64, dw: f64) -> Result<(), SimError> {
        if !core.iter().all(|v| v.is_finite()) || !dx2.is_finite() {
            return Err(SimError::NonFinite { tau: self.tau + dt });
        }
        if core[..3].iter().any(|v| v.abs() > RUNAWAY) {
            return Err(SimError::Diverged { tau: self.tau + dt });
        }
        if dt > 1e-12 * (1.0 + self.tau.abs()) {
            self.zeno = 0;
        }
        self.tau += dt;
        self.core = core;
        self.x2.add(dx2);
        if self.track_work {
            self.actuator_work.add(dw);
        }
        Ok(())
    }

    /// Crosses event `kind` at the current state: applies its transition (the new regime and
    /// reset); returns it.
    fn cross(&mut self, kind: EventKind) -> Result<Transition, SimError> {
        self.zeno += 1;
        if self.zeno > 64 {
            return Err(SimError::Zeno {
                tau: self.tau,
                count: self.zeno,
            });
        }
        let (regime_before, core_before) = (self.regime, self.core);
        let (regime, core, kind) = equations::transition(&self.model, self.regime, self.core, kind);
        self.regime = regime;
        self.core = core;
        self.work.events += 1;
        if let Some(h) = self.history.as_mut() {
            h.breakpoint(self.tau);
        }
        Ok(Transition {
            event: Event {
                tau: self.tau,
                kind,
            },
            regime_before,
            before: core_before,
            regime_after: regime,
            after: core,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compensated_sum_keeps_small_increments_on_a_large_value() {
        let mut s = Sum::new(1e8);
        for _ in 0..1_000_000 {
            s.add(1e-9);
        }
        assert!(
            (s.value() - (1e8 + 1e-3)).abs() < 1e-8,
            "{}",
            s.value() - 1e8
        );
    }
}
