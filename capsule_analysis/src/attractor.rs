//! Which attractor a run ends on: period (or none), impacts per period, progression, its
//! Poincaré points, and an identity shared by every run that ends on the same orbit.
//!
//! A run is stopped as soon as it has settled, by recurrence on the Poincaré section (in the
//! spirit of the recurrence method of Attractors.jl): either its last points repeat with a
//! period `k` for [`SettleConfig::repeats`] cycles at the period tolerance (a new periodic
//! attractor), or they follow an attractor already in the [`Catalogue`] point by point for as
//! many cycles at [`SettleConfig::known_tol`] (a known one). Otherwise it runs to
//! [`SettleConfig::max_periods`] and its tail is classified as [`RunReport`] would.
//!
//! [`RunReport`]: crate::RunReport

use crate::cycle::{canonical, same_cycle, SAME_TOL};
use crate::run::{detect_period, PERIOD_TOL};
use crate::schedule::GainSchedule;
use capsule_controller::period::{close, reduced};
use capsule_plant::scene::Scene;
use capsule_plant::AffineLaw;
use capsule_plant::{EventKind, SimError, Simulator, Snapshot, Work};
use serde::Serialize;

/// Longest period recognised before the horizon (needs `repeats` cycles in the window).
const EARLY_MAX_PERIOD: usize = 12;
/// Poincaré points kept for a run that never settles.
const UNSETTLED_POINTS: usize = 200;

/// When a run counts as settled.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SettleConfig {
    /// Drive periods at most.
    pub max_periods: u32,
    /// Two Poincaré points closer than this (max norm) repeat.
    pub tol: f64,
    /// Cycles that must repeat (or follow a known attractor) before the run stops.
    pub repeats: u32,
    /// Distance (max norm) within which a point follows a known attractor's point; 0 turns the
    /// recognition of known attractors off (every run then settles on its own).
    pub known_tol: f64,
}

impl SettleConfig {
    /// The defaults for a scene: its horizon, the period tolerance of [`crate::RunReport`],
    /// three cycles, known attractors recognised within `1e-4`.
    pub fn for_scene(scene: &Scene) -> Self {
        SettleConfig {
            max_periods: scene.horizon.periods,
            tol: PERIOD_TOL,
            repeats: 3,
            known_tol: 1e-4,
        }
    }
}

/// An attractor as seen on the Poincaré section (drive phase 0).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Attractor {
    /// Period in drive periods, or `None` (chaotic, or not settled within the horizon).
    pub period: Option<usize>,
    /// Impacts (contact onsets) per drive period.
    pub impacts_per_period: f64,
    /// Capsule advance per drive period.
    pub avg_progression: f64,
    /// `[x1 - x2, y1 - y2, y1]`: one cycle starting at its lowest `y1` for a periodic attractor
    /// (the exact orbit when Newton's method found it, [`crate::identity::refine`]), the last
    /// points of the run otherwise.
    pub poincare: Vec<[f64; 3]>,
    /// For a run that neither settled nor diverged: its largest Lyapunov exponent per drive
    /// period ([`crate::identity::largest_exponent`]), which tells chaos from quasi-periodic or
    /// slowly converging motion ([`Character`]); `None` for a periodic attractor or where the
    /// exponents are not defined (a law with memory).
    pub largest_lyapunov: Option<f64>,
}

/// What kind of attractor it is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Character {
    /// Periodic, of this period.
    Periodic(usize),
    /// Largest Lyapunov exponent near zero: quasi-periodic, or converging too slowly to settle.
    QuasiPeriodic,
    /// Largest Lyapunov exponent clearly positive.
    Chaotic,
    /// Not periodic, exponent not computable (a law with memory, a linearization that failed).
    Aperiodic,
}

impl Attractor {
    /// Its character: periodic, or by its largest Lyapunov exponent
    /// ([`crate::identity::CHAOS_EXPONENT`]).
    pub fn character(&self) -> Character {
        match (self.period, self.largest_lyapunov) {
            (Some(k), _) => Character::Periodic(k),
            (None, Some(l)) if l > crate::identity::CHAOS_EXPONENT => Character::Chaotic,
            (None, Some(_)) => Character::QuasiPeriodic,
            (None, None) => Character::Aperiodic,
        }
    }
}

