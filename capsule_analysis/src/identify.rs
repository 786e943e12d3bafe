//! Identification: the free numbers of a scene that make its capsule, driven by a recorded
//! force, reproduce the recorded positions.
//!
//! The method (impacts and stick-slip make a fit over the whole record hopeless: a small change
//! of a parameter moves an impact, and after a few periods the response has nothing to do with
//! the parameter any more):
//!
//! - The recording is cut into windows of one drive period. Each window restarts the twin
//!   from a state of its own, fitted to the window's positions (four nuisance numbers per
//!   window: the device measures positions only, and a restart from a noisy measured position
//!   and a differentiated velocity would put the noise into the parameters).
//! - The free keys and the measurement delay are fitted to all windows together by
//!   Levenberg-Marquardt (`levenberg-marquardt`) on the residuals with the window states
//!   projected out (variable projection, Kaufman's Jacobian: `(I - J_s J_s^+) J_p` per window,
//!   `J_s` and `J_p` by forward differences of the exact simulator). A key with a positive
//!   nominal value is fitted in a smooth bounded log coordinate (`Free::value`): relative
//!   changes, and no clamp for a step to die in.
//! - The twin measures what the device's sensor sends on average (`twin::SensorPick`: where the
//!   reading's age is a coin toss between two samples, the mean of both). Where the age varies,
//!   a second stage refits with each residual weighted by the error that variation gives it
//!   (the capsule's speed times the spread of the age, `pick_weights`), from the first stage's
//!   twin: the slow samples (turning points on the stop, the stuck shell) carry the gap. Where
//!   the age is a coin toss between readings, the second stage fits the mixture instead
//!   (`mixture`): each measurement is the capsule at one of the pick's delays, the same on both
//!   channels, weighed by how likely each is given the data (expectation-maximisation).
//! - Uncertainty: the standard error from the projected Jacobian at the optimum, as a
//!   cluster-robust ("sandwich") estimate with the windows as clusters,
//!   `A^-1 (sum_w J_w^T r_w r_w^T J_w) A^-1` with `A = J^T J`: the residuals within a window are
//!   correlated (jitter, the delay's jumps, what the twin lacks) and their spread varies with
//!   the speed, which the textbook `(J^T J)^-1 sigma^2` assumes away; the larger of the two is
//!   reported.
//! - Identifiability: the correlation matrix of the estimates, and the singular values of the
//!   column-scaled Jacobian; a pair correlated beyond 0.95, or a direction whose singular value
//!   is under 1e-3 of the largest, is reported in words and its numbers are not.

use crate::twin::{
    fit_window, state_jacobian, window_samples, windows, Forcing, Recorded, SensorPick, Twin,
    Weights,
};
use capsule_plant::scene::{KeyError, Scene};
use capsule_plant::State;
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt, MinimizationReport};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn};
use rayon::prelude::*;
use serde::Serialize;
use std::sync::OnceLock;
use thiserror::Error;

/// Keys whose numbers the twin uses (the drive, the control gain, the solver and the device's
/// sensor are not: the force is recorded, the device is taken as the scene describes it).
const TWIN_TABLES: [&str; 3] = ["capsule.", "friction.", "physical."];

/// A free value stays within this factor of its nominal value; ending at the bound is refused.
pub const BOUND_FACTOR: f64 = 4.0;

/// Windows needed per fitted number (the free keys and the delay).
pub const WINDOWS_PER_NUMBER: usize = 5;

/// Correlation beyond which two estimates are reported as not told apart (where it leaves
/// either loose: [`TOLD`]).
pub const STRONG_CORRELATION: f64 = 0.95;

/// A strongly correlated pair is still told apart where the standard error of each is under
/// this fraction of its value: the correlation widens the standard errors (they are the
/// marginal ones), and a value known within 10 % is known. The capsule (1.25, 1.2, 0.8, 0.8)
/// had beta and delta correlated at +0.975 and fitted within 0.02 % and 1 % of the truth,
/// with standard errors of 0.2 % and 4 %: reported as not told apart before. The measurement
/// delay is told where its standard error is under this fraction of a sample.
pub const TOLD: f64 = 0.1;

/// Singular value (of the column-scaled Jacobian, relative to the largest) under which a
/// direction is reported as flat.
pub const FLAT: f64 = 1e-3;

/// How to identify.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Window length in drive periods of the nominal scene.
    pub window_periods: f64,
    /// Levenberg-Marquardt's patience: at most this many evaluations per fitted number + 1.
    pub patience: usize,
    /// Where the sensor's pick is a coin toss between readings, fit the mixture of its delays
    /// (`mixture`) instead of weighting the residuals of their mean.
    pub mixture: bool,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            window_periods: 1.0,
            patience: 30,
            mixture: true,
        }
    }
}

