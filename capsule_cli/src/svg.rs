//! The one plot layer: a small hand-written SVG writer (panels with round ticks and a light
//! grid, bifurcation diagrams, basin maps, log-log plots) and its rasterisation to PNG.
//!
//! Why not plotters: what takes the lines here is the figures' own content (a basin map as
//! run-length rectangles with the attractors' Poincaré points and a share legend, heat maps
//! whose colour is a share of a reference with the value written in each cell, continuation
//! branches dashed where unstable with their special points, captions under the panels), which
//! plotters would not write for us; its axes and frames are the small part. Its SVG backend
//! would change every figure the docs show, and its PNGs need a font stack (font-kit and the
//! system's fonts, or registering one by hand), where resvg renders our SVG with the embedded
//! font the same on every machine. So the figures stay byte for byte reproducible.

use capsule_analysis::SweepPoint;
use std::fmt::Write;

const W: f64 = 900.0;
const PANEL_H: f64 = 300.0;
const LEFT: f64 = 80.0;
const TOP: f64 = 40.0;

struct Axis {
    lo: f64,
    hi: f64,
}

impl Axis {
    /// The finite values' range, or the axis to draw when it is empty or a single value (a unit
    /// range around it; `tiny` is what counts as a single value).
    fn range_of(
        values: impl Iterator<Item = f64>,
        tiny: impl Fn(f64) -> f64,
    ) -> Result<(f64, f64), Axis> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite()) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            return Err(Axis { lo: 0.0, hi: 1.0 });
        }
        if hi - lo < tiny(lo) {
            return Err(Axis {
                lo: lo - 0.5,
                hi: hi + 0.5,
            });
        }
        Ok((lo, hi))
    }

    /// An axis over `values` with 4 % of the range as margin.
    fn of(values: impl Iterator<Item = f64>) -> Axis {
        let (lo, hi) = match Axis::range_of(values, |_| 1e-12) {
            Ok(r) => r,
            Err(axis) => return axis,
        };
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

/// The sweep as an SVG document: the bifurcation diagram (Poincaré `y1` per value) above the
/// average progression per value.
/// With `lyapunov` (value, largest exponent), a third panel: positive exponents in red.
pub fn bifurcation(
    title: &str,
    param: &str,
    points: &[SweepPoint],
    lyapunov: Option<&[(f64, f64)]>,
) -> String {
    let (dots, line) = bifurcation_panels(param, points);
    let mut all = vec![dots, line];
    if let Some(ly) = lyapunov {
        let finite: Vec<(f64, f64)> = ly.iter().copied().filter(|p| p.1.is_finite()).collect();
        let (lo, hi) = points
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.value), b.max(p.value))
            });
        let dots = |name: &str, colour: &str, keep: fn(f64) -> bool| {
            Curve::new(
                name,
                colour,
                Style::Dots,
                finite.iter().copied().filter(|p| keep(p.1)).collect(),
            )
        };
        all.push(Panel::new(
            "largest Lyapunov exponent",
            param,
            "lambda_1",
            vec![
                Curve::new("", "grey", Style::Dashed, vec![(lo, 0.0), (hi, 0.0)]),
                dots("positive (chaos)", "crimson", |l| l > 0.0),
                dots("not positive", "black", |l| l <= 0.0),
            ],
        ));
    }
    panels(title, &[], 1, (820.0, 280.0), &all)
}