/// How a run was stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Stop {
    /// Its own points repeated.
    Settled,
    /// It followed the catalogue's attractor of this index.
    Recognised(usize),
    /// It reached the horizon.
    Horizon,
    /// It entered state-space cells labelled with the catalogue's attractor of this index
    /// ([`crate::basin_cells`]).
    KnownCell(usize),
}

/// Where a run ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    /// The attractor.
    pub attractor: Attractor,
    /// How the run stopped.
    pub stop: Stop,
    /// Drive periods integrated.
    pub periods_run: u32,
    /// Integrator work.
    pub work: Work,
}

/// A run advanced drive period by drive period, with its record on the Poincaré section.
#[derive(Debug, Clone)]
pub struct Trajectory {
    sim: Simulator,
    period: f64,
    /// `[x1 - x2, y1 - y2, y1]` at the end of each period.
    pub points: Vec<[f64; 3]>,
    /// Capsule position at each section, the start included (one more than `points`).
    pub x2: Vec<f64>,
    /// Impacts (contact onsets) in each period.
    pub impacts: Vec<u32>,
}

impl Trajectory {
    /// A trajectory from the scene's initial state.
    pub fn new(scene: &Scene) -> Result<Self, SimError> {
        let sim = Simulator::new(scene.model, scene.initial, 0.0, scene.solver)?;
        let x2 = vec![sim.state().x2];
        Ok(Trajectory {
            sim,
            period: scene.drive.period(),
            points: Vec::new(),
            x2,
            impacts: Vec::new(),
        })
    }

    /// Periods done.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// No period done yet.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// What the plant shows now.
    pub fn snapshot(&self) -> Snapshot {
        self.sim.snapshot()
    }

    /// Integrator work so far.
    pub fn work(&self) -> Work {
        self.sim.work()
    }

    /// Advance one drive period under `law`; with `samples > 0` hand `sample` that many
    /// snapshots through the period (its end included).
    pub fn step(
        &mut self,
        law: &AffineLaw,
        samples: u32,
        sample: &mut dyn FnMut(&Snapshot),
    ) -> Result<(), SimError> {
        let n = self.points.len();
        let mut hits = 0u32;
        let mut on_event = |e: &capsule_plant::Event| {
            if e.kind == EventKind::ContactOn {
                hits += 1;
            }
        };
        let end = (n + 1) as f64 * self.period;
        for i in 1..samples {
            let t = n as f64 * self.period + self.period * f64::from(i) / f64::from(samples);
            self.sim.advance_observed(law, t, &mut on_event)?;
            sample(&self.sim.snapshot());
        }
        self.sim.advance_observed(law, end, &mut on_event)?;
        if samples > 0 {
            sample(&self.sim.snapshot());
        }
        let s = self.sim.state();
        self.points.push([s.x1 - s.x2, s.y1 - s.y2, s.y1]);
        self.x2.push(s.x2);
        self.impacts.push(hits);
        Ok(())
    }

    /// The period the last points repeat with for `repeats` cycles (at most
    /// `EARLY_MAX_PERIOD`), if they do.
    pub fn settled(&self, tol: f64, repeats: u32) -> Option<usize> {
        let reps = repeats.max(1) as usize;
        let window = (reps * EARLY_MAX_PERIOD + 1).min(self.points.len());
        let k = detect_period(&self.points[self.points.len() - window..], tol)?;
        (window > reps * k).then_some(k)
    }