/// Why an identification is refused or failed.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum IdentifyError {
    /// A free key names no number of the scene.
    #[error("--free {0}")]
    Key(#[from] KeyError),
    /// A free key the twin does not use.
    #[error("--free {0}: the twin driven by the recorded force does not use it (free keys: capsule.*, friction.<constant>, physical.*)")]
    NotInTwin(String),
    /// A key given twice.
    #[error("--free {0}: given twice")]
    Twice(String),
    /// No key.
    #[error("--free: no key given")]
    NoKeys,
    /// No measured positions.
    #[error("the recording has no measured positions (x1 - x2 and x2)")]
    NoPositions,
    /// Too few windows for the numbers asked.
    #[error("the recording is too short for {numbers} fitted numbers ({keys} keys and the delay): {windows} windows of {samples} samples (one drive period), at least {needed} needed ({per} per number); record longer or free fewer keys")]
    TooShort {
        /// Free keys.
        keys: usize,
        /// Keys and the delay.
        numbers: usize,
        /// Windows found.
        windows: usize,
        /// Samples per window.
        samples: usize,
        /// Windows needed.
        needed: usize,
        /// Per number.
        per: usize,
    },
    /// The fit did not converge.
    #[error("the fit did not converge ({0}); try a nominal scene closer to the device, fewer free keys or a longer recording")]
    NoConvergence(String),
    /// A value ended at its bound.
    #[error("{key} ended at its bound {bound} (nominal {nominal}, bounds within a factor {BOUND_FACTOR}): the data push it out of the range a fit can trust; check the nominal scene and the recording's units")]
    Pinned {
        /// The key.
        key: String,
        /// The bound.
        bound: f64,
        /// The nominal value.
        nominal: f64,
    },
    /// The fitted scene is not a valid scene.
    #[error("the fitted scene is refused: {0}")]
    Invalid(String),
}

/// A free key: its nominal value and the range it may take.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Free {
    /// The key, as in a scene file.
    pub key: String,
    /// The nominal scene's value.
    pub nominal: f64,
    /// Lower bound.
    pub lo: f64,
    /// Upper bound.
    pub hi: f64,
}

/// How close (as a fraction of the log-range) to a bound a fitted value counts as pinned.
const PINNED: f64 = 0.01;

impl Free {
    /// Whether the key is fitted in the smooth bounded log coordinate (a positive nominal).
    fn logarithmic(&self) -> bool {
        self.nominal > 0.0
    }

    /// The value at coordinate `u`. A positive nominal: `nominal exp(L tanh(u / L))`,
    /// `L = ln BOUND_FACTOR`, i.e. relative changes near the nominal value and the bounds
    /// approached smoothly: a clamp would give a step outside the bounds a zero derivative,
    /// and Levenberg-Marquardt never comes back from there (what pinned delta at its bound
    /// after the first step from a nominal scene 25 % off). Otherwise the value itself, clamped.
    fn value(&self, u: f64) -> f64 {
        if self.logarithmic() {
            let l = BOUND_FACTOR.ln();
            self.nominal * (l * (u / l).tanh()).exp()
        } else {
            u.clamp(self.lo, self.hi)
        }
    }

    /// The coordinate of the nominal value.
    fn start(&self) -> f64 {
        if self.logarithmic() {
            0.0
        } else {
            self.nominal
        }
    }

    /// `d value / d u` at `u`.
    fn slope(&self, u: f64) -> f64 {
        if self.logarithmic() {
            let c = (u / BOUND_FACTOR.ln()).cosh();
            self.value(u) / (c * c)
        } else {
            1.0
        }
    }

    /// The bound `value` ended at, if it did.
    fn pinned(&self, value: f64) -> Option<f64> {
        if self.logarithmic() {
            let l = BOUND_FACTOR.ln();
            let r = (value / self.nominal).ln();
            (l - r.abs() <= PINNED * l).then_some(if r > 0.0 { self.hi } else { self.lo })
        } else {
            [self.lo, self.hi]
                .into_iter()
                .find(|b| (value - b).abs() <= 1e-6 * (self.hi - self.lo))
        }
    }
}

/// The free keys of `scene` named in `keys`, checked.
pub fn free_keys(scene: &Scene, keys: &[String]) -> Result<Vec<Free>, IdentifyError> {
    if keys.is_empty() {
        return Err(IdentifyError::NoKeys);
    }
    let mut out: Vec<Free> = Vec::new();
    for key in keys {
        let nominal = scene.number(key)?;
        if !TWIN_TABLES.iter().any(|t| key.starts_with(t)) {
            return Err(IdentifyError::NotInTwin(key.clone()));
        }
        if out.iter().any(|f| &f.key == key) {
            return Err(IdentifyError::Twice(key.clone()));
        }
        let (lo, hi) = if nominal > 0.0 {
            (nominal / BOUND_FACTOR, nominal * BOUND_FACTOR)
        } else {
            (0.0, 1.0)
        };
        out.push(Free {
            key: key.clone(),
            nominal,
            lo,
            hi,
        });
    }
    Ok(out)
}

/// One fitted number.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Estimate {
    /// The key (`delay_s` for the measurement delay).
    pub key: String,
    /// The nominal value.
    pub nominal: f64,
    /// The fitted value; `None` where the data cannot tell it (see `statement`).
    pub value: Option<f64>,
    /// Standard error (one sigma): the larger of the cluster-robust and the textbook one.
    pub std_error: Option<f64>,
    /// The textbook standard error `sqrt(sigma^2 (J^T J)^-1)`, for comparison.
    pub textbook_std_error: f64,
    /// The fitted value (also where not identified), for the record.
    pub raw_value: f64,
    /// Why no number, in words.
    pub statement: Option<String>,
}

