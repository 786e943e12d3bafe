//! Locating the first upward zero crossing of a smooth scalar function on an interval.
//!
//! Event functions are written so that the current regime is valid while `g <= 0`; an event is
//! the first time `g` becomes positive. Both solvers hand in `g` over one step (an exact power
//! series, or the Runge-Kutta dense output). The step is short compared with the dynamics (the
//! solvers bound it), so sampling it at a few points and checking the derivative for a hidden
//! maximum between samples finds grazing crossings that a sign check at the ends would miss.

/// Samples per step for crossing detection (the solvers keep steps short enough that `g`
/// turns at most once between samples).
pub const SAMPLES: usize = 4;

/// The points [`first_crossing`] looks at in a step of length `h`: its start and the ends of
/// [`SAMPLES`] equal parts.
pub type Grid = [f64; SAMPLES + 1];

/// `|g|` below this at the start of a step counts as "on the boundary" (just switched there).
pub const BOUNDARY: f64 = 1e-10;

/// A crossing must take `g` above this: excursions of rounding size just after a switch (a
/// velocity that starts at zero with a derivative of `1e-16`) are not events.
pub const NOISE: f64 = 1e-13;

/// First `t` in `(0, h]` where `g` crosses from `<= 0` to `> 0`, or `Some(0.0)` if `g` leaves the
/// valid side immediately. `g` gives the value, `gd` the value and the derivative, `gd_grid`
/// the same as `gd` at every point of a [`Grid`] (all at once: independent evaluations
/// overlap, where one after the other each waits for the last).
pub fn first_crossing(
    g: impl Fn(f64) -> f64,
    gd: impl Fn(f64) -> (f64, f64),
    gd_grid: impl FnOnce(&Grid) -> [(f64, f64); SAMPLES + 1],
    h: f64,
) -> Option<f64> {
    let mut ts: Grid = [0.0; SAMPLES + 1];
    for (i, t) in ts.iter_mut().enumerate().skip(1) {
        *t = h * i as f64 / SAMPLES as f64;
    }
    let values = gd_grid(&ts);
    let (g0_raw, d0) = values[0];
    if g0_raw > BOUNDARY {
        return Some(0.0);
    }
    let on_boundary = g0_raw.abs() <= BOUNDARY;
    // On the boundary, measure from the start value so rounding there is not a crossing.
    let shift = if on_boundary { g0_raw } else { 0.0 };
    let f = |t: f64| g(t) - shift;

    let mut t_prev = 0.0;
    // `f(0.0)`, taken from `gd`'s value at 0 (the two can differ only in the sign of a zero,
    // which `min` and `==` do not see)
    let mut g_prev = 0.0f64.min(g0_raw - shift);
    let mut d_prev = d0;
    for (&t, &(gt, dt)) in ts.iter().zip(&values).skip(1) {
        let gt = gt - shift;
        if gt > NOISE {
            if t_prev == 0.0 && g_prev == 0.0 {
                // Starts on the boundary and is above it at the first sample. If it heads
                // inward first, the crossing is on the way back up, after the minimum.
                if d_prev < 0.0 && dt > 0.0 {
                    let tm = turning_point(&gd, 0.0, d_prev, t, dt);
                    let fm = f(tm);
                    if fm < 0.0 {
                        return Some(refine(&f, (tm, fm), (t, gt)));
                    }
                }
                // The derivative at 0 may be rounding noise: look for a dip on a geometric grid;
                // if there is none, `g` leaves at once.
                let mut last_below = None;
                for frac in [1.0 / 4096.0, 1.0 / 512.0, 1.0 / 64.0, 1.0 / 8.0, 0.5] {
                    let tf = t * frac;
                    let v = f(tf);
                    if v > NOISE {
                        break;
                    }
                    if v < 0.0 {
                        last_below = Some((tf, v));
                    }
                }
                return Some(match last_below {
                    Some(a) => refine(&f, a, (t, gt)),
                    None => 0.0,
                });
            }
            return Some(refine(&f, (t_prev, g_prev), (t, gt)));
        }
        // a maximum hidden between two non-positive samples?
        if d_prev > 0.0 && dt < 0.0 {
            let tm = turning_point(&gd, t_prev, d_prev, t, dt);
            let fm = f(tm);
            if fm > NOISE {
                return Some(refine(&f, (t_prev, g_prev), (tm, fm)));
            }
        }
        t_prev = t;
        g_prev = gt;
        d_prev = dt;
    }
    None
}