/// Continued branches as an SVG document: `y1` at drive phase 0 against the parameter, stable
/// parts solid, unstable dashed (the first branch black, period-doubled ones in colour), special
/// points marked; `sweep` (brute-force runs) as grey dots underneath.
pub fn continuation(
    title: &str,
    param: &str,
    branches: &[capsule_analysis::continuation::Branch],
    sweep: Option<&[SweepPoint]>,
) -> String {
    use capsule_analysis::continuation::SpecialKind;
    let mut curves = vec![Curve::new(
        if sweep.is_some() {
            "sweep (brute force)".into()
        } else {
            String::new()
        },
        "darkgrey",
        Style::Dots,
        sweep
            .unwrap_or(&[])
            .iter()
            .filter_map(|p| p.result.as_ref().ok().map(|r| (p.value, r)))
            .flat_map(|(v, r)| r.poincare.iter().map(move |q| (v, q[2])))
            .collect(),
    )];
    // the branch in runs of equal stability: solid where stable, dashed where not
    // each branch in runs of equal stability: solid where stable, dashed where not; the first
    // branch black, period-doubled ones in colour
    let colours = ["black", "darkcyan", "darkmagenta", "olive"];
    for (bi, branch) in branches.iter().enumerate() {
        let colour = colours[bi % colours.len()];
        let mut first = [true, true];
        let mut start = 0;
        for run in branch.points.chunk_by(|a, b| a.stable == b.stable) {
            start += run.len();
            // joined to the next run's first point so the branch has no gaps
            let next = branch.points.get(start).map(|p| (p.value, p.x[1]));
            let stable = run[0].stable;
            let k = usize::from(!stable);
            let what = if stable { "stable" } else { "unstable" };
            curves.push(Curve::new(
                if std::mem::take(&mut first[k]) {
                    format!("period {} {what}", branch.period)
                } else {
                    String::new()
                },
                colour,
                if stable { Style::Line } else { Style::Dashed },
                run.iter().map(|p| (p.value, p.x[1])).chain(next).collect(),
            ));
        }
    }
    for (kind, colour, name) in [
        (SpecialKind::PeriodDoubling, "crimson", "period doubling"),
        (SpecialKind::Fold, "darkorange", "fold"),
        (SpecialKind::Torus, "purple", "torus"),
        (SpecialKind::Grazing, "steelblue", "grazing"),
        (SpecialKind::Sticking, "seagreen", "sticking"),
        (SpecialKind::EventSequence, "grey", "event sequence"),
    ] {
        let pts: Vec<(f64, f64)> = branches
            .iter()
            .flat_map(|b| b.special.iter())
            .filter(|sp| sp.kind == kind)
            .map(|sp| (sp.value, sp.x[1]))
            .collect();
        if !pts.is_empty() {
            curves.push(Curve::new(name, colour, Style::Dots, pts));
        }
    }
    let panel = Panel::new("y1 at drive phase 0", param, "y1*", curves);
    panels(title, &[], 1, (820.0, 360.0), &[panel])
}

