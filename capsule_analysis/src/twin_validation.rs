//! How well a twin predicts a recording it was not fitted to: the position error over
//! horizons of 1, 5 and 20 drive periods, each started from the state the period before the
//! start measured (at up to [`MAX_STARTS`] periods spread over the recording), the progression
//! per period recorded against predicted, and where the twin errs most.

use crate::twin::{fit_window, window_samples, windows, Forcing, Recorded, SensorPick, Twin};
use capsule_plant::scene::Scene;
use capsule_plant::State;
use rayon::prelude::*;
use serde::Serialize;

/// The horizons, in drive periods.
pub const HORIZONS: [usize; 3] = [1, 5, 20];

/// Most predictions a validation starts, at periods spread evenly over the recording: each
/// costs a window fit and 21 periods of the twin, and 30 s of data has 333 periods (started at
/// every one, the validation cost up to a third of the fit; 64 starts put over 10,000 samples into
/// each horizon's RMS).
pub const MAX_STARTS: usize = 64;

/// The error over one horizon.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HorizonError {
    /// Drive periods predicted.
    pub periods: usize,
    /// Predictions made (one started at each of up to `MAX_STARTS` periods).
    pub starts: usize,
    /// RMS error of `x2` at the horizon's end \[m\].
    pub capsule_end_m: f64,
    /// RMS error of `x1 - x2` at the horizon's end \[m\].
    pub displacement_end_m: f64,
    /// RMS error of `x2` over the horizon \[m\].
    pub capsule_rms_m: f64,
    /// RMS error of `x1 - x2` over the horizon \[m\].
    pub displacement_rms_m: f64,
    /// Mean progression per period over the horizons, predicted \[m\].
    pub predicted_progression_m: f64,
    /// The same, recorded \[m\].
    pub recorded_progression_m: f64,
}

/// What the validation found.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Validation {
    /// Drive periods in the recording.
    pub periods: f64,
    /// The errors by horizon.
    pub horizons: Vec<HorizonError>,
    /// Progression per drive period, recorded \[m\].
    pub recorded_progression_m: f64,
    /// Predicted from the first measured state, driven by the recorded force over the whole
    /// recording \[m\].
    pub predicted_progression_m: f64,
    /// `predicted / recorded - 1`.
    pub progression_error: f64,
    /// One-period prediction error of `x1 - x2` by drive phase (8 bins of an eighth) \[m\].
    pub error_by_phase_m: Vec<f64>,
    /// The same, split by whether the recorded mass was past the gap (in contact) \[m\].
    pub error_in_contact_m: f64,
    /// Out of contact \[m\].
    pub error_free_m: f64,
    /// What the twin gets wrong and where, in words.
    pub findings: Vec<String>,
    /// For a picture: time \[s\], recorded and predicted `x2` \[m\] (whole run, thinned).
    pub trace_capsule: Vec<[f64; 3]>,
    /// Time \[s\], recorded and one-period-predicted `x1 - x2` \[m\] (the first periods).
    pub trace_displacement: Vec<[f64; 3]>,
}

