//! The twin: a scene's capsule driven by a recorded force, restarted from a state at any
//! sample of the recording, and the state that makes it follow a stretch of measured
//! positions best. What `identify` fits and what its validation predicts with.
//!
//! The device between the recorded command and the capsule is modelled as the emulator models
//! it (`capsule_plant::device`): the command answering sample `k` is held from sample `k` to
//! `k + 1`, through the actuator's dead band, saturation and the coil's first-order lag (the
//! scene's `[device]`; an ideal actuator without one). The measurement of sample `k` is the
//! capsule at `t_k - delay`, averaged over the delays the sensor's pick of a reading can give
//! (`SensorPick`, from the `[device]`'s latency and jitter): the mean delay is a number of the
//! twin, fitted beside the scene's keys.

use capsule_plant::device::actuator::Actuator;
use capsule_plant::device::DeviceModel;
use capsule_plant::scene::Scene;
use capsule_plant::{ConstantForce, SimError, Simulator, State};
use levenberg_marquardt::{LeastSquaresProblem, LevenbergMarquardt};
use nalgebra::{storage::Owned, DMatrix, DVector, Dyn, Vector4, U4};

/// A recorded run on its sample grid, SI: the positions the device measured (NaN where it
/// measured nothing) and the force after each sample: commanded (through the scene's actuator
/// on its way to the mass) or, `acted`, what the actuator applied.
#[derive(Debug, Clone, PartialEq)]
pub struct Recorded {
    /// Sample spacing \[s\].
    pub h_s: f64,
    /// `x1 - x2` at each sample \[m\].
    pub rel_m: Vec<f64>,
    /// `x2` at each sample \[m\].
    pub x2_m: Vec<f64>,
    /// The force commanded from each sample to the next \[N\] (`acted`: the mean force on the
    /// mass over that period).
    pub command_n: Vec<f64>,
    /// The forces are what acted on the mass (a device's report of its actuator): the twin
    /// takes them as they are, without the scene's actuator.
    pub acted: bool,
}

impl Recorded {
    /// A recording of these series (each as long as `x2_m`: what is missing is not measured).
    pub fn new(h_s: f64, rel_m: Vec<f64>, x2_m: Vec<f64>, command_n: Vec<f64>) -> Recorded {
        let n = x2_m.len();
        let fit = |mut v: Vec<f64>, fill: f64| {
            v.resize(n, fill);
            v
        };
        Recorded {
            h_s,
            rel_m: fit(rel_m, f64::NAN),
            command_n: fit(command_n, 0.0),
            x2_m,
            acted: false,
        }
    }

    /// The same, its forces what acted on the mass or not (see [`Recorded::acted`]).
    pub fn with_acted(self, acted: bool) -> Recorded {
        Recorded { acted, ..self }
    }

    /// Samples in the recording.
    pub fn len(&self) -> usize {
        self.x2_m.len()
    }

    /// Whether it has no sample.
    pub fn is_empty(&self) -> bool {
        self.x2_m.is_empty()
    }

    /// Whether sample `k` has both positions.
    pub fn measured(&self, k: usize) -> bool {
        self.rel_m[k].is_finite() && self.x2_m[k].is_finite()
    }

    /// Samples `a..b` (clamped to the recording).
    pub fn segment(&self, a: usize, b: usize) -> Recorded {
        let b = b.min(self.len());
        let a = a.min(b);
        Recorded {
            h_s: self.h_s,
            rel_m: self.rel_m[a..b].to_vec(),
            x2_m: self.x2_m[a..b].to_vec(),
            command_n: self.command_n[a..b].to_vec(),
            acted: self.acted,
        }
    }
}

/// The force on the mass over the recording: the commands through the actuator (target and
/// coil force at the start of each hold), integrated exactly over any interval.
#[derive(Debug, Clone)]
pub struct Forcing {
    h_s: f64,
    lag_s: f64,
    target: Vec<f64>,
    coil: Vec<f64>,
}

impl Forcing {
    /// The force of `rec`'s commands through `device`'s actuator (`None`: ideal). Forces that
    /// acted (`rec.acted`, each the mean over its period) are shaped within each period by
    /// the device's coil lag ([`coil_targets`]); without a lag they are held constant.
    pub fn new(rec: &Recorded, device: Option<&DeviceModel>) -> Forcing {
        let finite: Vec<f64> = rec
            .command_n
            .iter()
            .map(|c| if c.is_finite() { *c } else { 0.0 })
            .collect();
        let lag_s = device.map_or(0.0, |d| d.lag_s.max(0.0));
        let target: Vec<f64> = match device {
            Some(d) if !rec.acted => {
                let a = Actuator::new(d);
                rec.command_n.iter().map(|c| a.target(*c)).collect()
            }
            Some(_) if lag_s > 0.0 => coil_targets(&finite, rec.h_s, lag_s),
            _ => finite,
        };
        let decay = if lag_s > 0.0 {
            (-rec.h_s / lag_s).exp()
        } else {
            0.0
        };
        let mut coil = Vec::with_capacity(target.len());
        let mut f = 0.0;
        for t in &target {
            coil.push(f);
            f = t + (f - t) * decay;
        }
        Forcing {
            h_s: rec.h_s,
            lag_s,
            target,
            coil,
        }
    }

