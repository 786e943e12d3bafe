//! `capsule continue`: pseudo-arclength continuation of the periodic orbit a scene settles on, in
//! one parameter; writes the branch (CSV, JSON) and the bifurcation diagram (SVG, stable solid,
//! unstable dashed, special points marked, optionally over a brute-force sweep).

use crate::scene_args::ParamArgs;
use crate::svg;
use crate::work;
use anyhow::{bail, Context, Result};
use capsule_analysis::continuation::{
    continue_branch_observed, switch_at_period_doubling, Branch, BranchPoint, ContinuationConfig,
    SpecialKind,
};
use capsule_analysis::{sweep, Param};
use capsule_args::ranges;
use capsule_plant::scene::Scene;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Continue a periodic orbit.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    vary: ParamArgs,
    /// Continue from the scene's own value of --param (set it with the scene flags, e.g. --alpha
    /// 2.0) towards this value (stops past it), finite, |value| <= 1e12.
    #[arg(long, value_parser = ranges::within(-ranges::MAX_MAGNITUDE, ranges::MAX_MAGNITUDE))]
    to: f64,
    /// First arclength step (in the norm of (x1 - x2, y1, y2, parameter)), (0, 10].
    #[arg(long, default_value_t = 0.01, value_parser = ranges::positive(10.0))]
    arc_step: f64,
    /// Largest arclength step, (0, 10].
    #[arg(long, default_value_t = 0.02, value_parser = ranges::positive(10.0))]
    max_arc_step: f64,
    /// Most branch points, 2 to 1000000.
    #[arg(long, default_value_t = 5000, value_parser = ranges::count_usize(2, 1_000_000))]
    max_points: usize,
    /// Also run a brute-force sweep of this many values over the same range and draw it under
    /// the branch (grey dots).
    #[arg(long, value_name = "N", value_parser = ranges::count_usize(2, 1_000_000))]
    sweep_steps: Option<usize>,
    /// At each period doubling found, switch to the period-doubled branch and continue it too
    /// (one level): written as PREFIX_pd1.csv/.json, ..., drawn in the same SVG.
    #[arg(long)]
    switch: bool,
    /// Output prefix: writes PREFIX.csv, PREFIX.json and PREFIX.svg. Required: the files are
    /// the branch.
    #[arg(long, value_name = "PREFIX")]
    out: PathBuf,
}

pub fn main(args: Args) -> Result<()> {
    let param = args.vary.param;
    if !args.to.is_finite() {
        bail!("--to must be a finite number");
    }
    if !(args.arc_step > 0.0 && args.max_arc_step >= args.arc_step && args.max_arc_step.is_finite())
    {
        bail!("--arc-step must be positive and at most --max-arc-step");
    }
    if args.max_points < 2 {
        bail!("--max-points must be at least 2");
    }
    let scene = args.vary.scene.scene()?;
    let mut settings = ContinuationConfig::new(param, args.to);
    settings.step = args.arc_step;
    settings.max_step = args.max_arc_step;
    settings.max_points = args.max_points;
    let t0 = std::time::Instant::now();
    let branch = continue_interruptibly(&scene, &settings)?;
    let mut doubled = Vec::new();
    if args.switch && branch.stopped.is_none() {
        for sp in branch
            .special
            .iter()
            .filter(|s| s.kind == SpecialKind::PeriodDoubling)
        {
            match switch_at_period_doubling(&scene, &settings, branch.period, sp) {
                Ok(b) => doubled.push(b),
                Err(e) => eprintln!("branch switching at {} = {}: {e}", param.name(), sp.value),
            }
        }
    }
    let wall = t0.elapsed().as_secs_f64();
    let from = param.value(&scene);
    let swept = args.sweep_steps.filter(|&n| n >= 2).map(|n| {
        let values: Vec<f64> = (0..n)
            .map(|i| from + (args.to - from) * i as f64 / (n - 1) as f64)
            .collect();
        sweep(&scene, param, &values, &|| {})
    });
    let csv = args.out.with_extension("csv");
    let json = args.out.with_extension("json");
    let svg_path = args.out.with_extension("svg");
    write_branch(&csv, &json, &branch)?;
    let title = format!(
        "{}: period-{} branch in {} (solid stable, dashed unstable)",
        scene.model.friction.name(),
        branch.period,
        param.name()
    );
    let mut all = vec![branch.clone()];
    for (i, b) in doubled.iter().enumerate() {
        write_doubled(&args.out, i + 1, b, param)?;
        all.push(b.clone());
    }
    std::fs::write(
        &svg_path,
        svg::continuation(&title, param.name(), &all, swept.as_deref()),
    )
    .with_context(|| format!("writing {}", svg_path.display()))?;
    println!(
        "{} branch points, {} = {} .. {}, period {}, in {:.3} s; wrote {}, {}, {}",
        branch.points.len(),
        param.name(),
        from,
        branch.points.last().map_or(from, |p| p.value),
        branch.period,
        wall,
        csv.display(),
        json.display(),
        svg_path.display()
    );
    print_special(&branch, param);
    if let Some(why) = &branch.stopped {
        bail!("the continuation stopped early at {why}; the branch so far is written");
    }
    Ok(())
}