fn rms(v: &[f64]) -> f64 {
    if v.is_empty() {
        f64::NAN
    } else {
        (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
    }
}

/// Predictions of `len` samples from their starts: (start sample, [x1 - x2, x2] per sample).
type Runs = [(usize, Vec<[f64; 2]>)];

/// The error of the predictions `hp` drive periods (`n` samples each) from their starts.
fn horizon_error(hp: usize, n: usize, runs: &Runs, rec: &Recorded) -> HorizonError {
    let len = hp * n;
    let (mut end_x2, mut end_rel, mut all_x2, mut all_rel) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let (mut pred, mut meas, mut count) = (0.0, 0.0, 0usize);
    for (start, out) in runs {
        if out.len() <= len || !rec.measured(start + len) || !rec.measured(*start) {
            continue;
        }
        for (i, p) in out.iter().enumerate().take(len + 1) {
            let k = start + i;
            if rec.measured(k) {
                all_rel.push(p[0] - rec.rel_m[k]);
                all_x2.push(p[1] - rec.x2_m[k]);
            }
        }
        end_rel.push(out[len][0] - rec.rel_m[start + len]);
        end_x2.push(out[len][1] - rec.x2_m[start + len]);
        pred += out[len][1] - out[0][1];
        meas += rec.x2_m[start + len] - rec.x2_m[*start];
        count += 1;
    }
    let per = (count * hp).max(1) as f64;
    HorizonError {
        periods: hp,
        starts: count,
        capsule_end_m: rms(&end_x2),
        displacement_end_m: rms(&end_rel),
        capsule_rms_m: rms(&all_x2),
        displacement_rms_m: rms(&all_rel),
        predicted_progression_m: pred / per,
        recorded_progression_m: meas / per,
    }
}

/// Where the one-period predictions err: the RMS by eighth of the drive period, and the errors
/// in contact and free.
fn errors_by_phase(
    runs: &Runs,
    n: usize,
    rec: &Recorded,
    gap_m: f64,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut by_phase = vec![Vec::new(); 8];
    let (mut contact, mut free) = (Vec::new(), Vec::new());
    for (start, out) in runs {
        for (i, p) in out.iter().enumerate().take(n + 1) {
            let k = start + i;
            if !rec.measured(k) {
                continue;
            }
            let e = p[0] - rec.rel_m[k];
            let phase = ((k % n) * 8 / n).min(7);
            by_phase[phase].push(e);
            if rec.rel_m[k] >= gap_m {
                contact.push(e);
            } else {
                free.push(e);
            }
        }
    }
    (by_phase.iter().map(|v| rms(v)).collect(), contact, free)
}

/// The twin of `scene` on the recorded `forcing`, every residual weighed alike.
fn unweighted<'a>(
    scene: &'a Scene,
    forcing: &'a Forcing,
    pick: &'a SensorPick,
    delay_s: f64,
) -> Twin<'a> {
    Twin {
        scene,
        forcing,
        pick,
        weights: None,
        delay_s,
    }
}

/// Validates `scene` (with measurement delay `delay_s`) on `rec`. `None` when the recording is
/// shorter than two drive periods.
pub fn validate(scene: &Scene, delay_s: f64, rec: &Recorded) -> Option<Validation> {
    let n = window_samples(scene, rec.h_s, 1.0);
    let starts = windows(rec, n);
    if starts.len() < 2 {
        return None;
    }
    let forcing = Forcing::new(rec, scene.device.as_ref());
    let pick = SensorPick::new(scene.device.as_ref(), rec.h_s);
    let twin = unweighted(scene, &forcing, &pick, delay_s);
    let half = (n / 16).max(3);
    let longest = *HORIZONS.iter().max().unwrap_or(&1);
    // each prediction starts at the end of a measured period, from the state fitted to it
    let every = starts.len().div_ceil(MAX_STARTS).max(1);
    let spread: Vec<usize> = starts.iter().step_by(every).copied().collect();
    let runs: Vec<(usize, Vec<[f64; 2]>)> = spread
        .par_iter()
        .filter_map(|a| {
            let fit = fit_window(&twin, rec, *a, n, twin.guess(rec, *a, half));
            let mut tmp = Vec::new();
            let s0 = twin.run(*a, n, fit.state, &mut tmp).ok()?;
            let start = a + n;
            let steps = (longest * n).min(rec.len().saturating_sub(start + 1));
            let mut out = Vec::with_capacity(steps + 1);
            twin.run(start, steps, s0, &mut out).ok()?;
            Some((start, out))
        })
        .collect();
    let horizons = HORIZONS
        .iter()
        .map(|&hp| horizon_error(hp, n, &runs, rec))
        .collect();
    // the whole recording from its first measured period's state
    let a0 = starts[0];
    let fit = fit_window(&twin, rec, a0, n, twin.guess(rec, a0, half));
    let mut whole = Vec::with_capacity(rec.len() - a0);
    let last = (a0..rec.len())
        .rev()
        .find(|k| rec.measured(*k))
        .unwrap_or(a0);
    let ok = twin.run(a0, last - a0, fit.state, &mut whole).is_ok();
    let periods = (last - a0) as f64 / n as f64;
    let recorded = (rec.x2_m[last] - rec.x2_m[a0]) / periods;
    let predicted = if ok && whole.len() > last - a0 {
        (whole[last - a0][1] - whole[0][1]) / periods
    } else {
        f64::NAN
    };
    // where the one-period predictions err: by drive phase, in contact or not
    let gap_m = scene.model.capsule.delta * scene.physical.length_m();
    let (error_by_phase_m, contact, free) = errors_by_phase(&runs, n, rec, gap_m);
    let progression_error = predicted / recorded - 1.0;
    let horizons: Vec<HorizonError> = horizons;
    let findings = findings(
        &horizons,
        &error_by_phase_m,
        (rms(&contact), rms(&free)),
        progression_error,
    );
    let thin = (rec.len() / 2000).max(1);
    let trace_capsule = (0..whole.len())
        .step_by(thin)
        .filter(|i| rec.measured(a0 + i))
        .map(|i| [(a0 + i) as f64 * rec.h_s, rec.x2_m[a0 + i], whole[i][1]])
        .collect();
    let mut trace_displacement = Vec::new();
    for (start, out) in runs.iter().take(6) {
        for (i, p) in out.iter().enumerate().take(n + 1) {
            let k = start + i;
            if rec.measured(k) {
                trace_displacement.push([k as f64 * rec.h_s, rec.rel_m[k], p[0]]);
            }
        }
    }
    Some(Validation {
        periods,
        horizons,
        recorded_progression_m: recorded,
        predicted_progression_m: predicted,
        progression_error,
        error_by_phase_m,
        error_in_contact_m: rms(&contact),
        error_free_m: rms(&free),
        findings,
        trace_capsule,
        trace_displacement,
    })
}