    /// The coil's time constant \[s\].
    pub fn lag_s(&self) -> f64 {
        self.lag_s
    }

    /// The integral of the force over `[a, b]` \[N s\] (times from the first sample; zero
    /// before it, the last command held after the end).
    pub fn integral(&self, a: f64, b: f64) -> f64 {
        let (h, n) = (self.h_s, self.target.len());
        if n == 0 || b <= a {
            return 0.0;
        }
        let mut sum = 0.0;
        let first = (a / h).floor().max(0.0) as usize;
        let mut j = first;
        loop {
            let t0 = j as f64 * h;
            if t0 >= b {
                break;
            }
            let last = j + 1 >= n;
            let t1 = if last { f64::INFINITY } else { t0 + h };
            let (u, v) = (a.max(t0), b.min(t1));
            if v > u && b > 0.0 {
                let k = j.min(n - 1);
                let (target, f0) = (self.target[k], self.coil[k]);
                sum += target * (v - u);
                if self.lag_s > 0.0 {
                    let gap = f0 - target;
                    sum += gap
                        * self.lag_s
                        * ((-(u - t0) / self.lag_s).exp() - (-(v - t0) / self.lag_s).exp());
                }
            }
            if last {
                break;
            }
            j += 1;
        }
        sum
    }
}

/// The coil's targets, period by period, whose first-order lag `lag_s` (the coil at rest at
/// the start) gives `means` as the mean force over each period of `h_s`: a device reports the
/// mean force its actuator applied over each period, and the coil's force within it is not
/// constant. Held constant at its mean, the force of the graph's recordings put every fitted
/// key low by 1 to 4 standard errors (xi -0.32 %, 3.9 s.e., at 30 s; docs/perf/identify.md);
/// shaped by the lag, each period keeps its mean and the shape is the coil's. The recursion
/// is stable for any lag (each step multiplies an error in the coil's start by -0.52 at the
/// typical device's `h / lag = 2`, by -1 only as the lag grows without bound).
pub fn coil_targets(means: &[f64], h_s: f64, lag_s: f64) -> Vec<f64> {
    let lagging = lag_s > 0.0 && h_s > 0.0;
    if !lagging {
        return means.to_vec();
    }
    let r = h_s / lag_s;
    let decay = (-r).exp();
    // a period's mean is its target plus `share` times the coil's gap to it at its start
    let share = -(-r).exp_m1() / r;
    let mut coil = 0.0;
    means
        .iter()
        .map(|m| {
            let target = (m - share * coil) / (1.0 - share);
            coil = target + (coil - target) * decay;
            target
        })
        .collect()
}

/// How the device's sensor picks the reading it sends (`capsule_plant::device::sensor`): the
/// newest reading at least the latency old, each reading taken at its sample time plus a
/// Gaussian jitter. Where the latency is within a few jitters of a whole number of samples
/// (the typical device: 2 ms at 1 kHz), which of two readings is old enough is a coin toss,
/// and the measurement is the capsule 2 or 3 ms before at random. A twin with one delay then
/// fits the mean of the two, which it cannot reproduce (a two-point average smooths the
/// impacts and the slips): with the typical device it put xi 1 % (3.3 standard errors) and
/// delta 9 % off, the same with a noiseless sensor. So the twin measures what the sensor sends
/// on average: the weighted mean of the capsule at each delay the pick can give.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorPick {
    /// Delays relative to their mean \[s\] and their probabilities.
    offsets: Vec<(f64, f64)>,
    /// The mean delay \[s\].
    mean_s: f64,
    /// The sensor's jitter \[s\].
    jitter_s: f64,
}