/// What an identification found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// The free keys, in the order given.
    pub parameters: Vec<Estimate>,
    /// The mean measurement delay (measurement `k` is the capsule at `t_k - delay`, averaged
    /// over the sensor's pick; nominal: the pick's mean for the scene's `[device]`): fitted,
    /// not written to the scene.
    pub delay: Estimate,
    /// RMS of the position residuals (`x1 - x2` and `x2` together) \[m\].
    pub residual_rms_m: f64,
    /// Of `x1 - x2` alone \[m\].
    pub residual_rms_displacement_m: f64,
    /// Of `x2` alone \[m\].
    pub residual_rms_capsule_m: f64,
    /// Windows fitted.
    pub windows: usize,
    /// Samples per window.
    pub window_samples: usize,
    /// Positions compared.
    pub residuals: usize,
    /// Evaluations of the windows (a first of two stages evaluates a part of them).
    pub evaluations: usize,
    /// Why the optimiser stopped.
    pub termination: String,
    /// Correlation of the estimates (keys, then the delay).
    pub correlation: Vec<Vec<f64>>,
    /// Singular values of the column-scaled Jacobian, relative to the largest.
    pub singular_values: Vec<f64>,
    /// What the data cannot tell apart, in words (empty: everything identified).
    pub statements: Vec<String>,
    /// How the uncertainty is computed.
    pub uncertainty: String,
}

/// A scene fitted to a recording.
#[derive(Debug, Clone)]
pub struct Identified {
    /// The nominal scene with the fitted values (nominal where not identified).
    pub scene: Scene,
    /// The mean measurement delay fitted \[s\] (the twin spreads it as the sensor picks).
    pub delay_s: f64,
    /// The report.
    pub report: Report,
}

/// The outer problem: the free numbers (scaled) and the delay (in samples).
struct Outer<'a> {
    base: &'a Scene,
    free: &'a [Free],
    forcing: &'a Forcing,
    pick: &'a SensorPick,
    weights: Option<Weights>,
    rec: &'a Recorded,
    starts: &'a [usize],
    n: usize,
    p: DVector<f64>,
    states: Vec<State>,
    /// The window states of the best parameters so far and their sum of squares: every trial
    /// starts its windows from them (a rejected wild trial must not move the next one's start).
    best: Option<(f64, Vec<State>)>,
    res: Vec<Vec<f64>>,
    evaluations: usize,
    jac: OnceLock<DMatrix<f64>>,
}

impl Outer<'_> {
    /// The twin of `scene` and `delay_s` on this recording, weighted as the fit is (`weighted`)
    /// or not.
    fn twin<'s>(&'s self, scene: &'s Scene, delay_s: f64, weighted: bool) -> Twin<'s> {
        Twin {
            scene,
            forcing: self.forcing,
            pick: self.pick,
            weights: self.weights.as_ref().filter(|_| weighted),
            delay_s,
        }
    }

    /// The scene and delay of parameters `p` (clamped to the bounds).
    fn candidate(&self, p: &DVector<f64>) -> (Scene, f64) {
        let mut s = self.base.clone();
        for (i, f) in self.free.iter().enumerate() {
            let v = f.value(p[i]);
            // every free key was read from this scene: setting it cannot fail
            let _ = s.set_number(&f.key, v);
        }
        let h = self.rec.h_s;
        let delay = (p[self.free.len()] * h).clamp(-2.0 * h, 100.0 * h);
        (s, delay)
    }
}

impl LeastSquaresProblem<f64, Dyn, Dyn> for Outer<'_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, Dyn>;
    type ParameterStorage = Owned<f64, Dyn>;

    fn set_params(&mut self, x: &DVector<f64>) {
        self.p = x.clone();
        self.jac = OnceLock::new();
        self.evaluations += 1;
        let (scene, delay_s) = self.candidate(x);
        let twin = self.twin(&scene, delay_s, true);
        let (rec, n) = (self.rec, self.n);
        let from = self.best.as_ref().map_or(&self.states, |b| &b.1);
        let fits: Vec<_> = self
            .starts
            .par_iter()
            .zip(from.par_iter())
            .map(|(a, s)| fit_window(&twin, rec, *a, n, *s))
            .collect();
        self.states = fits.iter().map(|f| f.state).collect();
        self.res = fits.into_iter().map(|f| f.residuals).collect();
        let ss: f64 = self.res.iter().flatten().map(|r| r * r).sum();
        if self.best.as_ref().is_none_or(|b| ss < b.0) {
            self.best = Some((ss, self.states.clone()));
        }
    }

    fn params(&self) -> DVector<f64> {
        self.p.clone()
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(DVector::from_iterator(
            self.res.iter().map(Vec::len).sum(),
            self.res.iter().flatten().copied(),
        ))
    }

    fn jacobian(&self) -> Option<DMatrix<f64>> {
        Some(self.jac.get_or_init(|| self.projected_jacobian()).clone())
    }
}

/// Levenberg-Marquardt's relative tolerances (sum of squares, parameters) of the fit: the
/// window states are refitted at each evaluation, which leaves the sum of squares rough at
/// about 1e-7 of itself; below 1e-6 the evaluations moved the parameters by under 1 % of their
/// standard errors (ftol 1e-10 and xtol 1e-8 took 17 evaluations for what 11 found).
const TOLERANCE: f64 = 1e-6;