/// The validation in words.
fn findings(
    horizons: &[HorizonError],
    by_phase: &[f64],
    (contact, free): (f64, f64),
    progression_error: f64,
) -> Vec<String> {
    let mut out = Vec::new();
    out.push(if progression_error.is_finite() {
        format!(
            "progression per period: the twin predicts {:+.1} % of the recorded",
            100.0 * progression_error
        )
    } else {
        "progression per period: no comparison (the twin's run over the recording failed, or the capsule did not move)".into()
    });
    // the horizons the run was long enough for
    let told: Vec<&HorizonError> = horizons.iter().filter(|h| h.starts > 0).collect();
    if let (Some(first), Some(last)) = (told.first(), told.last()) {
        out.push(format!(
            "the capsule's position error grows from {:.1} um after {} period(s) to {:.1} um after {} (RMS at the horizon's end)",
            first.capsule_end_m * 1e6,
            first.periods,
            last.capsule_end_m * 1e6,
            last.periods
        ));
    }
    if let Some((worst, e)) = by_phase
        .iter()
        .enumerate()
        .filter(|(_, e)| e.is_finite())
        .max_by(|a, b| a.1.total_cmp(b.1))
    {
        out.push(format!(
            "x1 - x2 errs most in the {}th eighth of a drive period ({:.1} um RMS over one period's prediction)",
            worst + 1,
            e * 1e6
        ));
    }
    if contact.is_finite() && free.is_finite() {
        out.push(format!(
            "with the mass past the gap (on the stop) the error is {:.1} um RMS, away from it {:.1} um: {}",
            contact * 1e6,
            free * 1e6,
            if contact > 1.5 * free {
                "the impacts are where the twin is least right"
            } else {
                "the impacts are modelled as well as the free flight"
            }
        ));
    }
    out
}

/// The state the twin gives `rec` at the end of its first measured period (for tools that run
/// the twin on from there).
pub fn first_state(scene: &Scene, delay_s: f64, rec: &Recorded) -> Option<(usize, State)> {
    let n = window_samples(scene, rec.h_s, 1.0);
    let a = *windows(rec, n).first()?;
    let forcing = Forcing::new(rec, scene.device.as_ref());
    let pick = SensorPick::new(scene.device.as_ref(), rec.h_s);
    let twin = unweighted(scene, &forcing, &pick, delay_s);
    let fit = fit_window(&twin, rec, a, n, twin.guess(rec, a, (n / 16).max(3)));
    Some((a, fit.state))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn horizon(periods: usize, starts: usize, end_m: f64) -> HorizonError {
        HorizonError {
            periods,
            starts,
            capsule_end_m: end_m,
            displacement_end_m: end_m,
            capsule_rms_m: end_m,
            displacement_rms_m: end_m,
            predicted_progression_m: 0.0,
            recorded_progression_m: 0.0,
        }
    }

    #[test]
    fn the_findings_say_what_is_there_and_print_no_nan() {
        // 20 periods did not fit in the run, and the twin's whole run failed
        let h = [
            horizon(1, 10, 2e-6),
            horizon(5, 4, 9e-6),
            horizon(20, 0, f64::NAN),
        ];
        let phases = [1e-6; 8];
        let f = findings(&h, &phases, (f64::NAN, 1e-6), f64::NAN);
        let text = f.join("\n");
        assert!(!text.contains("NaN"), "{text}");
        assert!(text.contains("no comparison"), "{text}");
        assert!(text.contains("after 5"), "{text}");
        let f = findings(&h[..1], &phases, (2e-6, 1e-6), 0.01);
        assert!(f[0].contains("+1.0 %") && f[1].contains("after 1"), "{f:?}");
    }
}