/// The two panels of a sweep: Poincaré `y1` per value (dots, each pixel once) and the average
/// progression per value.
pub fn bifurcation_panels(param: &str, points: &[SweepPoint]) -> (Panel, Panel) {
    let ok: Vec<(f64, &capsule_analysis::RunReport)> = points
        .iter()
        .filter_map(|p| p.result.as_ref().ok().map(|r| (p.value, r)))
        .collect();
    // one unnamed curve over the parameter
    let panel = |title: &str, ylabel: &str, colour: &str, style: Style, points| {
        Panel::new(
            title,
            param,
            ylabel,
            vec![Curve::new("", colour, style, points)],
        )
    };
    let dots = panel(
        "Poincaré y1 (drive phase 0)",
        "y1*",
        "black",
        Style::Dots,
        ok.iter()
            .flat_map(|(v, r)| r.poincare.iter().map(move |q| (*v, q[2])))
            .collect(),
    );
    let line = panel(
        "average progression per period",
        "progression / period",
        "steelblue",
        Style::Line,
        ok.iter().map(|(v, r)| (*v, r.avg_progression)).collect(),
    );
    (dots, line)
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

/// Tick values at round numbers (1, 2 or 5 times a power of ten) covering `[lo, hi]`, about
/// `target` of them.
pub fn nice_ticks(lo: f64, hi: f64, target: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![lo];
    }
    let raw = (hi - lo) / target.max(1) as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

/// A tick label with as many decimals as the step between ticks needs.
fn tick_label(v: f64, step: f64) -> String {
    let decimals = if step > 0.0 {
        (-(step.log10().floor())).max(0.0) as usize
    } else {
        3
    };
    let v = if v.abs() < step * 1e-9 { 0.0 } else { v };
    format!("{v:.decimals$}")
}

impl Axis {
    /// An axis over `values` widened to the nearest round tick values.
    fn nice(values: impl Iterator<Item = f64>) -> Axis {
        let (lo, hi) = match Axis::range_of(values, |lo| 1e-12 * (1.0 + lo.abs())) {
            Ok(r) => r,
            Err(axis) => return axis,
        };
        let t = nice_ticks(lo, hi, 5);
        let step = if t.len() > 1 { t[1] - t[0] } else { hi - lo };
        Axis {
            lo: (lo / step).floor() * step,
            hi: (hi / step).ceil() * step,
        }
    }
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Style {
    /// A polyline.
    Line,
    /// A dashed polyline.
    Dashed,
    /// Dots.
    Dots,
}

/// A named series of a linear panel.
pub struct Curve {
    /// Legend text (empty: not in the legend).
    pub name: String,
    /// SVG colour.
    pub colour: String,
    /// How it is drawn.
    pub style: Style,
    /// Points (x, y).
    pub points: Vec<(f64, f64)>,
}

/// A panel with linear axes.
pub struct Panel {
    /// Title above the panel.
    pub title: String,
    /// Horizontal axis label.
    pub xlabel: String,
    /// Vertical axis label.
    pub ylabel: String,
    /// The curves.
    pub curves: Vec<Curve>,
    /// Vertical lines (e.g. the impact surface, an event), with colour.
    pub vlines: Vec<(f64, String)>,
}

impl Curve {
    /// A series `name` (empty: not in the legend) drawn in `style` and `colour`.
    pub fn new(
        name: impl Into<String>,
        colour: impl Into<String>,
        style: Style,
        points: Vec<(f64, f64)>,
    ) -> Curve {
        Curve {
            name: name.into(),
            colour: colour.into(),
            style,
            points,
        }
    }
}

impl Panel {
    /// A panel titled `title`, axes labelled `xlabel` and `ylabel`, without vertical lines.
    pub fn new(
        title: impl Into<String>,
        xlabel: impl Into<String>,
        ylabel: impl Into<String>,
        curves: Vec<Curve>,
    ) -> Panel {
        Panel {
            title: title.into(),
            xlabel: xlabel.into(),
            ylabel: ylabel.into(),
            curves,
            vlines: Vec::new(),
        }
    }

    /// The panel with a vertical line at `x` in `colour`.
    pub fn with_vline(mut self, x: f64, colour: impl Into<String>) -> Panel {
        self.vlines.push((x, colour.into()));
        self
    }
}

/// Plot area of a panel in [`panels`] by default (width, height).
pub const PANEL: (f64, f64) = (420.0, 260.0);
const PL: f64 = 70.0;
const PT: f64 = 30.0;
const PR: f64 = 20.0;
const PB: f64 = 50.0;

/// Axes frame with a light grid and round ticks, returns the pixel mapping.
fn frame(
    out: &mut String,
    (ox, oy): (f64, f64),
    (pw, ph): (f64, f64),
    x: &Axis,
    y: &Axis,
    (title, xlabel, ylabel): (&str, &str, &str),
) {
    let (l, t) = (ox + PL, oy + PT);
    let (r, b) = (l + pw, t + ph);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="13" text-anchor="middle">{title}</text>"#,
        (l + r) / 2.0,
        t - 10.0
    );
    let xt = nice_ticks(x.lo, x.hi, 6);
    let yt = nice_ticks(y.lo, y.hi, 5);
    let xs = if xt.len() > 1 { xt[1] - xt[0] } else { 1.0 };
    let ys = if yt.len() > 1 { yt[1] - yt[0] } else { 1.0 };
    for v in &xt {
        let px = x.map(*v, l, r);
        let _ = writeln!(
            out,
            r##"<line x1="{px:.1}" y1="{t:.1}" x2="{px:.1}" y2="{b:.1}" stroke="#e4e4e4"/><text x="{px:.1}" y="{:.1}" font-size="11" text-anchor="middle">{}</text>"##,
            b + 14.0,
            tick_label(*v, xs)
        );
    }
    for v in &yt {
        let py = y.map(*v, b, t);
        let _ = writeln!(
            out,
            r##"<line x1="{l:.1}" y1="{py:.1}" x2="{r:.1}" y2="{py:.1}" stroke="#e4e4e4"/><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="end">{}</text>"##,
            l - 5.0,
            py + 4.0,
            tick_label(*v, ys)
        );
    }
    let _ = writeln!(
        out,
        r#"<rect x="{l:.1}" y="{t:.1}" width="{pw}" height="{ph}" fill="none" stroke="black"/>"#
    );
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">{xlabel}</text>"#,
        (l + r) / 2.0,
        b + 32.0
    );
    let (yx, ym) = (ox + 16.0, (t + b) / 2.0);
    let _ = writeln!(
        out,
        r#"<text x="{yx:.1}" y="{ym:.1}" font-size="12" transform="rotate(-90 {yx:.1} {ym:.1})" text-anchor="middle">{ylabel}</text>"#
    );
}

