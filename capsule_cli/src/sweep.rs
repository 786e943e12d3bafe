//! `capsule sweep`: one parameter over a range, in parallel, with a progress bar; writes the
//! Poincaré points and measurements per value as CSV and JSON, and the bifurcation diagram and
//! progression curve as SVG.

use crate::scene_args::SceneArgs;
use crate::svg;
use anyhow::{bail, Context, Result};
use capsule_analysis::{sweep, sweep_following, Param, SweepPoint};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Sweep one parameter.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Parameter to sweep: alpha, omega, gamma, beta, delta, xi or kp.
    #[arg(long)]
    param: String,
    /// First value.
    #[arg(long)]
    from: f64,
    /// Last value.
    #[arg(long)]
    to: f64,
    /// Number of values, both ends included.
    #[arg(long, default_value_t = 191)]
    steps: usize,
    /// Output prefix: writes PREFIX.csv, PREFIX.json and PREFIX.svg.
    #[arg(long, value_name = "PREFIX", default_value = "sweep")]
    out: PathBuf,
    /// Follow one attractor: each value starts from the previous value's final state (runs
    /// one after the other) instead of every value from the scene's initial state (in parallel).
    #[arg(long)]
    follow: bool,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
}

pub fn main(args: Args) -> Result<()> {
    let Some(param) = Param::parse(&args.param) else {
        bail!(
            "--param `{}`: not a sweepable parameter (alpha, omega, gamma, beta, delta, xi, kp)",
            args.param
        );
    };
    if !(args.from.is_finite() && args.to.is_finite()) {
        bail!("--from/--to must be finite numbers");
    }
    if args.steps < 1 {
        bail!("--steps must be at least 1");
    }
    let scene = args.scene.scene()?;
    let values: Vec<f64> = (0..args.steps)
        .map(|i| {
            if args.steps == 1 {
                args.from
            } else {
                args.from + (args.to - args.from) * i as f64 / (args.steps - 1) as f64
            }
        })
        .collect();
    if let Some(n) = args.threads {
        rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
            .context("setting up the worker threads")?;
    }
    let bar = ProgressBar::new(values.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} values, {elapsed} elapsed, eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t0 = std::time::Instant::now();
    let points = if args.follow {
        sweep_following(&scene, param, &values, &|| bar.inc(1))
    } else {
        sweep(&scene, param, &values, &|| bar.inc(1))
    };
    bar.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    let csv = args.out.with_extension("csv");
    let json = args.out.with_extension("json");
    let svg_path = args.out.with_extension("svg");
    write_csv(&csv, &args.param, &points).with_context(|| format!("writing {}", csv.display()))?;
    std::fs::write(&json, serde_json::to_string(&points)?)
        .with_context(|| format!("writing {}", json.display()))?;
    let title = format!(
        "{} friction: y1 at drive phase 0 and progression vs {}",
        scene.model.friction.name(),
        args.param
    );
    std::fs::write(&svg_path, svg::bifurcation(&title, &args.param, &points))
        .with_context(|| format!("writing {}", svg_path.display()))?;
    let failed = points.iter().filter(|p| p.result.is_err()).count();
    println!(
        "{} values of {} in {:.2} s ({} failed); wrote {}, {}, {}",
        points.len(),
        args.param,
        wall,
        failed,
        csv.display(),
        json.display(),
        svg_path.display()
    );
    for p in points
        .iter()
        .filter_map(|p| p.result.as_ref().err().map(|e| (p.value, e)))
        .take(5)
    {
        println!("  {} = {}: {}", args.param, p.0, p.1);
    }
    Ok(())
}

fn write_csv(path: &Path, name: &str, points: &[SweepPoint]) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        w,
        "{name},n,x1_minus_x2,y1_minus_y2,y1,period,impacts_per_period,backward_slips_per_period,avg_progression,efficiency"
    )?;
    for p in points {
        let Ok(r) = &p.result else { continue };
        let period = r.period.map_or(String::new(), |k| k.to_string());
        for (n, q) in r.poincare.iter().enumerate() {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{}",
                p.value,
                n,
                q[0],
                q[1],
                q[2],
                period,
                r.impacts_per_period,
                r.backward_slips_per_period,
                r.avg_progression,
                r.efficiency
            )?;
        }
    }
    w.flush()?;
    Ok(())
}