/// The same for the first, unweighted stage where a second one follows: it needs only to
/// bring the second near.
const FIRST_TOLERANCE: f64 = 1e-4;

/// The first stage fits every this many windows (fewer where the recording is short: at least
/// twice the windows the numbers need): it needs only to bring the second near, and its
/// standard errors at a quarter of the windows, twice the final ones, are well inside the
/// second stage's reach.
const FIRST_EVERY: usize = 4;

/// Forward-difference step of the scaled parameters.
const PARAM_STEP: f64 = 1e-6;

impl Outer<'_> {
    /// Kaufman's Jacobian of the projected residuals, window by window.
    fn projected_jacobian(&self) -> DMatrix<f64> {
        let np = self.p.len();
        let (base_scene, base_delay) = self.candidate(&self.p);
        let blocks: Vec<DMatrix<f64>> = self
            .starts
            .par_iter()
            .zip(self.states.par_iter().zip(self.res.par_iter()))
            .map(|(a, (s, r0))| {
                let twin = self.twin(&base_scene, base_delay, true);
                let js = state_jacobian(&twin, self.rec, *a, self.n, *s, Some(r0));
                let mut jp = DMatrix::zeros(r0.len(), np);
                for c in 0..np {
                    let mut p = self.p.clone();
                    let step = PARAM_STEP * p[c].abs().max(1.0);
                    p[c] += step;
                    let (scene, delay_s) = self.candidate(&p);
                    let t = self.twin(&scene, delay_s, true);
                    let r = t.residuals(self.rec, *a, self.n, *s);
                    for (i, (ri, r0i)) in r.iter().zip(r0).enumerate() {
                        jp[(i, c)] = (ri - r0i) / step;
                    }
                }
                // project out the window's state: (I - J_s J_s^+) J_p
                let js = DMatrix::from_iterator(js.nrows(), 4, js.iter().copied());
                match js.clone().svd(true, true).solve(&jp, 1e-12) {
                    Ok(x) => &jp - js * x,
                    Err(_) => jp,
                }
            })
            .collect();
        let rows: usize = blocks.iter().map(|b| b.nrows()).sum();
        let mut j = DMatrix::zeros(rows, np);
        let mut at = 0;
        for b in blocks {
            j.view_mut((at, 0), (b.nrows(), np)).copy_from(&b);
            at += b.nrows();
        }
        j
    }
}

/// The first stage's fit over every window (it fitted every `step`-th): the windows' states, the
/// fitted ones where it had them, the guesses elsewhere, at the first stage's parameters.
fn all_windows<'a>(
    mut first: Outer<'a>,
    starts: &'a [usize],
    guesses: &[State],
    step: usize,
) -> Outer<'a> {
    let fitted_states = std::mem::take(&mut first.states);
    let mut all = Outer {
        starts,
        states: guesses
            .iter()
            .enumerate()
            .map(|(i, s)| {
                fitted_states
                    .get(i / step)
                    .filter(|_| i % step == 0)
                    .unwrap_or(s)
            })
            .copied()
            .collect(),
        best: None,
        jac: OnceLock::new(),
        ..first
    };
    let p = all.p.clone();
    all.set_params(&p);
    all
}

/// Fits `keys` of `scene` to `rec` (the scene's `[device]` as the actuator, ideal without one).
pub fn identify(
    scene: &Scene,
    rec: &Recorded,
    keys: &[String],
    settings: &Settings,
) -> Result<Identified, IdentifyError> {
    let free = free_keys(scene, keys)?;
    let (n, starts) = checked_windows(scene, rec, free.len(), settings)?;
    let forcing = Forcing::new(rec, scene.device.as_ref());
    let pick = SensorPick::new(scene.device.as_ref(), rec.h_s);
    let delay0 = pick.mean_delay_s();
    let mut p0: Vec<f64> = free.iter().map(Free::start).collect();
    p0.push(delay0 / rec.h_s);
    let twin0 = Twin {
        scene,
        forcing: &forcing,
        pick: &pick,
        weights: None,
        delay_s: delay0,
    };
    let half = (n / 16).max(3);
    let states: Vec<State> = starts.iter().map(|a| twin0.guess(rec, *a, half)).collect();
    // where the reading's age varies, its error grows with the capsule's speed: a second stage
    // weights the residuals by it, from the first stage's twin; the first only brings the
    // second near, and a part of the windows does for it
    let two_stages = pick.spreads();
    let needed = WINDOWS_PER_NUMBER * (free.len() + 1);
    let step = if two_stages {
        (starts.len() / (2 * needed)).clamp(1, FIRST_EVERY)
    } else {
        1
    };
    let first_starts: Vec<usize> = starts.iter().step_by(step).copied().collect();
    let outer = Outer {
        base: scene,
        free: &free,
        forcing: &forcing,
        pick: &pick,
        weights: None,
        rec,
        starts: &first_starts,
        n,
        p: DVector::from_vec(p0),
        states: states.iter().step_by(step).copied().collect(),
        best: None,
        res: Vec::new(),
        evaluations: 0,
        jac: OnceLock::new(),
    };
    let first = if two_stages {
        FIRST_TOLERANCE
    } else {
        TOLERANCE
    };
    let (mut outer, mut report) = minimise(outer, &free, settings, first)?;
    if two_stages {
        let all = all_windows(outer, &starts, &states, step);
        let noise_m = scene.device.map_or(0.0, |d| {
            (d.noise_m * d.noise_m + d.quantum_m * d.quantum_m / 12.0).sqrt()
        });
        (outer, report) = if settings.mixture && pick.count() > 1 {
            mixture(all, &free, settings, noise_m)?
        } else {
            let weights = pick_weights(&all, noise_m);
            minimise(reweighted(all, weights), &free, settings, TOLERANCE)?
        };
    }
    let (fitted, delay_s) = outer.candidate(&outer.p);
    let report = summarise(
        &outer,
        &free,
        &fitted,
        delay_s,
        format!("{:?}", report.termination),
    );
    let mut scene = fitted;
    for e in &report.parameters {
        if e.value.is_none() {
            let _ = scene.set_number(&e.key, e.nominal);
        }
    }
    scene
        .validate()
        .map_err(|e| IdentifyError::Invalid(e.to_string()))?;
    Ok(Identified {
        scene,
        delay_s,
        report,
    })
}

