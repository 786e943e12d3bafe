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

/// A named curve for [`loglog`].
pub struct Series {
    /// Legend text.
    pub name: String,
    /// SVG colour.
    pub colour: &'static str,
    /// Points (x, y), both positive.
    pub points: Vec<(f64, f64)>,
}

/// A log-log plot with one polyline and markers per series, decade grid and a legend.
pub fn loglog(title: &str, xlabel: &str, ylabel: &str, series: &[Series]) -> String {
    let all = || series.iter().flat_map(|s| s.points.iter().copied());
    let lx = Axis::of(all().filter(|p| p.0 > 0.0).map(|p| p.0.log10()));
    let ly = Axis::of(all().filter(|p| p.1 > 0.0).map(|p| p.1.log10()));
    let (lx, ly) = (decades(lx), decades(ly));
    let height = TOP + PANEL_H + 80.0;
    let right = W - 180.0;
    let bottom = TOP + PANEL_H;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{height}" viewBox="0 0 {W} {height}">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="24" font-size="16" text-anchor="middle">{title}</text>"#,
        (LEFT + right) / 2.0
    );
    let _ = writeln!(
        out,
        r#"<rect x="{LEFT}" y="{TOP}" width="{}" height="{PANEL_H}" fill="none" stroke="black"/>"#,
        right - LEFT
    );
    for d in (lx.lo as i32)..=(lx.hi as i32) {
        let px = lx.map(d as f64, LEFT, right);
        let _ = writeln!(
            out,
            r#"<line x1="{px:.1}" y1="{TOP}" x2="{px:.1}" y2="{bottom}" stroke="lightgrey"/>"#
        );
        let _ = writeln!(
            out,
            r#"<text x="{px:.1}" y="{:.1}" font-size="12" text-anchor="middle">1e{d}</text>"#,
            bottom + 16.0
        );
    }
    for d in (ly.lo as i32)..=(ly.hi as i32) {
        let py = ly.map(d as f64, bottom, TOP);
        let _ = writeln!(
            out,
            r#"<line x1="{LEFT}" y1="{py:.1}" x2="{right}" y2="{py:.1}" stroke="lightgrey"/>"#
        );
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="end">1e{d}</text>"#,
            LEFT - 6.0,
            py + 4.0
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="14" text-anchor="middle">{xlabel}</text>"#,
        (LEFT + right) / 2.0,
        bottom + 36.0
    );
    let mid = (TOP + bottom) / 2.0;
    let _ = writeln!(
        out,
        r#"<text x="16" y="{mid:.1}" font-size="14" transform="rotate(-90 16 {mid:.1})" text-anchor="middle">{ylabel}</text>"#
    );
    for (i, s) in series.iter().enumerate() {
        let mut path = String::new();
        for (j, &(x, y)) in s
            .points
            .iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .enumerate()
        {
            let px = lx.map(x.log10(), LEFT, right);
            let py = ly.map(y.log10(), bottom, TOP);
            let _ = write!(path, "{}{px:.2},{py:.2} ", if j == 0 { "M" } else { "L" });
            let _ = writeln!(
                out,
                r#"<circle cx="{px:.2}" cy="{py:.2}" r="3.5" fill="{}"/>"#,
                s.colour
            );
        }
        let _ = writeln!(
            out,
            r#"<path d="{path}" fill="none" stroke="{}" stroke-width="1.5"/>"#,
            s.colour
        );
        let ly_leg = TOP + 20.0 + 22.0 * i as f64;
        let _ = writeln!(
            out,
            r#"<circle cx="{:.1}" cy="{ly_leg:.1}" r="5" fill="{}"/>"#,
            right + 20.0,
            s.colour
        );
        let _ = writeln!(
            out,
            r#"<text x="{:.1}" y="{:.1}" font-size="13">{}</text>"#,
            right + 32.0,
            ly_leg + 4.0,
            s.name
        );
    }
    let _ = writeln!(out, "</svg>");
    out
}

/// An axis widened to whole decades.
fn decades(a: Axis) -> Axis {
    Axis {
        lo: a.lo.floor(),
        hi: a.hi.ceil().max(a.lo.floor() + 1.0),
    }
}