/// Panels on a grid of `cols` columns under a title (and optional caption lines below), each
/// with a plot area of `size` (see [`PANEL`]).
pub fn panels(
    title: &str,
    caption: &[String],
    cols: usize,
    size: (f64, f64),
    panels: &[Panel],
) -> String {
    let (pw, ph) = size;
    let cols = cols.max(1);
    let rows = panels.len().div_ceil(cols);
    let cw = PL + pw + PR;
    let ch = PT + ph + PB;
    let width = cw * cols as f64;
    let height = 40.0 + ch * rows as f64 + 16.0 * caption.len() as f64 + 10.0;
    let mut out = titled_page(width, height, title);
    for (k, p) in panels.iter().enumerate() {
        let (ox, oy) = (cw * (k % cols) as f64, 40.0 + ch * (k / cols) as f64);
        let all = || p.curves.iter().flat_map(|c| c.points.iter().copied());
        let x = Axis::nice(all().map(|q| q.0).chain(p.vlines.iter().map(|v| v.0)));
        let y = Axis::nice(all().map(|q| q.1));
        frame(
            &mut out,
            (ox, oy),
            size,
            &x,
            &y,
            (&escape(&p.title), &p.xlabel, &p.ylabel),
        );
        let (l, t) = (ox + PL, oy + PT);
        let (r, b) = (l + pw, t + ph);
        let _ = writeln!(
            out,
            r#"<clipPath id="c{k}"><rect x="{l:.1}" y="{t:.1}" width="{pw}" height="{ph}"/></clipPath><g clip-path="url(#c{k})">"#
        );
        for (v, colour) in &p.vlines {
            let px = x.map(*v, l, r);
            let _ = writeln!(
                out,
                r#"<line x1="{px:.1}" y1="{t:.1}" x2="{px:.1}" y2="{b:.1}" stroke="{colour}" stroke-width="1.2"/>"#
            );
        }
        for c in &p.curves {
            let pts = c
                .points
                .iter()
                .map(|&(a, v)| (x.map(a, l, r), y.map(v, b, t)));
            match c.style {
                Style::Dots => {
                    let mut d = String::new();
                    for (px, py) in dedup_pixels(pts) {
                        let _ = write!(d, "M{px:.1},{py:.1}h0.01");
                    }
                    let _ = writeln!(
                        out,
                        r#"<path d="{d}" stroke="{}" stroke-width="2.6" stroke-linecap="round"/>"#,
                        c.colour
                    );
                }
                Style::Line | Style::Dashed => {
                    let mut d = String::new();
                    for (i, (px, py)) in pts.enumerate() {
                        let _ = write!(d, "{}{px:.1},{py:.1}", if i == 0 { "M" } else { "L" });
                    }
                    let dash = if c.style == Style::Dashed {
                        r#" stroke-dasharray="5,3""#
                    } else {
                        ""
                    };
                    let _ = writeln!(
                        out,
                        r#"<path d="{d}" fill="none" stroke="{}" stroke-width="1.1"{dash}/>"#,
                        c.colour
                    );
                }
            }
        }
        let _ = writeln!(out, "</g>");
        for (i, c) in p.curves.iter().filter(|c| !c.name.is_empty()).enumerate() {
            let ly = t + 14.0 + 15.0 * i as f64;
            let _ = writeln!(
                out,
                r#"<rect x="{:.1}" y="{:.1}" width="10" height="4" fill="{}"/><text x="{:.1}" y="{:.1}" font-size="11">{}</text>"#,
                r - 130.0,
                ly - 4.0,
                c.colour,
                r - 116.0,
                ly,
                escape(&c.name)
            );
        }
    }
    close_page(out, height, caption)
}