/// The window length and the windows of `rec`, refused where it measured nothing or has too
/// few windows for `keys` free keys and the delay.
fn checked_windows(
    scene: &Scene,
    rec: &Recorded,
    keys: usize,
    settings: &Settings,
) -> Result<(usize, Vec<usize>), IdentifyError> {
    if !(0..rec.len()).any(|k| rec.measured(k)) {
        return Err(IdentifyError::NoPositions);
    }
    let n = window_samples(scene, rec.h_s, settings.window_periods);
    let starts = windows(rec, n);
    let numbers = keys + 1;
    let needed = WINDOWS_PER_NUMBER * numbers;
    if starts.len() < needed {
        return Err(IdentifyError::TooShort {
            keys,
            numbers,
            windows: starts.len(),
            samples: n,
            needed,
            per: WINDOWS_PER_NUMBER,
        });
    }
    Ok((n, starts))
}

/// The residuals of every window without the weights, \[m\].
fn residuals_in_metres(outer: &Outer, fitted: &Scene, delay_s: f64) -> Vec<Vec<f64>> {
    let raw = outer.twin(fitted, delay_s, false);
    outer
        .starts
        .par_iter()
        .zip(outer.states.par_iter())
        .map(|(a, s)| raw.residuals(outer.rec, *a, outer.n, *s))
        .collect()
}

/// Levenberg-Marquardt on `outer` from its parameters to a relative change of `tolerance` (of
/// the sum of squares and of the parameters); refused where it did not converge or a value
/// ended at its bound.
fn minimise<'a>(
    mut outer: Outer<'a>,
    free: &[Free],
    settings: &Settings,
    tolerance: f64,
) -> Result<(Outer<'a>, MinimizationReport<f64>), IdentifyError> {
    let p = outer.p.clone();
    outer.set_params(&p);
    let (outer, report) = LevenbergMarquardt::new()
        .with_ftol(tolerance)
        .with_xtol(tolerance)
        .with_gtol(1e-10)
        .with_patience(settings.patience)
        .minimize(outer);
    let (fitted, _) = outer.candidate(&outer.p);
    for f in free {
        let v = fitted.number(&f.key)?;
        if let Some(bound) = f.pinned(v) {
            return Err(IdentifyError::Pinned {
                key: f.key.clone(),
                bound,
                nominal: f.nominal,
            });
        }
    }
    if !report.termination.was_successful() {
        return Err(IdentifyError::NoConvergence(format!(
            "{:?} after {} evaluations",
            report.termination, outer.evaluations
        )));
    }
    Ok((outer, report))
}

/// `outer` with `weights`, its fit to be redone.
fn reweighted(outer: Outer<'_>, weights: Weights) -> Outer<'_> {
    Outer {
        weights: Some(weights),
        best: None,
        jac: OnceLock::new(),
        ..outer
    }
}

/// Most rounds of expectation-maximisation over the sensor's pick.
const MIXTURE_ROUNDS: usize = 4;

/// The rounds stop once no scaled parameter moved by more than this (a relative change of
/// 1e-3 of a key; a thousandth of a sample of the delay).
const MIXTURE_MOVE: f64 = 1e-3;

/// Where the reading's age is a coin toss between samples (the typical device's 2 or 3 ms):
/// the measurement is the capsule at one of the pick's delays, not their mean, the same on both
/// channels. Expectation-maximisation: each round weighs, for every sample, how likely each
/// delay is given the measurement and the fitted twin (`mixture_weights`), then refits with
/// each delay's residuals weighted by that (a weighted least squares whose optimum is the
/// maximum of the mixture's likelihood once the rounds settle).
fn mixture<'a>(
    mut outer: Outer<'a>,
    free: &[Free],
    settings: &Settings,
    noise_m: f64,
) -> Result<(Outer<'a>, MinimizationReport<f64>), IdentifyError> {
    let mut round = 0;
    loop {
        let before = outer.p.clone();
        let weights = mixture_weights(&outer, noise_m);
        let report;
        (outer, report) = minimise(reweighted(outer, weights), free, settings, TOLERANCE)?;
        round += 1;
        let moved = (&outer.p - before).amax();
        if round >= MIXTURE_ROUNDS || moved < MIXTURE_MOVE {
            return Ok((outer, report));
        }
    }
}