impl SensorPick {
    /// The pick of `device`'s sensor sampled every `h_s` (`None`: an ideal one, no delay).
    pub fn new(device: Option<&DeviceModel>, h_s: f64) -> SensorPick {
        let (latency, jitter) = device.map_or((0.0, 0.0), |d| (d.latency_s, d.jitter_s));
        let mut picks: Vec<(f64, f64)> = Vec::new();
        if jitter > 0.0 && h_s > 0.0 {
            // reading k - m is old enough when its jitter e <= m h - latency; the newest such
            let mut newer_not_due = 1.0;
            let first = ((latency - 8.0 * jitter) / h_s).floor().max(0.0) as usize;
            for m in first..first + 64 {
                let a = (m as f64 * h_s - latency) / jitter;
                let due = normal_cdf(a);
                let p = newer_not_due * due;
                if p > 1e-9 {
                    // the reading's mean jitter given that it is due: -sigma phi(a) / Phi(a)
                    let phi = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
                    picks.push((m as f64 * h_s + jitter * phi / due, p));
                }
                newer_not_due *= 1.0 - due;
                if newer_not_due < 1e-9 {
                    break;
                }
            }
        }
        if picks.is_empty() {
            let m = if h_s > 0.0 {
                ((latency - 1e-12) / h_s).ceil().max(0.0)
            } else {
                0.0
            };
            picks.push((m * h_s, 1.0));
        }
        let total: f64 = picks.iter().map(|p| p.1).sum();
        let mean_s = picks.iter().map(|p| p.0 * p.1).sum::<f64>() / total;
        SensorPick {
            offsets: picks
                .into_iter()
                .map(|(d, p)| (d - mean_s, p / total))
                .collect(),
            mean_s,
            jitter_s: jitter,
        }
    }

    /// The variance of the pick's delays around their mean \[s^2\].
    fn variance_s2(&self) -> f64 {
        self.offsets.iter().map(|(o, p)| p * o * o).sum()
    }

    /// Whether a reading's age varies (a spread of the pick or a jitter).
    pub fn spreads(&self) -> bool {
        self.offsets.len() > 1 || self.jitter_s > 0.0
    }

    /// How many delays the pick can give.
    pub fn count(&self) -> usize {
        self.offsets.len()
    }

    /// The probability of each of the pick's delays, in the order of the twin's picks.
    pub fn probabilities(&self) -> Vec<f64> {
        self.offsets.iter().map(|o| o.1).collect()
    }

    /// The mean delay of the readings \[s\].
    pub fn mean_delay_s(&self) -> f64 {
        self.mean_s
    }
}

/// The standard normal distribution function (Numerical Recipes' `erfcc`, relative error under
/// 1.2e-7). Written out: std has no erf, and `libm` as a dependency of its own changed the
/// features of the one in the tree and with them every dependent crate's build.
fn normal_cdf(x: f64) -> f64 {
    let z = x.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = [
        -1.265_512_23,
        1.000_023_68,
        0.374_091_96,
        0.096_784_18,
        -0.186_288_06,
        0.278_868_07,
        -1.135_203_98,
        1.488_515_87,
        -0.822_152_23,
        0.170_872_77,
    ]
    .iter()
    .rev()
    .fold(0.0, |acc, c| c + t * acc);
    let erfc = t * (-z * z + poly).exp();
    if x >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

/// How a twin's residuals are weighted, per sample of the recording.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Weights {
    /// The weights of the `x1 - x2` and `x2` residuals, per sample.
    pub channels: Vec<[f64; 2]>,
    /// Per sample, [`Twin::pick_count`] probabilities that the measurement is the reading of
    /// each of the pick's delays, given the data (expectation-maximisation's responsibilities):
    /// the twin then compares the capsule at each delay with the measurement, weighted by its
    /// probability, instead of their mean. Empty: the mean.
    pub picks: Vec<f64>,
}

/// A candidate twin: a scene, the recording's force, the measurement delay.
pub struct Twin<'a> {
    /// The capsule, friction, solver and scale.
    pub scene: &'a Scene,
    /// The recorded force through the actuator.
    pub forcing: &'a Forcing,
    /// How the sensor picks its readings (the spread of the delay around its mean).
    pub pick: &'a SensorPick,
    /// How the residuals are weighted (`None`: all 1, the pick's mean).
    pub weights: Option<&'a Weights>,
    /// The mean delay: measurement `k` is the capsule at `t_k - delay_s - o`, averaged over the
    /// pick's offsets `o`.
    pub delay_s: f64,
}

/// Constant-force pieces per sample interval, each at the exact mean force: at most half the
/// coil's lag (the emulator cuts its holds at a quarter; half changed the fitted numbers of
/// docs/perf/identify.md's case by under 0.1 of their standard errors, at half the cost).
fn pieces(h_s: f64, lag_s: f64) -> usize {
    if lag_s > 0.0 {
        ((2.0 * h_s / lag_s).ceil() as usize).clamp(1, 8)
    } else {
        1
    }
}