/// A white page of `width` x `height` with `title` centred on top.
fn titled_page(width: f64, height: f64, title: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif">"#
    );
    let _ = writeln!(out, r#"<rect width="100%" height="100%" fill="white"/>"#);
    let _ = writeln!(
        out,
        r#"<text x="{:.1}" y="24" font-size="15" text-anchor="middle">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    out
}

/// The page closed with the caption's lines at its foot.
fn close_page(mut out: String, height: f64, caption: &[String]) -> String {
    caption_lines(
        &mut out,
        height - 16.0 * caption.len() as f64 - 4.0,
        caption,
    );
    let _ = writeln!(out, "</svg>");
    out
}

fn caption_lines(out: &mut String, top: f64, caption: &[String]) {
    for (i, line) in caption.iter().enumerate() {
        let _ = writeln!(
            out,
            r##"<text x="12" y="{:.1}" font-size="11" fill="#333">{}</text>"##,
            top + 12.0 + 16.0 * i as f64,
            escape(line)
        );
    }
}

/// Points rounded to a tenth of a pixel, each drawn once (periodic orbits and the Poincaré
/// points of settled runs repeat many times over).
fn dedup_pixels(pts: impl Iterator<Item = (f64, f64)>) -> Vec<(f64, f64)> {
    let mut seen = std::collections::HashSet::new();
    pts.filter(|(x, y)| x.is_finite() && y.is_finite())
        .filter(|(x, y)| seen.insert(((x * 2.0).round() as i64, (y * 2.0).round() as i64)))
        .collect()
}

/// Text safe inside SVG.
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// A basin map panel: its title, the map, and the label of each catalogue index.
pub struct BasinPanel<'a> {
    /// Title above the panel.
    pub title: String,
    /// The map.
    pub map: &'a capsule_analysis::basin::BasinMap,
    /// `(catalogue index, label)` in legend order.
    pub labels: Vec<(usize, String)>,
}

/// Fill colour of an attractor label: by period (the paper's dominant period 1 yellow, the
/// coexisting period 3 red), lighter for a second attractor of the same period.
pub fn label_colour(label: &str) -> String {
    let base = match label
        .trim_start_matches('P')
        .trim_end_matches(char::is_alphabetic)
    {
        "1" => (242, 194, 0),
        "2" => (120, 190, 70),
        "3" => (214, 39, 40),
        "4" => (255, 127, 14),
        "5" => (140, 86, 75),
        "6" => (148, 60, 170),
        _ if label == "chaos" => (120, 170, 220),
        // quasi-periodic or slowly converging: a grey apart from "failed" black
        _ if label == "QP" => (150, 150, 150),
        _ => (100, 100, 100),
    };
    // only the a, b, c suffix of a periodic label lightens it
    let periodic = label.starts_with('P') && label[1..].starts_with(|c: char| c.is_ascii_digit());
    let shade = match label.chars().last().filter(|_| periodic) {
        Some(c @ 'b'..='z') => (c as u8 - b'a') as f64 * 0.35,
        _ => 0.0,
    };
    let mix = |v: u8| (v as f64 + (255.0 - v as f64) * shade.min(0.8)) as u8;
    format!("#{:02x}{:02x}{:02x}", mix(base.0), mix(base.1), mix(base.2))
}