/// The mixture's weights from `outer`'s fit: per sample and delay of the pick, the probability
/// that the measurement is the capsule at that delay (its prior times a Gaussian likelihood of
/// both channels with the noise and the jitter's variance), and per channel
/// `floor / sqrt(floor^2 + jitter variance)` (`floor` as in [`pick_weights`]).
fn mixture_weights(outer: &Outer, noise_m: f64) -> Weights {
    let (scene, delay_s) = outer.candidate(&outer.p);
    let twin = outer.twin(&scene, delay_s, false);
    let per = twin.pick_count();
    let prior = outer.pick.probabilities();
    let runs: Vec<(usize, Vec<[f64; 2]>)> = outer
        .starts
        .par_iter()
        .zip(outer.states.par_iter())
        .filter_map(|(a, s)| Some((*a, twin.picks(*a, outer.n, *s).ok()?.0)))
        .collect();
    let (sum, count) = runs
        .iter()
        .flat_map(|(_, p)| twin.pick_variances(p).0)
        .fold((0.0, 0usize), |(s, c), v| (s + v[0] + v[1], c + 2));
    let floor = noise_m.max(0.1 * (sum / count.max(1) as f64).sqrt());
    let rec = outer.rec;
    let mut w = Weights {
        channels: vec![[1.0; 2]; rec.len()],
        picks: prior
            .iter()
            .copied()
            .cycle()
            .take(per * rec.len())
            .collect(),
    };
    if floor <= 0.0 {
        return w;
    }
    for (a, picks) in runs {
        let (_, within) = twin.pick_variances(&picks);
        for (i, at) in picks.chunks(per).enumerate() {
            let k = a + i;
            let var = within[i].map(|v| floor * floor + v);
            w.channels[k] = var.map(|v| floor / v.sqrt());
            let meas = [rec.rel_m[k], rec.x2_m[k]];
            let log: Vec<f64> = at
                .iter()
                .zip(&prior)
                .map(|(x, p)| {
                    let d: f64 = (0..2)
                        .filter(|c| meas[*c].is_finite())
                        .map(|c| (x[c] - meas[c]).powi(2) / var[c])
                        .sum();
                    p.ln() - 0.5 * d
                })
                .collect();
            let top = log.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            let e: Vec<f64> = log.iter().map(|l| (l - top).exp()).collect();
            let total: f64 = e.iter().sum();
            if total.is_finite() && total > 0.0 {
                for (j, v) in e.iter().enumerate() {
                    w.picks[k * per + j] = v / total;
                }
            }
        }
    }
    w
}

/// Weights of the residuals, per sample of the recording: `floor / sqrt(floor^2 + var)`, `var`
/// the variance the reading's age gives the measurement (the fitted twin's positions over the
/// pick's delays, [`Twin::spread`]), `floor` the sensor's noise but at least a tenth of the
/// RMS spread (a noiseless sensor would weigh the standstills a million times the motion).
/// From the twin, not from the data: weights made from the measured positions carry their
/// noise and biased delta by 2 standard errors.
fn pick_weights(outer: &Outer, noise_m: f64) -> Weights {
    let (scene, delay_s) = outer.candidate(&outer.p);
    let twin = outer.twin(&scene, delay_s, false);
    let spreads: Vec<(usize, Vec<[f64; 2]>)> = outer
        .starts
        .par_iter()
        .zip(outer.states.par_iter())
        .filter_map(|(a, s)| Some((*a, twin.spread(*a, outer.n, *s).ok()?)))
        .collect();
    let (sum, count) = spreads
        .iter()
        .flat_map(|(_, v)| v.iter().flatten())
        .fold((0.0, 0usize), |(s, c), v| (s + v, c + 1));
    let floor = noise_m.max(0.1 * (sum / count.max(1) as f64).sqrt());
    let mut w = vec![[1.0; 2]; outer.rec.len()];
    if floor > 0.0 {
        for (a, v) in spreads {
            for (i, var) in v.iter().enumerate() {
                w[a + i] = var.map(|x| floor / (floor * floor + x).sqrt());
            }
        }
    }
    Weights {
        channels: w,
        picks: Vec::new(),
    }
}

/// Sums of squared residuals at the optimum: all, of the displacement `x1 - x2` (even rows),
/// of the capsule (odd rows), and how many residuals are not zero.
fn residual_sums(res: &[Vec<f64>]) -> (f64, f64, f64, usize) {
    let (mut ss, mut ss_rel, mut ss_x2, mut count) = (0.0, 0.0, 0.0, 0usize);
    for w in res {
        for (i, r) in w.iter().enumerate() {
            if *r != 0.0 {
                count += 1;
            }
            ss += r * r;
            if i % 2 == 0 {
                ss_rel += r * r;
            } else {
                ss_x2 += r * r;
            }
        }
    }
    (ss, ss_rel, ss_x2, count.max(1))
}