impl Twin<'_> {
    /// Simulates from `s0` (non-dimensional) at sample `a` over `n` sample intervals, pushing
    /// the measurement the twin expects, `[x1 - x2, x2]` \[m\], at samples `a ..= a + n` onto
    /// `out`; returns the state at `a + n`.
    ///
    /// The simulator's clock runs on the measurement's, shifted by the longest delay of the
    /// pick: its state at sample `k` is the capsule at `t_k - delay - o_max`, and the
    /// measurement of `k` averages its states at `t_k + o_max - o` (at or after `t_k`).
    pub fn run(
        &self,
        a: usize,
        n: usize,
        s0: State,
        out: &mut Vec<[f64; 2]>,
    ) -> Result<State, SimError> {
        let (picks, end) = self.picks(a, n, s0)?;
        let weights: Vec<f64> = self.pick.offsets.iter().map(|o| o.1).collect();
        out.extend(picks.chunks(weights.len()).map(|at| {
            at.iter()
                .zip(&weights)
                .fold([0.0; 2], |m, (x, w)| [m[0] + w * x[0], m[1] + w * x[1]])
        }));
        Ok(end)
    }

    /// The variance of each measurement of a run from `s0` at `a` over `n` intervals that the
    /// age of the reading makes, `[x1 - x2, x2]` \[m^2\]: the capsule's motion over the pick's
    /// spread of delays, and over the jitter (`v^2 sigma^2`, from the pick's positions too).
    pub fn spread(&self, a: usize, n: usize, s0: State) -> Result<Vec<[f64; 2]>, SimError> {
        let (picks, _) = self.picks(a, n, s0)?;
        let (between, within) = self.pick_variances(&picks);
        Ok(between
            .iter()
            .zip(&within)
            .map(|(b, w)| [b[0] + w[0], b[1] + w[1]])
            .collect())
    }

    /// Per sample of `picks` ([`Twin::picks`]), the variance of the measurement between the
    /// pick's readings and the jitter's within one, `[x1 - x2, x2]` \[m^2\] (the jitter's from
    /// the same motion: in proportion to the pick's spread, which stands for `v^2`).
    pub fn pick_variances(&self, picks: &[[f64; 2]]) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let offsets = &self.pick.offsets;
        let spread = self.pick.variance_s2();
        let jitter = if spread > 0.0 {
            self.pick.jitter_s * self.pick.jitter_s / spread
        } else {
            0.0
        };
        picks
            .chunks(offsets.len())
            .map(|at| {
                let var = [0, 1].map(|c| {
                    let m: f64 = at.iter().zip(offsets).map(|(x, o)| o.1 * x[c]).sum();
                    let v: f64 = at
                        .iter()
                        .zip(offsets)
                        .map(|(x, o)| o.1 * (x[c] - m).powi(2))
                        .sum();
                    v.max(0.0)
                });
                (var, var.map(|v| v * jitter))
            })
            .unzip()
    }

    /// The pick count: readings of different age the sensor may send for a sample.
    pub fn pick_count(&self) -> usize {
        self.pick.offsets.len()
    }

    /// The capsule `[x1 - x2, x2]` \[m\] at each delay of the pick for samples `a ..= a + n`
    /// of a run from `s0` at `a`, [`Twin::pick_count`] a sample; and the state at `a + n`.
    pub fn picks(&self, a: usize, n: usize, s0: State) -> Result<(Vec<[f64; 2]>, State), SimError> {
        let p = &self.scene.physical;
        let (l, ts, fs) = (p.length_m(), p.time_s(), p.force_n());
        let h = self.forcing.h_s;
        let mut sim = Simulator::new(self.scene.model(), s0, 0.0, self.scene.solver())?;
        let o_max = self
            .pick
            .offsets
            .iter()
            .map(|o| o.0)
            .fold(f64::NEG_INFINITY, f64::max);
        let delay = self.delay_s + o_max;
        // each offset's lead on the sample: whole samples and the rest
        let leads: Vec<(usize, f64)> = self
            .pick
            .offsets
            .iter()
            .map(|&(o, _)| {
                let lead = (o_max - o).max(0.0);
                let whole = (lead / h + 1e-9).floor();
                let rest = (lead - whole * h).max(0.0);
                (whole as usize, if rest < 1e-9 * h { 0.0 } else { rest })
            })
            .collect();
        let count = leads.len();
        let q = pieces(h, self.forcing.lag_s);
        // the cuts in a sample interval: the pieces, the hold boundaries (in the measurement's
        // time they fall `delay mod h` after a sample) and the leads' rests
        let offset = delay.rem_euclid(h);
        let mut cuts: Vec<f64> = (0..=q).map(|i| h * i as f64 / q as f64).collect();
        cuts.push(offset);
        cuts.extend(leads.iter().map(|x| x.1));
        cuts.sort_by(f64::total_cmp);
        cuts.dedup_by(|x, y| (*x - *y).abs() <= 1e-9 * h);
        let mut out = vec![[0.0; 2]; (n + 1) * count];
        let mut add = |j: usize, at: f64, s: State| {
            for (i, &(whole, rest)) in leads.iter().enumerate() {
                if (rest - at).abs() <= 1e-9 * h && j >= whole && j - whole <= n {
                    out[(j - whole) * count + i] = [(s.x1 - s.x2) * l, s.x2 * l];
                }
            }
        };
        let last = n + leads
            .iter()
            .map(|x| x.0 + usize::from(x.1 > 0.0))
            .max()
            .unwrap_or(0);
        let mut end = s0;
        for j in 0..=last {
            let state = sim.state();
            add(j, 0.0, state);
            if j == n {
                end = state;
            }
            if j == last {
                break;
            }
            let t_j = (a + j) as f64 * h;
            for w in cuts.windows(2) {
                let (u, v) = (t_j + w[0], t_j + w[1]);
                if v - u <= 1e-12 * h {
                    continue;
                }
                let mean = self.forcing.integral(u - delay, v - delay) / (v - u);
                let tau_end = (v - a as f64 * h) / ts;
                sim.advance(&ConstantForce(mean / fs), tau_end)?;
                if w[1] < h * (1.0 - 1e-9) {
                    add(j, w[1], sim.state());
                }
            }
        }
        Ok((out, end))
    }

    /// Residuals of a run from `s0` at `a` over `n` intervals against `rec`, \[m\]: `x1 - x2`
    /// then `x2` of each sample, zero where nothing was measured (with the pick's
    /// responsibilities, [`Weights::picks`]: of each pick of each sample, times the square root
    /// of its responsibility). A failed run gives 1 m.
    pub fn residuals(&self, rec: &Recorded, a: usize, n: usize, s0: State) -> Vec<f64> {
        let mixture = self.weights.filter(|w| !w.picks.is_empty());
        let per = if mixture.is_some() {
            self.pick_count()
        } else {
            1
        };
        let mut out = Vec::with_capacity((n + 1) * per);
        let ran = match mixture {
            Some(_) => self.picks(a, n, s0).map(|(p, _)| out = p),
            None => self.run(a, n, s0, &mut out).map(|_| ()),
        };
        if ran.is_err() {
            out.clear();
        }
        out.resize((n + 1) * per, [f64::NAN; 2]);
        let mut r = Vec::with_capacity(2 * (n + 1) * per);
        for (i, &[rel, x2]) in out.iter().enumerate() {
            let k = a + i / per;
            let w = self.weights.map_or([1.0; 2], |w| w.channels[k]);
            let share = mixture.map_or(1.0, |m| m.picks[k * per + i % per].sqrt());
            for (c, (sim, meas)) in [(rel, rec.rel_m[k]), (x2, rec.x2_m[k])]
                .into_iter()
                .enumerate()
            {
                r.push(if !meas.is_finite() {
                    0.0
                } else if sim.is_finite() {
                    share * w[c] * (sim - meas)
                } else {
                    1.0
                });
            }
        }
        r
    }

    /// A first guess of the state at sample `a` from the positions around it: a quadratic
    /// through the measured samples within `half` of it, its value and slope at `a`.
    pub fn guess(&self, rec: &Recorded, a: usize, half: usize) -> State {
        let p = &self.scene.physical;
        let (l, v) = (p.length_m(), p.velocity_m_per_s());
        let lo = a.saturating_sub(half);
        let hi = (a + half + 1).min(rec.len());
        let fit = |y: &[f64]| -> (f64, f64) {
            let pts: Vec<(f64, f64)> = (lo..hi)
                .filter(|k| rec.measured(*k))
                .map(|k| ((k as f64 - a as f64) * rec.h_s, y[k]))
                .collect();
            quadratic_at_zero(&pts)
        };
        let (rel, drel) = fit(&rec.rel_m);
        let (x2, dx2) = fit(&rec.x2_m);
        State {
            x1: (rel + x2) / l,
            y1: (drel + dx2) / v,
            x2: x2 / l,
            y2: dx2 / v,
        }
    }
}