    /// The attractor seen over periods `from..to` (at least one): the cycle of the smallest
    /// period up to [`crate::run::MAX_PERIOD`] that repeats within `tol`, or none.
    pub fn classify(&self, from: usize, to: usize, tol: f64) -> Attractor {
        let n = to.clamp(1, self.points.len().max(1)).min(self.points.len());
        let from = from.min(n.saturating_sub(1));
        match detect_period(&self.points[from..n], tol) {
            Some(k) => self.cycle(n, k),
            None => {
                let m = (n - from).max(1);
                let kept = UNSETTLED_POINTS.min(n - from);
                let hits: u32 = self.impacts[from..n].iter().sum();
                Attractor {
                    period: None,
                    impacts_per_period: f64::from(hits) / m as f64,
                    avg_progression: (self.x2[n] - self.x2[from]) / m as f64,
                    poincare: self.points[n - kept..n].to_vec(),
                    largest_lyapunov: None,
                }
            }
        }
    }

    /// The attractor of the `k` periods ending at `n`: impacts and advance over them, the cycle
    /// rotated to start at its lowest `y1`, reduced to its smallest period.
    fn cycle(&self, n: usize, k: usize) -> Attractor {
        let hits: u32 = self.impacts[n - k..n].iter().sum();
        let last = &self.points[n - k..n];
        let d = reduced(last, SAME_TOL);
        Attractor {
            period: Some(d),
            impacts_per_period: f64::from(hits) / k as f64,
            avg_progression: (self.x2[n] - self.x2[n - k]) / k as f64,
            poincare: canonical(&last[k - d..]),
            largest_lyapunov: None,
        }
    }
}

/// Looser period tolerance for a run that did not settle: a cycle seen at it is handed to
/// Newton's method, which finds the orbit a slowly converging run approaches.
const LOOSE_TOL: f64 = 1e-3;

/// Periods a run goes on before it may stop again once its repeating cycle turned out to lie
/// near an unstable orbit (a transient that leaves it slowly).
const RECHECK_AFTER: u32 = 50;

/// A settled run's attractor (see [`crate::identity`]): the exact stable orbit Newton's method
/// finds near its cycle, or the cycle as seen where Newton finds nothing (a law with memory, a
/// grazing orbit); `None` when the orbit found is unstable: the run is still in a transient.
fn identify_settled(scene: &Scene, run: &Trajectory, k: usize) -> Option<Attractor> {
    let a = run.cycle(run.len(), k);
    let n = run.len();
    let d = a.poincare.len();
    // the run's own last cycle (the attractor's is rotated and may be reduced)
    match crate::identity::refine(scene, &run.points[n - d..n]) {
        None => Some(a),
        Some(r) if r.largest_modulus < 1.0 => Some(Attractor {
            period: Some(r.period),
            poincare: r.cycle,
            ..a
        }),
        Some(_) => None,
    }
}

/// A run that reached the horizon: a periodic attractor as [`identify_settled`] finds it; else
/// the stable orbit Newton's method finds from a cycle seen at a looser tolerance (a run that
/// converges too slowly to settle); else the run's largest Lyapunov exponent, with the tail's
/// progression and impacts (a repeating cycle near an unstable orbit counts as unsettled).
fn identify_unsettled(scene: &Scene, run: &Trajectory, seen: Attractor, tail: usize) -> Attractor {
    let n = run.len();
    if let Some(k) = seen.period {
        // a repeating cycle near an unstable orbit is a transient: judged as unsettled below
        if let Some(a) = identify_settled(scene, run, seen.poincare.len().min(k).max(1)) {
            return a;
        }
    }
    if let Some(k) = detect_period(&run.points[tail..], LOOSE_TOL) {
        if let Some(r) = crate::identity::refine(scene, &run.points[n - k..n]) {
            if r.largest_modulus < 1.0 {
                return Attractor {
                    period: Some(r.period),
                    poincare: r.cycle,
                    ..run.cycle(n, k)
                };
            }
        }
    }
    Attractor {
        period: None,
        largest_lyapunov: crate::identity::largest_exponent(scene, run.snapshot().state),
        ..run.classify(tail, n, 0.0)
    }
}

