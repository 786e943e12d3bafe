//! A small SVG writer for sweep plots: a bifurcation diagram (Poincaré `y1` per value) above the
//! average progression per value. Hand-written to keep the build free of a plotting stack.

use capsule_analysis::SweepPoint;
use std::fmt::Write;

const W: f64 = 900.0;
const PANEL_H: f64 = 300.0;
const LEFT: f64 = 80.0;
const TOP: f64 = 40.0;
const GAP: f64 = 60.0;

struct Axis {
    lo: f64,
    hi: f64,
}

impl Axis {
    fn of(values: impl Iterator<Item = f64>) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            return Axis { lo: 0.0, hi: 1.0 };
        }
        if hi - lo < 1e-12 {
            return Axis {
                lo: lo - 0.5,
                hi: hi + 0.5,
            };
        }
        let pad = 0.04 * (hi - lo);
        Axis {
            lo: lo - pad,
            hi: hi + pad,
        }
    }
    fn map(&self, v: f64, a: f64, b: f64) -> f64 {
        a + (v - self.lo) / (self.hi - self.lo) * (b - a)
    }
}

fn panel(out: &mut String, top: f64, x: &Axis, y: &Axis, xlabel: &str, ylabel: &str) {
    let right = W - 20.0;
    let bottom = top + PANEL_H;
    let _ = writeln!(
        out,
        r#"<rect x="{LEFT}" y="{top}" width="{}" height="{PANEL_H}" fill="none" stroke="black"/>"#,
        right - LEFT
    );
    for i in 0..=4 {
        let fx = x.lo + (x.hi - x.lo) * i as f64 / 4.0;
        let px = x.map(fx, LEFT, right);
        let _ = writeln!(
            out,
            r#"<text x="{px:.1}" y="{:.1}" font-size="12" text-anchor="middle">{fx:.3}</text>"#,
            bottom + 16.0
        );
        let fy = y.lo + (y.hi - y.lo) * i as f64 / 4.0;
        let py = y.map(fy, bottom, top);
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{py:.1}" font-size="12" text-anchor="end">{fy:.3}</text>"#,
            LEFT - 6.0
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="14" text-anchor="middle">{xlabel}</text>"#,
        (LEFT + right) / 2.0,
        bottom + 34.0
    );
    let _ = writeln!(
        out,
        r#"<text x="16" y="{:.1}" font-size="14" transform="rotate(-90 16 {:.1})" text-anchor="middle">{ylabel}</text>"#,
        (top + bottom) / 2.0,
        (top + bottom) / 2.0
    );
}

/// The sweep as an SVG document.
pub fn bifurcation(title: &str, param: &str, points: &[SweepPoint]) -> String {
    let ok: Vec<(f64, &capsule_analysis::RunReport)> = points
        .iter()
        .filter_map(|p| p.result.as_ref().ok().map(|r| (p.value, r)))
        .collect();
    let x = Axis::of(points.iter().map(|p| p.value));
    let y1 = Axis::of(ok.iter().flat_map(|(_, r)| r.poincare.iter().map(|q| q[2])));
    let prog = Axis::of(ok.iter().map(|(_, r)| r.avg_progression));
    let height = TOP + 2.0 * PANEL_H + GAP + 60.0;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="24" font-size="16" text-anchor="middle">{title}</text>"#,
        W / 2.0
    );
    let right = W - 20.0;
    panel(&mut out, TOP, &x, &y1, param, "y1 (Poincaré)");
    for (v, r) in &ok {
        let px = x.map(*v, LEFT, right);
        for q in &r.poincare {
            let py = y1.map(q[2], TOP + PANEL_H, TOP);
            let _ = writeln!(
                out,
                r#"<circle cx="{px:.2}" cy="{py:.2}" r="0.7" fill="black"/>"#
            );
        }
    }
    let top2 = TOP + PANEL_H + GAP;
    panel(&mut out, top2, &x, &prog, param, "progression / period");
    let mut path = String::new();
    for (i, (v, r)) in ok.iter().enumerate() {
        let px = x.map(*v, LEFT, right);
        let py = prog.map(r.avg_progression, top2 + PANEL_H, top2);
        let _ = write!(path, "{}{px:.2},{py:.2} ", if i == 0 { "M" } else { "L" });
    }
    let _ = writeln!(
        out,
        r#"<path d="{path}" fill="none" stroke="steelblue" stroke-width="1.2"/>"#
    );
    let _ = writeln!(out, "</svg>");
    out
}