/// Value and slope at 0 of the least-squares quadratic through `pts` (a line through fewer
/// than four points, the point itself through one).
fn quadratic_at_zero(pts: &[(f64, f64)]) -> (f64, f64) {
    match pts.len() {
        0 => (0.0, 0.0),
        1 => (pts[0].1, 0.0),
        n => {
            let cols = if n >= 4 { 3 } else { 2 };
            let a = DMatrix::from_fn(n, cols, |i, j| pts[i].0.powi(j as i32));
            let b = DVector::from_iterator(n, pts.iter().map(|p| p.1));
            match a.svd(true, true).solve(&b, 1e-18) {
                Ok(c) => (c[0], c[1]),
                Err(_) => (pts[0].1, 0.0),
            }
        }
    }
}

/// Column scales of the window state: positions and velocities are O(1) non-dimensional.
const STATE_STEP: f64 = 1e-7;

/// The state at `a` that makes `twin` follow `rec`'s positions over `n` intervals best
/// (least squares from `guess`), its residuals, and their Jacobian in the state.
pub struct WindowFit {
    /// The state at the window's first sample.
    pub state: State,
    /// Residuals \[m\].
    pub residuals: Vec<f64>,
}

struct WindowProblem<'a, 'b> {
    twin: &'a Twin<'b>,
    rec: &'a Recorded,
    a: usize,
    n: usize,
    s: Vector4<f64>,
}