/// Run `scene` under `schedule` until it settles (see the module doc), from the scene's
/// initial state.
pub fn settle(
    scene: &Scene,
    schedule: &GainSchedule,
    config: &SettleConfig,
    known: &Catalogue,
) -> Result<Outcome, SimError> {
    settle_watched(scene, schedule, config, known, &mut |_| None)
}

/// [`settle`], handing `watch` each section point `[x1 - x2, y1 - y2, y1]` once the gain no
/// longer changes (the initial state's first, if the schedule is constant from the start);
/// `Some(i)` from it stops the run on `known`'s attractor `i` ([`Stop::KnownCell`]).
pub fn settle_watched(
    scene: &Scene,
    schedule: &GainSchedule,
    config: &SettleConfig,
    known: &Catalogue,
    watch: &mut dyn FnMut(&[f64; 3]) -> Option<usize>,
) -> Result<Outcome, SimError> {
    let mut run = Trajectory::new(scene)?;
    let on_cell = |i: usize, n: u32, run: &Trajectory| Outcome {
        attractor: known.attractors[i].clone(),
        stop: Stop::KnownCell(i),
        periods_run: n,
        work: run.work(),
    };
    let s0 = scene.initial;
    if schedule.is_constant_from(0) {
        if let Some(i) = watch(&[s0.x1 - s0.x2, s0.y1 - s0.y2, s0.y1]) {
            return Ok(on_cell(i, 0, &run));
        }
    }
    let max = config.max_periods.max(1);
    // the law from the end of the schedule on: the orbit a run settles on is this law's
    let mut at_end = scene.clone();
    at_end.control.kp = schedule.after;
    let mut follow = Follow::default();
    let mut quiet_until = 0;
    for n in 0..max {
        run.step(&schedule.law(scene, n), 0, &mut |_| {})?;
        // a gain that still changes ahead can move the orbit: no early stop before it settles
        if !schedule.is_constant_from(n + 1) {
            continue;
        }
        let p = run.points[run.len() - 1];
        if let Some(i) = watch(&p) {
            return Ok(on_cell(i, n + 1, &run));
        }
        let stop = match follow.step(known, &p, config) {
            Some(i) => Some((known.attractors[i].clone(), Stop::Recognised(i))),
            None if n < quiet_until => None,
            None => match run.settled(config.tol, config.repeats) {
                None => None,
                Some(k) => match identify_settled(&at_end, &run, k) {
                    Some(a) => Some((a, Stop::Settled)),
                    None => {
                        quiet_until = n + RECHECK_AFTER;
                        None
                    }
                },
            },
        };
        if let Some((attractor, stop)) = stop {
            return Ok(Outcome {
                attractor,
                stop,
                periods_run: n + 1,
                work: run.work(),
            });
        }
    }
    // the horizon: classify the last third as a run's measured periods would be
    let tail = run.len() - (run.len() / 3).max(1);
    let seen = run.classify(tail, run.len(), config.tol);
    Ok(Outcome {
        attractor: identify_unsettled(&at_end, &run, seen, tail),
        stop: Stop::Horizon,
        periods_run: max,
        work: run.work(),
    })
}

/// Follows a trajectory along a known attractor: which one, which of its points comes next,
/// for how many periods it has followed.
#[derive(Debug, Default)]
struct Follow {
    on: Option<(usize, usize)>,
    streak: usize,
}

impl Follow {
    /// Take the next section point; the attractor's index once followed long enough.
    fn step(&mut self, known: &Catalogue, p: &[f64; 3], config: &SettleConfig) -> Option<usize> {
        if config.known_tol <= 0.0 {
            return None;
        }
        let periodic = |i: usize| known.attractors[i].period.is_some();
        let next = self.on.and_then(|(i, j)| {
            let pts = &known.attractors[i].poincare;
            close(p, &pts[j], config.known_tol).then_some((i, (j + 1) % pts.len()))
        });
        match next {
            Some(on) => {
                self.on = Some(on);
                self.streak += 1;
            }
            None => {
                self.streak = 1;
                self.on = (0..known.attractors.len())
                    .filter(|&i| periodic(i))
                    .find_map(|i| {
                        let pts = &known.attractors[i].poincare;
                        pts.iter()
                            .position(|q| close(p, q, config.known_tol))
                            .map(|j| (i, (j + 1) % pts.len()))
                    });
                if self.on.is_none() {
                    self.streak = 0;
                }
            }
        }
        let (i, _) = self.on?;
        let k = known.attractors[i].period.unwrap_or(1);
        (self.streak >= (config.repeats.max(1) as usize * k).max(2)).then_some(i)
    }
}