const BW: f64 = 360.0;

/// Basin maps side by side, each with a legend (period, impacts, progression, share) and the
/// attractors' Poincaré points on top when the plane shows them.
pub fn basins(title: &str, caption: &[String], maps: &[BasinPanel]) -> String {
    let cw = PL + BW + PR;
    let legend_rows = maps.iter().map(|m| m.labels.len()).max().unwrap_or(0);
    let ch = PT + BW + PB + 16.0 * legend_rows as f64 + 10.0;
    let width = cw * maps.len().max(1) as f64;
    let height = 40.0 + ch + 16.0 * caption.len() as f64 + 10.0;
    let mut out = titled_page(width, height, title);
    for (k, m) in maps.iter().enumerate() {
        let g = &m.map.grid;
        let (ox, oy) = (cw * k as f64, 40.0);
        let (l, t) = (ox + PL, oy + PT);
        let (r, b) = (l + BW, t + BW);
        // cells are centred on the grid points: the axes extend half a cell beyond
        let half = |(lo, hi): (f64, f64), n: usize| {
            let h = if n > 1 {
                0.5 * (hi - lo) / (n - 1) as f64
            } else {
                0.5
            };
            Axis {
                lo: lo - h,
                hi: hi + h,
            }
        };
        let x = half(g.x_range, g.nx);
        let y = half(g.y_range, g.ny);
        basin_cells(&mut out, m, (l, b));
        attractor_points(&mut out, m, (&x, &y), (l, t, r, b));
        frame(
            &mut out,
            (ox, oy),
            (BW, BW),
            &x,
            &y,
            (&escape(&m.title), g.plane.x.name(), g.plane.y.name()),
        );
        basin_legend(&mut out, m, (l, b));
    }
    close_page(out, height, caption)
}

/// A basin map's cells: one rectangle per run of equal cells in a row (a small file), in the
/// square whose bottom-left corner is `(l, b)`.
fn basin_cells(out: &mut String, m: &BasinPanel, (l, b): (f64, f64)) {
    use capsule_analysis::basin::Cell;
    let g = &m.map.grid;
    let colour_of: std::collections::HashMap<usize, String> = m
        .labels
        .iter()
        .map(|(i, l)| (*i, label_colour(l)))
        .collect();
    let (cw_px, ch_px) = (BW / g.nx as f64, BW / g.ny as f64);
    // one rectangle per run of equal cells in a row keeps the file small
    for j in 0..g.ny {
        let row = &m.map.cells[j * g.nx..(j + 1) * g.nx];
        let mut i = 0;
        while i < g.nx {
            let mut e = i + 1;
            while e < g.nx && same_fill(&row[e], &row[i]) {
                e += 1;
            }
            let fill = match &row[i] {
                Cell::Pending => "#ffffff".to_string(),
                Cell::Failed(_) => "#000000".to_string(),
                Cell::Attractor { index, .. } => colour_of
                    .get(index)
                    .cloned()
                    .unwrap_or_else(|| "#888888".into()),
            };
            let _ = write!(
                out,
                r#"<rect x="{:.2}" y="{:.2}" width="{:.2}" height="{:.2}" fill="{fill}"/>"#,
                l + i as f64 * cw_px,
                b - (j + 1) as f64 * ch_px,
                (e - i) as f64 * cw_px + 0.3,
                ch_px + 0.3
            );
            i = e;
        }
        out.push('\n');
    }
}