fn state_of(s: &Vector4<f64>) -> State {
    State::from_array([s[0], s[1], s[2], s[3]])
}

impl LeastSquaresProblem<f64, Dyn, U4> for WindowProblem<'_, '_> {
    type ResidualStorage = Owned<f64, Dyn>;
    type JacobianStorage = Owned<f64, Dyn, U4>;
    type ParameterStorage = Owned<f64, U4>;

    fn set_params(&mut self, x: &Vector4<f64>) {
        self.s = *x;
    }

    fn params(&self) -> Vector4<f64> {
        self.s
    }

    fn residuals(&self) -> Option<DVector<f64>> {
        Some(DVector::from_vec(self.twin.residuals(
            self.rec,
            self.a,
            self.n,
            state_of(&self.s),
        )))
    }

    fn jacobian(&self) -> Option<nalgebra::OMatrix<f64, Dyn, U4>> {
        Some(state_jacobian(
            self.twin,
            self.rec,
            self.a,
            self.n,
            state_of(&self.s),
            None,
        ))
    }
}

/// The Jacobian of the window's residuals in its start state (forward differences; `base`:
/// the residuals at `s0` if known).
pub fn state_jacobian(
    twin: &Twin,
    rec: &Recorded,
    a: usize,
    n: usize,
    s0: State,
    base: Option<&[f64]>,
) -> nalgebra::OMatrix<f64, Dyn, U4> {
    let own;
    let r0 = match base {
        Some(b) => b,
        None => {
            own = twin.residuals(rec, a, n, s0);
            &own
        }
    };
    let mut j = nalgebra::OMatrix::<f64, Dyn, U4>::zeros(r0.len());
    let arr = s0.to_array();
    for c in 0..4 {
        let step = STATE_STEP * arr[c].abs().max(1.0);
        let mut s = arr;
        s[c] += step;
        let r = twin.residuals(rec, a, n, State::from_array(s));
        for (i, (ri, r0i)) in r.iter().zip(r0).enumerate() {
            j[(i, c)] = (ri - r0i) / step;
        }
    }
    j
}

/// Fits the state at sample `a` over `n` intervals, from `guess`.
pub fn fit_window(twin: &Twin, rec: &Recorded, a: usize, n: usize, guess: State) -> WindowFit {
    let problem = WindowProblem {
        twin,
        rec,
        a,
        n,
        s: Vector4::from(guess.to_array()),
    };
    let (problem, _) = LevenbergMarquardt::new()
        .with_ftol(1e-9)
        .with_xtol(1e-9)
        .with_patience(20)
        .minimize(problem);
    let state = state_of(&problem.s);
    let residuals = twin.residuals(rec, a, n, state);
    WindowFit { state, residuals }
}

/// A run as the plant records it in front of a device, made offline: `truth`'s capsule behind
/// `device` (`robustness::closed_loop_observed`, the emulator's prototype in lock-step), under
/// the law with gain `kp` at `rate_hz` for `seconds`; the device's readings and the commands.
/// For tests and benchmarks of identification without the ROS graph.
pub fn emulated_run(
    truth: &Scene,
    kp: f64,
    device: &DeviceModel,
    rate_hz: f64,
    seconds: f64,
) -> Result<Recorded, SimError> {
    use crate::robustness::{closed_loop_observed, controller_window, LoopCase, Mismatch};
    let period_s = truth.drive.period() * truth.physical.time_s();
    let periods = (seconds / period_s).ceil() as u32;
    let case = LoopCase {
        kp,
        device: *device,
        mismatch: Mismatch::NONE,
        rate_hz,
        transient: 0,
        periods,
        velocity_window: controller_window(period_s, rate_hz),
        orbit_tolerance: 0.1,
    };
    let n = (seconds * rate_hz).round() as usize;
    let mut rec = Recorded {
        h_s: 1.0 / rate_hz,
        rel_m: Vec::with_capacity(n),
        x2_m: Vec::with_capacity(n),
        command_n: Vec::with_capacity(n),
        acted: false,
    };
    closed_loop_observed(truth, &case, &mut |s| {
        if rec.x2_m.len() < n {
            rec.rel_m.push(s.reading.displacement_m);
            rec.x2_m.push(s.reading.capsule_m);
            rec.command_n.push(s.command_n);
        }
    })?;
    Ok(rec)
}