/// The attractors found so far; a new one is added only if no known one is the same orbit.
#[derive(Debug, Clone, Default, Serialize)]
pub struct Catalogue {
    /// In order of discovery (see [`Catalogue::ordered`] for a stable order).
    pub attractors: Vec<Attractor>,
}

impl Catalogue {
    /// The index of the attractor `a` is, if known. The non-periodic outcomes form one class
    /// per [`Character`] (chaotic, quasi-periodic, unknown).
    pub fn find(&self, a: &Attractor) -> Option<usize> {
        self.attractors
            .iter()
            .position(|b| match (a.period, b.period) {
                (None, None) => a.character() == b.character(),
                (Some(_), Some(_)) => same_cycle(&a.poincare, &b.poincare, SAME_TOL),
                _ => false,
            })
    }

    /// The index of `a`, adding it if new.
    pub fn insert(&mut self, a: &Attractor) -> usize {
        self.find(a).unwrap_or_else(|| {
            self.attractors.push(a.clone());
            self.attractors.len() - 1
        })
    }

    /// Indices in a stable order (by period, then the non-periodic classes, then by
    /// progression, fastest first) and a label for each: `P3` for the only period-3 attractor,
    /// `P3a`, `P3b` when there are several; `QP` (quasi-periodic or slowly converging: largest
    /// Lyapunov exponent near zero), `chaos` (clearly positive) and `aperiodic` (not known) for
    /// the runs that did not settle.
    pub fn ordered(&self) -> Vec<(usize, String)> {
        let mut idx: Vec<usize> = (0..self.attractors.len()).collect();
        let key = |i: usize| self.attractors[i].character();
        idx.sort_by(|&a, &b| {
            key(a).cmp(&key(b)).then(
                self.attractors[b]
                    .avg_progression
                    .total_cmp(&self.attractors[a].avg_progression),
            )
        });
        let mut out = Vec::with_capacity(idx.len());
        for (pos, &i) in idx.iter().enumerate() {
            let label = match self.attractors[i].character() {
                Character::QuasiPeriodic => "QP".to_string(),
                Character::Chaotic => "chaos".to_string(),
                Character::Aperiodic => "aperiodic".to_string(),
                Character::Periodic(k) => {
                    let same: Vec<usize> = idx
                        .iter()
                        .copied()
                        .filter(|&j| self.attractors[j].period == Some(k))
                        .collect();
                    if same.len() == 1 {
                        format!("P{k}")
                    } else {
                        let nth = idx[..pos]
                            .iter()
                            .filter(|&&j| self.attractors[j].period == Some(k))
                            .count();
                        format!("P{k}{}", (b'a' + (nth % 26) as u8) as char)
                    }
                }
            };
            out.push((i, label));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use capsule_plant::State;

    fn scene(alpha: f64, kp: f64, x1: f64, y1: f64) -> Scene {
        let mut s = Scene::default();
        s.drive.alpha = alpha;
        s.control.kp = kp;
        s.initial = State {
            x1,
            y1,
            x2: 0.0,
            y2: 0.0,
        };
        s
    }

    #[test]
    fn a_cycle_is_reduced_to_its_smallest_period() {
        let a = [[0.1, 0.2, 0.3], [0.4, 0.5, -0.6], [0.7, 0.8, 0.9]];
        // a period-1 orbit seen as a converging 4-cycle is period 1; a true 3-cycle stays 3
        let near = [
            [0.5, 1.0, 1.2],
            [0.5 + 2e-6, 1.0, 1.2],
            [0.5, 1.0 - 1e-6, 1.2],
        ];
        assert_eq!(reduced(&near, 1e-4), 1);
        assert_eq!(reduced(&a, 1e-4), 3);
        assert_eq!(reduced(&[a[0], a[1], a[0], a[1]], 1e-4), 2);
    }

    #[test]
    fn two_runs_on_the_same_orbit_get_the_same_label() {
        // alpha 1.5, k_p = 0: the period-1 orbit reached from rest and from a nearby start
        let cfg = SettleConfig {
            known_tol: 0.0,
            ..SettleConfig::for_scene(&scene(1.5, 0.0, 0.0, 0.0))
        };
        let never = GainSchedule::constant(0.0);
        let mut cat = Catalogue::default();
        let a = settle(&scene(1.5, 0.0, 0.0, 0.0), &never, &cfg, &cat).unwrap();
        let b = settle(&scene(1.5, 0.0, 0.05, -0.05), &never, &cfg, &cat).unwrap();
        assert_eq!(a.stop, Stop::Settled);
        assert!(a.periods_run < cfg.max_periods, "{}", a.periods_run);
        let ia = cat.insert(&a.attractor);
        let ib = cat.insert(&b.attractor);
        assert_eq!(a.attractor.period, b.attractor.period);
        assert_eq!(ia, ib);
        assert_eq!(cat.attractors.len(), 1);
        // and a third run, with recognition on, stops on the known attractor early
        let on = SettleConfig {
            known_tol: 1e-4,
            ..cfg
        };
        let c = settle(&scene(1.5, 0.0, 0.0, 0.0), &never, &on, &cat).unwrap();
        assert_eq!(c.stop, Stop::Recognised(ia));
        assert!(c.periods_run <= a.periods_run);
    }

    #[test]
    fn chaos_has_no_period() {
        // Coulomb, alpha 0.6 from rest has no period within 3000 drive periods (Fig 2a: between 0.132 and 0.928)
        let s = scene(0.6, 0.0, 0.0, 0.0);
        let cfg = SettleConfig::for_scene(&s);
        let o = settle(
            &s,
            &GainSchedule::constant(0.0),
            &cfg,
            &Catalogue::default(),
        )
        .unwrap();
        assert_eq!(o.stop, Stop::Horizon);
        assert_eq!(o.attractor.period, None);
        assert_eq!(o.periods_run, cfg.max_periods);
        let mut cat = Catalogue::default();
        let i = cat.insert(&o.attractor);
        assert_eq!(cat.ordered(), vec![(i, "chaos".to_string())]);
    }

    #[test]
    fn labels_are_ordered_by_period_and_distinguished() {
        let at = |period, prog: f64, y: f64| Attractor {
            period,
            impacts_per_period: 1.0,
            avg_progression: prog,
            poincare: vec![[0.0, 0.0, y]; period.unwrap_or(1)],
            largest_lyapunov: period.is_none().then_some(0.3),
        };
        let mut cat = Catalogue::default();
        cat.insert(&at(Some(3), 0.1, 0.0));
        cat.insert(&at(None, 0.0, 0.0));
        cat.insert(&at(Some(1), 0.5, 0.0));
        cat.insert(&at(Some(3), 0.2, 1.0));
        // a second non-periodic class: quasi-periodic (largest exponent near zero)
        cat.insert(&Attractor {
            largest_lyapunov: Some(1e-3),
            ..at(None, 0.1, 0.0)
        });
        // and a chaotic run is the same class as the first
        assert_eq!(
            cat.find(&Attractor {
                largest_lyapunov: Some(0.9),
                ..at(None, 0.4, 2.0)
            }),
            Some(1)
        );
        let labels: Vec<String> = cat.ordered().into_iter().map(|(_, l)| l).collect();
        assert_eq!(labels, ["P1", "P3a", "P3b", "QP", "chaos"]);
        assert_eq!(
            cat.ordered()[1].0,
            3,
            "the faster period-3 orbit comes first"
        );
    }
}
