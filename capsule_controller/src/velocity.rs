//! Velocities a real capsule does not measure. A prototype's displacement sensor and encoder give
//! positions; its state message then carries NaN velocities (capsule_msgs: "NaN: not
//! measured"). The paper's law needs none (`u = k_p |x2 - x1|` and the drive phase), nor do the
//! progression and efficiency (eq. 4's work is the held force times the mass's displacement);
//! only the Poincaré section of the orbit watch and the attractor switch interpolate with
//! velocities. For those, a missing velocity is the backward difference of the last two
//! positions.
//!
//! Why a plain backward difference: it is causal, has no tuning constant, and on a periodic
//! orbit its error (half a sample's acceleration, O(h)) repeats every period, so the section
//! points of one orbit still coincide and its period is still recognised. What it does not do is
//! reject noise: with noisy positions it multiplies the noise by 1/h; a device with a noisy
//! sensor needs a filter in front of it. Not chosen yet: the robustness study
//! (`capsule robustness`, docs/hardware.md) measures the law, which needs no velocity, and not
//! the orbit watch, which does.

/// Fills in velocities from consecutive positions where the sample has none.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct BackwardDifference {
    /// The last sample: time and the two positions (non-dimensional).
    last: Option<(f64, f64, f64)>,
}

impl BackwardDifference {
    /// The state `[x1, y1, x2, y2]` at `tau`, each non-finite velocity replaced by the backward
    /// difference of its position (zero at the first sample, or after time did not advance).
    pub fn state(&mut self, tau: f64, x1: f64, y1: f64, x2: f64, y2: f64) -> [f64; 4] {
        let estimate = match self.last {
            Some((t0, a, b)) if tau > t0 => [(x1 - a) / (tau - t0), (x2 - b) / (tau - t0)],
            _ => [0.0, 0.0],
        };
        self.last = Some((tau, x1, x2));
        let pick = |measured: f64, est: f64| if measured.is_finite() { measured } else { est };
        [x1, pick(y1, estimate[0]), x2, pick(y2, estimate[1])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measured_velocities_pass_and_missing_ones_are_differences() {
        let mut d = BackwardDifference::default();
        assert_eq!(d.state(0.0, 1.0, f64::NAN, 2.0, 5.0), [1.0, 0.0, 2.0, 5.0]);
        // x1 moved 0.5 in 0.25: 2.0; x2's measured velocity is kept
        assert_eq!(d.state(0.25, 1.5, f64::NAN, 3.0, 7.0), [1.5, 2.0, 3.0, 7.0]);
        assert_eq!(
            d.state(0.5, 1.0, f64::NAN, 3.0, f64::NAN),
            [1.0, -2.0, 3.0, 0.0]
        );
        // time standing still gives no estimate, not a division by zero
        assert_eq!(
            d.state(0.5, 9.0, f64::NAN, 3.0, f64::NAN),
            [9.0, 0.0, 3.0, 0.0]
        );
    }

    #[test]
    fn on_a_sine_the_estimate_lags_by_half_a_sample() {
        // x = sin t sampled at h: the difference is cos(t - h/2) to O(h^2)
        let h = 1e-3;
        let mut d = BackwardDifference::default();
        let mut worst: f64 = 0.0;
        for k in 0..5000 {
            let t = k as f64 * h;
            let s = d.state(t, t.sin(), f64::NAN, 0.0, 0.0);
            if k > 0 {
                worst = worst.max((s[1] - (t - h / 2.0).cos()).abs());
            }
        }
        assert!(worst < h * h, "{worst}");
    }
}