/// The windows of a recording: their first samples, `n` intervals each, each with enough
/// measured samples (three quarters).
pub fn windows(rec: &Recorded, n: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut a = 0;
    while n > 0 && a + n < rec.len() {
        let measured = (a..=a + n).filter(|k| rec.measured(*k)).count();
        if 4 * measured >= 3 * (n + 1) && rec.measured(a) {
            out.push(a);
        }
        a += n;
    }
    out
}

/// Samples in a window of `periods` drive periods of `scene`.
pub fn window_samples(scene: &Scene, h_s: f64, periods: f64) -> usize {
    let period_s = scene.drive.period() * scene.physical.time_s();
    ((periods * period_s / h_s).round() as usize).max(4)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(commands: Vec<f64>) -> Recorded {
        let n = commands.len();
        Recorded {
            h_s: 1e-3,
            rel_m: vec![0.0; n],
            x2_m: vec![0.0; n],
            command_n: commands,
            acted: false,
        }
    }

    #[test]
    fn the_force_integral_follows_the_coil_exactly() {
        let r = rec(vec![1.0, 1.0, 0.0]);
        let ideal = Forcing::new(&r, None);
        assert!((ideal.integral(0.0, 2e-3) - 2e-3).abs() < 1e-15);
        assert!((ideal.integral(0.5e-3, 2.5e-3) - 1.5e-3).abs() < 1e-15);
        assert_eq!(ideal.integral(-1.0, 0.0), 0.0);
        let d = DeviceModel {
            lag_s: 1e-3,
            ..DeviceModel::ideal(&Default::default())
        };
        let lagged = Forcing::new(&r, Some(&d));
        // f(t) = 1 - exp(-t / lag) from rest: its integral over [0, 2 ms]
        let want = 2e-3 - 1e-3 * (1.0 - (-2.0f64).exp());
        assert!((lagged.integral(0.0, 2e-3) - want).abs() < 1e-15);
        // split anywhere, the same
        let split = lagged.integral(0.0, 0.7e-3) + lagged.integral(0.7e-3, 2e-3);
        assert!((split - want).abs() < 1e-15);
        // forces that acted on the mass: without a device, held over their period
        let acted = Forcing::new(&r.clone().with_acted(true), None);
        assert!((acted.integral(0.0, 2e-3) - 2e-3).abs() < 1e-15);
        assert_eq!(acted.lag_s(), 0.0);
    }

    #[test]
    fn a_device_s_mean_forces_are_shaped_by_its_coil_and_keep_their_means() {
        let d = DeviceModel {
            lag_s: 0.5e-3,
            max_force_n: 0.8,
            ..DeviceModel::ideal(&Default::default())
        };
        // what the device reports: the mean force over each period of these commands
        let commands = [0.3, 1.0, -0.2, 0.0, 0.5, 0.5, -1.5, 0.1];
        let mut coil = Actuator::new(&d);
        let means: Vec<f64> = commands.iter().map(|c| coil.hold(*c, 1e-3)).collect();
        let reported = Forcing::new(&rec(means.clone()).with_acted(true), Some(&d));
        let commanded = Forcing::new(&rec(commands.to_vec()), Some(&d));
        assert_eq!(reported.lag_s(), 0.5e-3);
        for (k, m) in means.iter().enumerate() {
            let (a, b) = (k as f64 * 1e-3, (k + 1) as f64 * 1e-3);
            // each period keeps its mean; within it, the coil's force, not a constant
            assert!((reported.integral(a, b) - m * 1e-3).abs() < 1e-15, "{k}");
            let half = a + 0.5e-3;
            let (got, want) = (reported.integral(a, half), commanded.integral(a, half));
            assert!((got - want).abs() < 1e-15, "{k}: {got} {want}");
        }
        // the targets are the limited commands
        let targets = coil_targets(&means, 1e-3, 0.5e-3);
        let limited: Vec<f64> = commands.iter().map(|c| c.clamp(-0.8, 0.8)).collect();
        for (t, c) in targets.iter().zip(&limited) {
            assert!((t - c).abs() < 1e-12, "{targets:?}");
        }
        // the same means held constant are not the coil's force
        let held = Forcing::new(&rec(means.clone()).with_acted(true), None);
        assert!((held.integral(1e-3, 1.5e-3) - reported.integral(1e-3, 1.5e-3)).abs() > 1e-5);
    }

    #[test]
    fn the_normal_distribution_function_and_the_pick_of_the_typical_sensor() {
        for (x, want) in [(0.0, 0.5), (1.0, 0.841_344_746), (-2.0, 0.022_750_132)] {
            assert!(
                (normal_cdf(x) - want).abs() < 1e-7,
                "{x}: {}",
                normal_cdf(x)
            );
        }
        // 2 ms latency, 0.1 ms jitter, 1 kHz: the reading of 2 ms before when its jitter was
        // early (mean 0.08 ms early), of 3 ms before otherwise, at even odds
        let d = DeviceModel {
            latency_s: 2e-3,
            jitter_s: 1e-4,
            ..DeviceModel::ideal(&Default::default())
        };
        let pick = SensorPick::new(Some(&d), 1e-3);
        let early = 1e-4 * (2.0 / std::f64::consts::PI).sqrt();
        let mean = 0.5 * (2e-3 + early) + 0.5 * 3e-3;
        assert!((pick.mean_delay_s() - mean).abs() < 1e-9, "{pick:?}");
        assert_eq!(pick.offsets.len(), 2, "{pick:?}");
        // no jitter: the newest sample at least the latency old, always
        let exact = SensorPick::new(Some(&DeviceModel { jitter_s: 0.0, ..d }), 1e-3);
        assert_eq!((exact.mean_delay_s(), exact.offsets.len()), (2e-3, 1));
        let between = DeviceModel {
            latency_s: 2.5e-3,
            ..d
        };
        let late = SensorPick::new(Some(&between), 1e-3);
        assert!((late.mean_delay_s() - 3e-3).abs() < 1e-9, "{late:?}");
    }

    #[test]
    fn the_mixture_compares_each_delay_of_the_pick_and_the_mean_is_their_average() {
        let scene = Scene::default();
        let d = DeviceModel {
            latency_s: 2e-3,
            jitter_s: 1e-4,
            ..DeviceModel::typical(&scene.physical)
        };
        let n = 40;
        let r = rec((0..=n).map(|k| 0.1 * (k as f64 * 0.2).sin()).collect());
        let forcing = Forcing::new(&r, Some(&d));
        let pick = SensorPick::new(Some(&d), r.h_s);
        let twin = Twin {
            scene: &scene,
            forcing: &forcing,
            pick: &pick,
            weights: None,
            delay_s: pick.mean_delay_s(),
        };
        let s0 = scene.initial_state();
        let (picks, _) = twin.picks(0, n, s0).expect("picks");
        let mut mean = Vec::new();
        twin.run(0, n, s0, &mut mean).expect("run");
        let p = pick.probabilities();
        assert_eq!((picks.len(), p.len()), (2 * (n + 1), 2));
        // the capsule moves: the two delays see it apart, and the mean is their average
        let apart = picks
            .chunks(2)
            .map(|x| (x[0][1] - x[1][1]).abs())
            .fold(0.0, f64::max);
        assert!(apart > 0.0);
        for (m, x) in mean.iter().zip(picks.chunks(2)) {
            assert!((m[1] - (p[0] * x[0][1] + p[1] * x[1][1])).abs() < 1e-15);
        }
        // all of a sample's responsibility on its first delay: its residuals are that delay's
        let w = Weights {
            channels: vec![[1.0; 2]; n + 1],
            picks: [1.0, 0.0].repeat(n + 1),
        };
        let mixture = Twin {
            weights: Some(&w),
            ..twin
        };
        let res = mixture.residuals(&r, 0, n, s0);
        assert_eq!(res.len(), 4 * (n + 1));
        assert_eq!(res[1], picks[0][1] - r.x2_m[0]);
        assert_eq!((res[2], res[3]), (0.0, 0.0));
    }

    #[test]
    fn a_quadratic_is_read_back_with_its_slope() {
        let pts: Vec<(f64, f64)> = (-5..=5)
            .map(|i| {
                let t = f64::from(i) * 0.1;
                (t, 2.0 + 3.0 * t - t * t)
            })
            .collect();
        let (v, s) = quadratic_at_zero(&pts);
        assert!(
            (v - 2.0).abs() < 1e-12 && (s - 3.0).abs() < 1e-12,
            "{v} {s}"
        );
    }
}
