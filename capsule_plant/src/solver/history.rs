//! The capsule velocity's recent past, for frictional memory (`y2(tau - tau_d)`).
//!
//! Each accepted step stores its dense output for `y2`; a look-up finds the step that covers
//! `tau - tau_d`. Every switch at time `t` makes `y2(tau - tau_d)` non-smooth at `t + tau_d`,
//! so that time is kept as a breakpoint the integrator must step to exactly.

use std::collections::VecDeque;

/// How `y2` varies over one stored step.
#[derive(Debug, Clone, Copy)]
pub(super) enum Piece {
    /// Dormand-Prince continuous extension coefficients for `y2`.
    Dopri([f64; 5]),
    /// Straight line from the start to the end value (fixed-step baseline).
    Line(f64, f64),
}

#[derive(Debug, Clone, Copy)]
struct Segment {
    t0: f64,
    h: f64,
    piece: Piece,
}

/// Velocity history and pending breakpoints.
#[derive(Debug, Clone)]
pub(crate) struct History {
    delay: f64,
    start: f64,
    y2_start: f64,
    segments: VecDeque<Segment>,
    breakpoints: VecDeque<f64>,
}

impl History {
    /// An empty history: before `start` the velocity is taken as `y2_start`.
    pub fn new(delay: f64, start: f64, y2_start: f64) -> Self {
        History {
            delay,
            start,
            y2_start,
            segments: VecDeque::new(),
            breakpoints: VecDeque::new(),
        }
    }

    /// The delay `tau_d`.
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// Store a step `[t0, t0 + h]`.
    pub fn push(&mut self, t0: f64, h: f64, piece: Piece) {
        if h <= 0.0 {
            return;
        }
        self.segments.push_back(Segment { t0, h, piece });
        // keep what a look-up at or after t0 + h can still need
        let keep_from = t0 + h - self.delay - h.max(self.delay);
        while self.segments.len() > 2 && self.segments[0].t0 + self.segments[0].h < keep_from {
            self.segments.pop_front();
        }
    }

    /// `y2(tau - delay)`.
    pub fn delayed(&self, tau: f64) -> f64 {
        let t = tau - self.delay;
        if t <= self.start {
            return self.y2_start;
        }
        let idx = self.segments.partition_point(|s| s.t0 + s.h < t);
        let Some(seg) = self.segments.get(idx).or_else(|| self.segments.back()) else {
            return self.y2_start;
        };
        let th = ((t - seg.t0) / seg.h).clamp(0.0, 1.0);
        match seg.piece {
            Piece::Dopri([r1, r2, r3, r4, r5]) => {
                let th1 = 1.0 - th;
                r1 + th * (r2 + th1 * (r3 + th * (r4 + th1 * r5)))
            }
            Piece::Line(a, b) => a + th * (b - a),
        }
    }

    /// Record a switch at `tau`: `tau + delay` becomes a breakpoint.
    pub fn breakpoint(&mut self, tau: f64) {
        let b = tau + self.delay;
        if self.breakpoints.back().is_none_or(|&last| b > last) {
            self.breakpoints.push_back(b);
        }
    }

    /// The next breakpoint after `tau`, dropping the ones passed.
    pub fn next_breakpoint(&mut self, tau: f64) -> Option<f64> {
        while self.breakpoints.front().is_some_and(|&b| b <= tau) {
            self.breakpoints.pop_front();
        }
        self.breakpoints.front().copied()
    }
}
