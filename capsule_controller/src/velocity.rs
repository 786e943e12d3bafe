//! Velocities a real capsule does not measure. A prototype's displacement sensor and encoder give
//! positions; its state message then carries NaN velocities (capsule_msgs/CapsuleState: "NaN:
//! not measured"). The paper's law needs none (`u = k_p |x2 - x1|` and the drive phase), nor do
//! the progression and efficiency (eq. 4's work is the held force times the mass's
//! displacement); only the Poincaré section of the orbit watch and the attractor switch
//! interpolate with velocities. For those, [`LineFit`] estimates them from the positions.
//!
//! The filter: a least-squares straight line through each position's last `window` samples,
//! read at the window's middle (a centred first-order Savitzky-Golay filter). Why this one:
//! - it is a finite window: a fault, a reconnect or an impact leaves it after `window` samples,
//!   and it cannot go unstable (no state fed back, unlike an alpha-beta or Kalman tracker);
//! - read at the middle, the slope is exact to second order (a quadratic's slope is exact), the
//!   noise is averaged: position noise `sigma` becomes `sigma / sqrt(N)` on the position and
//!   `sigma sqrt(12 / (N (N^2 - 1))) / h` on the velocity (`N` samples `h` apart), against
//!   `sigma sqrt(2) / h` for a backward difference;
//! - its one cost is a fixed lag of `(N - 1) / 2` samples, and the estimate says so: it is
//!   stamped with the middle sample's time. The section is then taken at the right drive phase,
//!   only later, so an orbit's period is still recognised.
//! - one constant, the window's length in time, with a rule: [`LineFit::for_period`] takes an
//!   eighth of a drive period. `capsule robustness` measured it on the typical device (1 %
//!   noise, 1 kHz, the control point): the estimate's RMS error on the mass velocity is 0.87
//!   for a backward difference, 0.09 over 9 samples, 0.073 over 12 (the eighth), 0.09 over 18
//!   and 0.22 over 36, where the line no longer follows the orbit (docs/robustness).

use std::collections::VecDeque;

/// A least-squares line through the last positions: positions and velocities at its middle.
#[derive(Debug, Clone, PartialEq)]
pub struct LineFit {
    /// The window's length (non-dimensional time): samples at most this much older than the
    /// newest are fitted.
    span: f64,
    /// The window's samples: time and the two positions (non-dimensional).
    recent: VecDeque<(f64, f64, f64)>,
}

impl LineFit {
    /// A fit over the samples of the last `span` (non-dimensional time; one sample step is the
    /// difference of the last two samples, `N - 1` steps a window of `N` samples).
    pub fn new(span: f64) -> LineFit {
        LineFit {
            span: if span.is_finite() { span.max(0.0) } else { 0.0 },
            recent: VecDeque::new(),
        }
    }

    /// The fit for a drive of period `period`: an eighth of it.
    pub fn for_period(period: f64) -> LineFit {
        LineFit::new(period / 8.0)
    }

    /// The window's length (non-dimensional time).
    pub fn span(&self) -> f64 {
        self.span
    }

    /// Forgets the samples (a new plant, a jump back in time).
    pub fn reset(&mut self) {
        self.recent.clear();
    }