/// The textbook `sigma^2 (J^T J)^-1` and the cluster-robust (sandwich, windows as clusters)
/// covariances of the estimates.
fn covariances(
    outer: &Outer,
    j: &DMatrix<f64>,
    ss: f64,
    count: usize,
) -> (DMatrix<f64>, DMatrix<f64>) {
    let np = j.ncols();
    let windows = outer.starts.len();
    let dof = count.saturating_sub(np + 4 * windows).max(1);
    let sigma2 = ss / dof as f64;
    let a = j.transpose() * j;
    let ainv = a
        .clone()
        .pseudo_inverse(1e-14 * a.norm())
        .unwrap_or_else(|_| DMatrix::zeros(np, np));
    let mut meat = DMatrix::zeros(np, np);
    let mut at = 0;
    for w in &outer.res {
        let jw = j.rows(at, w.len());
        let g = jw.transpose() * DVector::from_column_slice(w);
        meat += &g * g.transpose();
        at += w.len();
    }
    let correction = windows as f64 / (windows as f64 - 1.0).max(1.0) * count as f64 / dof as f64;
    let robust = &ainv * meat * &ainv * correction;
    let textbook = &ainv * sigma2;
    (textbook, robust)
}

/// The correlation matrix of a covariance.
fn correlation_of(cov: &DMatrix<f64>) -> Vec<Vec<f64>> {
    let np = cov.ncols();
    (0..np)
        .map(|r| {
            (0..np)
                .map(|c| {
                    let d = (cov[(r, r)] * cov[(c, c)]).sqrt();
                    if d > 0.0 {
                        cov[(r, c)] / d
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect()
}

/// What the data cannot tell: plain statements, which estimates they leave unknown, and the
/// column-scaled Jacobian's singular values relative to the largest, largest first.
fn identifiability(
    j: &DMatrix<f64>,
    correlation: &[Vec<f64>],
    relative: &[f64],
    name: &dyn Fn(usize) -> String,
) -> (Vec<String>, Vec<bool>, Vec<f64>) {
    let np = j.ncols();
    // column-scaled Jacobian: its singular values say which directions the data fix
    let norms: Vec<f64> = (0..np).map(|c| j.column(c).norm()).collect();
    let scaled = DMatrix::from_fn(j.nrows(), np, |r, c| {
        if norms[c] > 0.0 {
            j[(r, c)] / norms[c]
        } else {
            0.0
        }
    });
    let svd = scaled.svd(false, true);
    let smax = svd.singular_values.max().max(f64::MIN_POSITIVE);
    let mut order: Vec<usize> = (0..np).collect();
    order.sort_by(|x, y| svd.singular_values[*y].total_cmp(&svd.singular_values[*x]));
    let singular_values: Vec<f64> = order
        .iter()
        .map(|i| svd.singular_values[*i] / smax)
        .collect();
    let mut statements = Vec::new();
    let mut unknown = vec![false; np];
    for (i, norm) in norms.iter().enumerate() {
        if *norm == 0.0 {
            statements.push(format!(
                "{} changes nothing the device measured: the recording cannot tell its value",
                name(i)
            ));
            unknown[i] = true;
        }
    }
    for r in 0..np {
        for c in r + 1..np {
            let rho = correlation[r][c];
            // a strong correlation is in the standard errors (each is the marginal one): the
            // pair is not told apart where it leaves either of them loose
            let loose = !(relative[r] <= TOLD && relative[c] <= TOLD);
            if rho.abs() > STRONG_CORRELATION && loose {
                statements.push(format!(
                    "{} and {} cannot be told apart from this recording (correlation {rho:+.3}): the data fix a combination of them, not each; free one of them only, or record a run that moves them differently",
                    name(r),
                    name(c)
                ));
                unknown[r] = true;
                unknown[c] = true;
            }
        }
    }
    if let Some(vt) = svd.v_t.as_ref() {
        for (k, i) in order.iter().enumerate() {
            if singular_values[k] < FLAT {
                let row = vt.row(*i);
                let parts: Vec<String> = (0..np)
                    .filter(|c| row[*c].abs() > 0.1)
                    .map(|c| {
                        unknown[c] = true;
                        format!("{:+.2} {}", row[c], name(c))
                    })
                    .collect();
                statements.push(format!(
                    "the data leave a direction flat (relative singular value {:.1e}): {} can change together without changing the fit",
                    singular_values[k],
                    parts.join(" ")
                ));
            }
        }
    }
    (statements, unknown, singular_values)
}

/// The report at the optimum: estimates, uncertainties, identifiability.
fn summarise(
    outer: &Outer,
    free: &[Free],
    fitted: &Scene,
    delay_s: f64,
    termination: String,
) -> Report {
    let j = outer.projected_jacobian();
    let np = j.ncols();
    let (ss, _, _, rows) = residual_sums(&outer.res);
    // the mixture has a row per delay of the pick for each measurement
    let per = match &outer.weights {
        Some(w) if !w.picks.is_empty() => outer.pick.count(),
        _ => 1,
    };
    let count = (rows / per).max(1);
    let (ss_m, ss_rel, ss_x2, _) = residual_sums(&residuals_in_metres(outer, fitted, delay_s));
    let (textbook, robust) = covariances(outer, &j, ss, count);
    // correlations from the robust estimate (the textbook one where it is degenerate)
    let cov = if (0..np).all(|i| robust[(i, i)] > 0.0) {
        &robust
    } else {
        &textbook
    };
    let sd: Vec<f64> = (0..np)
        .map(|i| robust[(i, i)].max(textbook[(i, i)]).max(0.0).sqrt())
        .collect();
    let correlation = correlation_of(cov);
    let name = |i: usize| {
        if i < free.len() {
            free[i].key.clone()
        } else {
            "the measurement delay".to_string()
        }
    };
    // each estimate's standard error relative to its value; the delay's in samples (its value
    // is zero for an ideal sensor, which made it loose however well known, and withheld every
    // key correlated with it)
    let relative: Vec<f64> = (0..np)
        .map(|i| match free.get(i) {
            Some(f) => {
                sd[i] * f.slope(outer.p[i]) / fitted.number(&f.key).unwrap_or(f64::NAN).abs()
            }
            None => sd[i],
        })
        .collect();
    let (statements, unknown, singular_values) =
        identifiability(&j, &correlation, &relative, &name);
    let estimate = |i: usize, key: String, nominal: f64, value: f64, scale: f64| Estimate {
        key,
        nominal,
        value: (!unknown[i]).then_some(value),
        std_error: (!unknown[i]).then_some(sd[i] * scale),
        textbook_std_error: textbook[(i, i)].max(0.0).sqrt() * scale,
        raw_value: value,
        statement: unknown[i].then(|| {
            statements
                .iter()
                .find(|s| s.contains(&name(i)))
                .cloned()
                .unwrap_or_default()
        }),
    };
    let parameters = free
        .iter()
        .enumerate()
        .map(|(i, f)| {
            let v = fitted.number(&f.key).unwrap_or(f64::NAN);
            estimate(i, f.key.clone(), f.nominal, v, f.slope(outer.p[i]))
        })
        .collect();
    let nominal_delay = outer.pick.mean_delay_s();
    let delay = estimate(
        free.len(),
        "delay_s".into(),
        nominal_delay,
        delay_s,
        outer.rec.h_s,
    );
    let half = count as f64 / 2.0;
    Report {
        parameters,
        delay,
        residual_rms_m: (ss_m / count as f64).sqrt(),
        residual_rms_displacement_m: (ss_rel / half).sqrt(),
        residual_rms_capsule_m: (ss_x2 / half).sqrt(),
        windows: outer.starts.len(),
        window_samples: outer.n,
        residuals: count,
        evaluations: outer.evaluations,
        termination,
        correlation,
        singular_values,
        statements,
        uncertainty: "one standard error: the larger of the cluster-robust (sandwich, windows as clusters) and the textbook sigma^2 (J^T J)^-1 estimate, J the Jacobian with the window states projected out".into(),
    }
}

/// Samples `[t0, t1)` of a recording, in seconds from its first sample.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Segment {
    /// Start \[s\].
    pub t0_s: f64,
    /// End \[s\].
    pub t1_s: f64,
}

impl Segment {
    /// The sample range of the segment in a recording of `len` samples `h_s` apart.
    pub fn range(&self, h_s: f64, len: usize) -> (usize, usize) {
        let at = |t: f64| ((t / h_s).round().max(0.0) as usize).min(len);
        (at(self.t0_s), at(self.t1_s))
    }
}

/// An identification and its validation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// Samples in the recording.
    pub samples: usize,
    /// Sample spacing \[s\].
    pub h_s: f64,
    /// The samples fitted (a `--segment`, or all).
    pub fitted_samples: [usize; 2],
    /// The fit.
    pub report: Report,
    /// The validation (another recording, or what `--segment` left out); `None` without one.
    pub validation: Option<crate::twin_validation::Validation>,
    /// What was validated on: `"other recording"`, `"left out by --segment"` or `"none"`.
    pub validated_on: String,
}

/// What `capsule identify --json` prints and `capsule.identify` returns: the outcome with
/// where it came from.
#[derive(Debug, Serialize)]
pub struct Printed<'a> {
    /// The recording fitted.
    pub recording: String,
    /// Where its forces came from (`commands`, `applied force`).
    pub forces: String,
    /// The fit and the validation.
    #[serde(flatten)]
    pub outcome: &'a Outcome,
    /// The fitted scene's file, if written.
    pub out: Option<String>,
    /// Wall time of the fit and the validation \[s\].
    pub wall_time_s: f64,
}

/// Identifies `keys` of `scene` on `rec` (within `segment`), validates on `other` or on what
/// the segment left out (its longer side).
pub fn identify_and_validate(
    scene: &Scene,
    rec: &Recorded,
    keys: &[String],
    segment: Option<Segment>,
    other: Option<&Recorded>,
    settings: &Settings,
) -> Result<(Identified, Outcome), IdentifyError> {
    let (a, b) = segment.map_or((0, rec.len()), |s| s.range(rec.h_s, rec.len()));
    let part = rec.segment(a, b);
    let identified = identify(scene, &part, keys, settings)?;
    let left_out = if a > rec.len() - b {
        rec.segment(0, a)
    } else {
        rec.segment(b, rec.len())
    };
    let (check, validated_on) = match other {
        Some(o) => (Some(o), "other recording"),
        None if segment.is_some() && !left_out.is_empty() => {
            (Some(&left_out), "left out by --segment")
        }
        None => (None, "none"),
    };
    let validation = check
        .and_then(|c| crate::twin_validation::validate(&identified.scene, identified.delay_s, c));
    let outcome = Outcome {
        samples: rec.len(),
        h_s: rec.h_s,
        fitted_samples: [a, b],
        report: identified.report.clone(),
        validated_on: if validation.is_some() {
            validated_on
        } else {
            "none"
        }
        .to_string(),
        validation,
    };
    Ok((identified, outcome))
}