/// The periodic attractors' Poincaré points that fall in the plane shown.
fn attractor_points(
    out: &mut String,
    m: &BasinPanel,
    (x, y): (&Axis, &Axis),
    (l, t, r, b): (f64, f64, f64, f64),
) {
    use capsule_analysis::basin::Coord;
    let g = &m.map.grid;
    let pick = |c: Coord, p: &[f64; 3]| match c {
        Coord::RelX => Some(p[0]),
        Coord::RelY => Some(p[1]),
        Coord::Y1 => Some(p[2]),
        _ => None,
    };
    for (i, _) in &m.labels {
        let a = &m.map.catalogue.attractors[*i];
        if a.period.is_none() {
            continue;
        }
        for p in &a.poincare {
            if let (Some(px), Some(py)) = (pick(g.plane.x, p), pick(g.plane.y, p)) {
                if (x.lo..=x.hi).contains(&px) && (y.lo..=y.hi).contains(&py) {
                    let _ = writeln!(
                        out,
                        r#"<circle cx="{:.1}" cy="{:.1}" r="3.5" fill="black" stroke="white" stroke-width="1"/>"#,
                        x.map(px, l, r),
                        y.map(py, b, t)
                    );
                }
            }
        }
    }
}

/// A basin map's legend under it: colour, period, impacts, progression and share per label.
fn basin_legend(out: &mut String, m: &BasinPanel, (l, b): (f64, f64)) {
    for (n, (i, label)) in m.labels.iter().enumerate() {
        let a = &m.map.catalogue.attractors[*i];
        let ly = b + 50.0 + 16.0 * n as f64;
        let period = a.period.map_or("none".to_string(), |p| p.to_string());
        let _ = writeln!(
            out,
            r#"<rect x="{l:.1}" y="{:.1}" width="12" height="12" fill="{}" stroke="black" stroke-width="0.5"/><text x="{:.1}" y="{ly:.1}" font-size="11">{label}: period {period}, {:.2} impacts/period, progression {:+.4}, {:.1} %</text>"#,
            ly - 10.0,
            label_colour(label),
            l + 18.0,
            a.impacts_per_period,
            a.avg_progression,
            100.0 * m.map.fraction(*i)
        );
    }
}

fn same_fill(a: &capsule_analysis::basin::Cell, b: &capsule_analysis::basin::Cell) -> bool {
    use capsule_analysis::basin::Cell;
    match (a, b) {
        (Cell::Attractor { index: i, .. }, Cell::Attractor { index: j, .. }) => i == j,
        (Cell::Failed(_), Cell::Failed(_)) | (Cell::Pending, Cell::Pending) => true,
        _ => false,
    }
}

/// Heat maps side by side, one per `(title, cells[row][column], reference)`: each cell coloured
/// by its value over the reference (green: at least the reference's progression in its
/// direction; through yellow to red: none; purple: the wrong direction), its value written in.
pub fn heat_maps(
    title: &str,
    columns: &[String],
    rows: &[String],
    xlabel: &str,
    ylabel: &str,
    maps: &[(String, Vec<Vec<f64>>, f64)],
) -> String {
    let (cell_w, cell_h, gap) = (52.0, 30.0, 40.0);
    let map_w = cell_w * columns.len() as f64;
    let map_h = cell_h * rows.len() as f64;
    let left = 70.0;
    let top = 70.0;
    let width = left + maps.len() as f64 * (map_w + gap) + 20.0;
    let height = top + map_h + 60.0;
    let mut out = String::new();
    let _ = writeln!(
        out,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" font-family="sans-serif" font-size="11"><rect width="100%" height="100%" fill="white"/><text x="{}" y="22" font-size="15" text-anchor="middle">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    for (k, (name, cells, reference)) in maps.iter().enumerate() {
        let x0 = left + k as f64 * (map_w + gap);
        let _ = writeln!(
            out,
            r#"<text x="{}" y="{}" font-size="13" text-anchor="middle">{} (exact: {:+.2})</text>"#,
            x0 + map_w / 2.0,
            top - 22.0,
            escape(name),
            reference
        );
        for (i, row) in cells.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                let (x, y) = (x0 + j as f64 * cell_w, top + i as f64 * cell_h);
                let _ = writeln!(
                    out,
                    r#"<rect x="{x}" y="{y}" width="{cell_w}" height="{cell_h}" fill="{}" stroke="white"/><text x="{}" y="{}" text-anchor="middle">{v:+.2}</text>"#,
                    heat_colour(*v, *reference),
                    x + cell_w / 2.0,
                    y + cell_h / 2.0 + 4.0
                );
            }
        }
        let sizes = (cell_w, cell_h, map_w, map_h);
        heat_map_labels(
            &mut out,
            (x0, top),
            sizes,
            (columns, rows),
            (xlabel, ylabel),
            k == 0,
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{left}" y="{}" font-size="10">green: the exact positions' progression or more; yellow: half; red: none; purple: the wrong direction</text></svg>"#,
        height - 12.0
    );
    out
}