/// Where `g'` vanishes in `[a, b]`, given its values `da`, `db` of opposite signs there
/// (Illinois false position on the derivative: a few evaluations, not fifty bisections).
fn turning_point(
    gd: &impl Fn(f64) -> (f64, f64),
    mut a: f64,
    mut da: f64,
    mut b: f64,
    mut db: f64,
) -> f64 {
    // the value at a turning point is flat in t: locating it to 1e-9 of the interval puts
    // the value there within rounding
    let width = 1e-9 * (b - a);
    let mut side = 0;
    for _ in 0..100 {
        if b - a <= width {
            break;
        }
        let mut m = (a * db - b * da) / (db - da);
        if !(m > a && m < b) {
            m = 0.5 * (a + b);
        }
        let dm = gd(m).1;
        if dm == 0.0 {
            return m;
        }
        if (dm > 0.0) == (da > 0.0) {
            a = m;
            da = dm;
            if side == -1 {
                db *= 0.5;
            }
            side = -1;
        } else {
            b = m;
            db = dm;
            if side == 1 {
                da *= 0.5;
            }
            side = 1;
        }
    }
    0.5 * (a + b)
}

/// Root of `f` in `[a, b]` with `f(a) <= 0 < f(b)` (Illinois false position), returning the
/// right end of the final bracket so that `f` at the result is `>= 0` (the event has happened).
/// The ends come with `f`'s values there, which the caller has already evaluated. (The samples'
/// values come from `gd`, whose value can differ from `g`'s in the sign of a zero only: a zero
/// `f(a)` takes no part in the next point, `a fb - b fa` and `fb - fa` being the same for
/// either sign.)
fn refine(
    f: &impl Fn(f64) -> f64,
    (mut a, mut fa): (f64, f64),
    (mut b, mut fb): (f64, f64),
) -> f64 {
    if fa > 0.0 {
        return a;
    }
    let mut side = 0;
    for _ in 0..100 {
        if b - a <= 4.0 * f64::EPSILON * b.abs().max(1e-300) {
            break;
        }
        let mut m = (a * fb - b * fa) / (fb - fa);
        if !(m > a && m < b) {
            m = 0.5 * (a + b);
        }
        let fm = f(m);
        if fm > 0.0 {
            b = m;
            fb = fm;
            if side == 1 {
                fa *= 0.5;
            }
            side = 1;
        } else {
            a = m;
            fa = fm;
            if side == -1 {
                fb *= 0.5;
            }
            side = -1;
        }
        if fm == 0.0 {
            return m;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`first_crossing`] with the grid evaluated point by point.
    fn crossing(g: impl Fn(f64) -> f64, gd: impl Fn(f64) -> (f64, f64), h: f64) -> Option<f64> {
        first_crossing(g, &gd, |ts| ts.map(&gd), h)
    }

    #[test]
    fn finds_a_simple_crossing() {
        let t = crossing(|t| t - 0.3, |t| (t - 0.3, 1.0), 1.0).unwrap_or(f64::NAN);
        assert!((t - 0.3).abs() < 1e-14, "{t}");
    }

    #[test]
    fn finds_a_grazing_crossing_between_samples() {
        // g peaks at t = 0.51 just above zero; both ends and all samples are negative
        let g = |t: f64| 1e-6 - 50.0 * (t - 0.51) * (t - 0.51);
        let dg = |t: f64| -100.0 * (t - 0.51);
        let t = crossing(g, |t| (g(t), dg(t)), 1.0).unwrap_or(f64::NAN);
        let expected = 0.51 - (1e-6f64 / 50.0).sqrt();
        assert!((t - expected).abs() < 1e-12, "{t} vs {expected}");
    }

    #[test]
    fn no_crossing_when_function_stays_below() {
        assert_eq!(
            crossing(|t| -1.0 - t * t, |t| (-1.0 - t * t, -2.0 * t), 2.0),
            None
        );
    }

    #[test]
    fn starting_on_the_boundary_and_moving_in_is_not_an_event() {
        assert_eq!(crossing(|t| 1e-13 - t, |t| (1e-13 - t, -1.0), 1.0), None);
        // ... nor is a derivative of rounding size pointing out while the curve bends in
        let g = |t: f64| {
            (
                5e-17 * t - 8.7e-3 * t * t + 0.0298 * t * t * t,
                5e-17 - 17.4e-3 * t + 0.0894 * t * t,
            )
        };
        let t = crossing(|t| g(t).0, g, 1.6).unwrap_or(f64::NAN);
        assert!((t - 8.7e-3 / 0.0298).abs() < 1e-6, "{t}");
        // ... but moving in then out again is
        let t = crossing(|t| t * (t - 0.5), |t| (t * (t - 0.5), 2.0 * t - 0.5), 1.0)
            .unwrap_or(f64::NAN);
        assert!((t - 0.5).abs() < 1e-12, "{t}");
    }
}