    /// Adds a sample. A sample with both velocities measured is returned as it is, at `tau`;
    /// otherwise the fit's `(tau, [x1, y1, x2, y2])` at the middle of the window (both
    /// velocities from the positions), or `None` while the window holds one sample. A time
    /// that does not advance starts the window afresh.
    pub fn state(
        &mut self,
        tau: f64,
        x1: f64,
        y1: f64,
        x2: f64,
        y2: f64,
    ) -> Option<(f64, [f64; 4])> {
        if self
            .recent
            .back()
            .is_some_and(|(t, _, _)| tau.partial_cmp(t) != Some(std::cmp::Ordering::Greater))
        {
            self.recent.clear();
        }
        // a relative margin, so that N samples h apart fit in a span of (N - 1) h
        let oldest = tau - self.span * (1.0 + 1e-9);
        while self.recent.front().is_some_and(|(t, _, _)| *t < oldest) {
            self.recent.pop_front();
        }
        self.recent.push_back((tau, x1, x2));
        if y1.is_finite() && y2.is_finite() {
            return Some((tau, [x1, y1, x2, y2]));
        }
        if self.recent.len() < 2 {
            return None;
        }
        let n = self.recent.len() as f64;
        let (mut t, mut a, mut b) = (0.0, 0.0, 0.0);
        for (ti, ai, bi) in &self.recent {
            t += ti;
            a += ai;
            b += bi;
        }
        let (t, a, b) = (t / n, a / n, b / n);
        let (mut tt, mut ta, mut tb) = (0.0, 0.0, 0.0);
        for (ti, ai, bi) in &self.recent {
            let d = ti - t;
            tt += d * d;
            ta += d * (ai - a);
            tb += d * (bi - b);
        }
        // the line through the means, read at the mean time: positions are the means
        Some((t, [a, ta / tt, b, tb / tt]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measured_velocities_pass_and_missing_ones_are_fitted() {
        let mut d = LineFit::new(0.25);
        // both measured: the sample itself, at once
        assert_eq!(
            d.state(0.0, 1.0, 4.0, 2.0, 5.0),
            Some((0.0, [1.0, 4.0, 2.0, 5.0]))
        );
        // x1 moved 0.5 in 0.25 (2.0), x2 1.0 (4.0): read at the middle, 0.125
        assert_eq!(
            d.state(0.25, 1.5, f64::NAN, 3.0, 7.0),
            Some((0.125, [1.25, 2.0, 2.5, 4.0]))
        );
        // time standing still starts afresh: no estimate, not a division by zero
        assert_eq!(d.state(0.25, 9.0, f64::NAN, 3.0, f64::NAN), None);
        let mut w = LineFit::new(2.0);
        assert_eq!(w.state(0.0, 0.0, f64::NAN, 0.0, f64::NAN), None);
        w.state(1.0, 1.0, f64::NAN, 0.0, f64::NAN);
        let s = w.state(2.0, 4.0, f64::NAN, 0.0, f64::NAN);
        // 0, 1, 4 (x = t^2): the line's slope is 2, the slope of t^2 at the middle (t = 1)
        assert_eq!(s.map(|(t, x)| (t, x[1])), Some((1.0, 2.0)));
        // the next sample drops the oldest: 1, 4, 9 at 1, 2, 3 give 4 at t = 2
        let s = w.state(3.0, 9.0, f64::NAN, 0.0, f64::NAN);
        assert_eq!(s.map(|(t, x)| (t, x[1])), Some((2.0, 4.0)));
    }

    #[test]
    fn on_a_sine_the_fit_is_second_order_and_late_by_half_the_window() {
        // x = sin t sampled at h, window 11: the slope at the middle is cos to O((N h)^2)
        let h = 1e-3;
        let mut d = LineFit::new(10.0 * h);
        let mut worst: f64 = 0.0;
        for k in 0..5000 {
            let t = k as f64 * h;
            if let (true, Some((tm, s))) = (k >= 10, d.state(t, t.sin(), f64::NAN, 0.0, f64::NAN)) {
                assert!((tm - (t - 5.0 * h)).abs() < 1e-12, "{tm} {t}");
                worst = worst.max((s[1] - tm.cos()).abs());
            }
        }
        // N^2 h^2 / 20 for the cubic term: 3e-5
        assert!(worst < 1e-5, "{worst}");
    }

    #[test]
    fn it_averages_noise_as_the_formula_says() {
        // white noise of 1 on a still position, h = 1: velocity noise sqrt(12 / (N (N^2 - 1)))
        let n = 21;
        let mut d = LineFit::new(20.0);
        let mut state: u64 = 7;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let (mut sum, mut count) = (0.0, 0usize);
        for k in 0..200_000 {
            // variance of uniform(-sqrt3, sqrt3) is 1
            let x = (uniform() * 2.0 - 1.0) * 3f64.sqrt();
            if let (true, Some((_, s))) = (k >= 20, d.state(k as f64, x, f64::NAN, 0.0, f64::NAN)) {
                sum += s[1] * s[1];
                count += 1;
            }
        }
        let rms = (sum / count as f64).sqrt();
        let nf = n as f64;
        let expected = (12.0 / (nf * (nf * nf - 1.0))).sqrt();
        assert!((rms / expected - 1.0).abs() < 0.03, "{rms} {expected}");
    }

    #[test]
    fn the_window_is_an_eighth_of_the_period() {
        assert_eq!(LineFit::for_period(8.0).span(), 1.0);
        assert_eq!(LineFit::new(f64::NAN).span(), 0.0);
        // a zero span keeps one sample: no estimate, never a division by zero
        let mut d = LineFit::new(0.0);
        assert_eq!(d.state(0.0, 1.0, f64::NAN, 0.0, f64::NAN), None);
        assert_eq!(d.state(1.0, 2.0, f64::NAN, 0.0, f64::NAN), None);
    }
}