/// A heat map cell's colour: its value over the reference (green: at least the reference's
/// progression in its direction; through yellow to red: none; purple: the wrong direction).
fn heat_colour(v: f64, reference: f64) -> String {
    let share = if reference.abs() > 0.0 {
        v / reference
    } else {
        f64::NAN
    };
    if !share.is_finite() {
        return "#dddddd".into();
    }
    if share < 0.0 {
        return "#b07cc6".into();
    }
    // red (0) -> yellow (0.5) -> green (1 and above)
    let s = share.min(1.0);
    let (r, g) = if s < 0.5 {
        (230.0, 80.0 + 300.0 * s)
    } else {
        (230.0 - 330.0 * (s - 0.5), 230.0)
    };
    format!("rgb({:.0},{:.0},90)", r.max(0.0), g.min(230.0))
}

/// A heat map's column labels and axis label; the row labels and vertical axis label beside
/// the `first` map only.
fn heat_map_labels(
    out: &mut String,
    (x0, top): (f64, f64),
    (cell_w, cell_h, map_w, map_h): (f64, f64, f64, f64),
    (columns, rows): (&[String], &[String]),
    (xlabel, ylabel): (&str, &str),
    first: bool,
) {
    for (j, c) in columns.iter().enumerate() {
        let _ = writeln!(
            out,
            r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
            x0 + (j as f64 + 0.5) * cell_w,
            top - 6.0,
            escape(c)
        );
    }
    let _ = writeln!(
        out,
        r#"<text x="{}" y="{}" text-anchor="middle">{}</text>"#,
        x0 + map_w / 2.0,
        top + map_h + 20.0,
        escape(xlabel)
    );
    if first {
        for (i, r) in rows.iter().enumerate() {
            let _ = writeln!(
                out,
                r#"<text x="{}" y="{}" text-anchor="end">{}</text>"#,
                x0 - 6.0,
                top + (i as f64 + 0.5) * cell_h + 4.0,
                escape(r)
            );
        }
        let _ = writeln!(
            out,
            r#"<text x="16" y="{}" text-anchor="middle" transform="rotate(-90 16 {})">{}</text>"#,
            top + map_h / 2.0,
            top + map_h / 2.0,
            escape(ylabel)
        );
    }
}

/// Rasterise an SVG document of ours to PNG at `scale` (fonts: the embedded Ubuntu Light, so no
/// system font or fontconfig is needed).
pub fn png(svg: &str, scale: f32) -> Result<Vec<u8>, String> {
    let mut opt = resvg::usvg::Options {
        font_family: "Ubuntu".into(),
        ..Default::default()
    };
    opt.fontdb_mut()
        .load_font_data(epaint_default_fonts::UBUNTU_LIGHT.to_vec());
    opt.fontdb_mut().set_sans_serif_family("Ubuntu");
    let tree = resvg::usvg::Tree::from_str(svg, &opt).map_err(|e| e.to_string())?;
    let size = tree
        .size()
        .to_int_size()
        .scale_by(scale)
        .ok_or("empty picture")?;
    let mut pixmap = resvg::tiny_skia::Pixmap::new(size.width(), size.height())
        .ok_or("picture too large to rasterise")?;
    resvg::render(
        &tree,
        resvg::tiny_skia::Transform::from_scale(scale, scale),
        &mut pixmap.as_mut(),
    );
    pixmap.encode_png().map_err(|e| e.to_string())
}