/// Continues the branch with a bar on a terminal; Ctrl-C ends it at the next point, written
/// as far as it got.
fn continue_interruptibly(scene: &Scene, settings: &ContinuationConfig) -> Result<Branch> {
    let param = settings.param;
    let bar = indicatif::ProgressBar::new(settings.max_points as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} points (most), {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    work::catch_ctrl_c();
    let mut on_point = |p: &BranchPoint| {
        bar.inc(1);
        bar.set_message(format!("{} = {:.6}", param.name(), p.value));
        !work::interrupted()
    };
    let branch = continue_branch_observed(scene, settings, &mut on_point);
    bar.finish_and_clear();
    work::release_ctrl_c();
    branch.with_context(|| {
        format!(
            "continuing {} from {} = {}",
            scene.name,
            param.name(),
            param.value(scene)
        )
    })
}

/// Writes a branch's CSV and JSON files.
fn write_branch(csv: &Path, json: &Path, b: &Branch) -> Result<()> {
    write_csv(csv, b).with_context(|| format!("writing {}", csv.display()))?;
    std::fs::write(json, serde_json::to_string_pretty(b)?)
        .with_context(|| format!("writing {}", json.display()))
}

/// Writes the `n`th period-doubled branch as PREFIX_pdN.csv/.json and says so.
fn write_doubled(out: &Path, n: usize, b: &Branch, param: Param) -> Result<()> {
    let stem = format!(
        "{}_pd{n}",
        out.file_name().and_then(|n| n.to_str()).unwrap_or("branch"),
    );
    let prefix = out.with_file_name(stem);
    let (c, j) = (prefix.with_extension("csv"), prefix.with_extension("json"));
    write_branch(&c, &j, b)?;
    println!(
        "period-{} branch from the period doubling: {} points, to {} = {}; wrote {}, {}",
        b.period,
        b.points.len(),
        param.name(),
        b.points.last().map_or(f64::NAN, |p| p.value),
        c.display(),
        j.display()
    );
    for s in &b.special {
        println!("  {:?} at {} = {:.9}", s.kind, param.name(), s.value);
    }
    Ok(())
}

/// Prints the branch's special points and, for an isola, its range.
fn print_special(branch: &Branch, param: Param) {
    for s in &branch.special {
        println!("  {:?} at {} = {:.9}", s.kind, param.name(), s.value);
    }
    if branch.closed {
        println!(
            "  the branch closed on itself (an isola between {} = {:.9} and {:.9}): complete",
            param.name(),
            branch
                .points
                .iter()
                .map(|p| p.value)
                .fold(f64::INFINITY, f64::min),
            branch
                .points
                .iter()
                .map(|p| p.value)
                .fold(f64::NEG_INFINITY, f64::max)
        );
    }
}

fn write_csv(path: &Path, b: &Branch) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        w,
        "{},x1_minus_x2,y1,y2,stable,largest_modulus,mu1_re,mu1_im,mu2_re,mu2_im,mu3_re,mu3_im,impacts,stick_entries,events",
        b.param.name()
    )?;
    for p in &b.points {
        let mu: String = p
            .multipliers
            .iter()
            .map(|m| format!(",{},{}", m[0], m[1]))
            .collect();
        writeln!(
            w,
            "{},{},{},{},{},{}{mu},{},{},{}",
            p.value,
            p.x[0],
            p.x[1],
            p.x[2],
            u8::from(p.stable),
            p.multipliers.first().map_or(f64::NAN, |m| m[0].hypot(m[1])),
            p.impacts,
            p.stick_entries,
            p.events
        )?;
    }
    w.flush()?;
    Ok(())
}
