//! `capsule sweep`: one parameter over a range, in parallel, with a progress bar; writes the
//! Poincaré points and measurements per value as CSV and JSON, and the bifurcation diagram and
//! progression curve as SVG.

use crate::scene_args::ParamArgs;
use crate::svg;
use crate::work::{self, WorkArgs};
use anyhow::{bail, Context, Result};
use capsule_analysis::lyapunov::{lyapunov_sweep, Lyapunov};
use capsule_analysis::{sweep, sweep_following, Param, SweepPoint};
use capsule_args::ranges;
use capsule_plant::scene::Scene;
use indicatif::{ProgressBar, ProgressStyle};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Most values one sweep takes (each is a run; see also --max-work).
pub const MAX_VALUES: usize = 10_000_000;
/// Most worker threads.
pub const MAX_THREADS: usize = 1024;

/// Sweep one parameter.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    vary: ParamArgs,
    /// First value, [-1e12, 1e12].
    #[arg(long, value_parser = ranges::finite())]
    from: f64,
    /// Last value, [-1e12, 1e12].
    #[arg(long, value_parser = ranges::finite())]
    to: f64,
    /// Number of values, both ends included, 1 to 10000000 (see --max-work).
    #[arg(long, default_value_t = 191, value_parser = ranges::count_usize(1, MAX_VALUES))]
    steps: usize,
    /// Output prefix: writes PREFIX.csv, PREFIX.json and PREFIX.svg; a directory (an existing
    /// one, or a path ending in `/`) writes DIR/PARAM.csv, ... . Its directory must exist.
    /// Required: the files are the sweep's result.
    #[arg(long, value_name = "PREFIX")]
    out: PathBuf,
    /// Follow one attractor: each value starts from the previous value's final state (runs
    /// one after the other) instead of every value from the scene's initial state (in parallel).
    #[arg(long)]
    follow: bool,
    /// Also compute the Lyapunov spectrum per value (a second, linearized run of each value
    /// from the scene's initial state): columns lyapunov_1..3 in the CSV, `lyapunov` in the
    /// JSON, a third panel in the SVG.
    #[arg(long)]
    lyapunov: bool,
    /// Worker threads, 1 to 1024 [default: all cores].
    #[arg(long, value_parser = ranges::count_usize(1, MAX_THREADS))]
    threads: Option<usize>,
    /// Exit with status 0 even when some values failed (they are listed, and left out of the
    /// CSV and the diagram).
    #[arg(long)]
    allow_failures: bool,
    #[command(flatten)]
    work: WorkArgs,
}

/// The output prefix: `--out` as given, or DIR/PARAM when it names a directory.
fn prefix(out: &Path, param: &str) -> PathBuf {
    let as_dir = out.is_dir() || out.as_os_str().to_string_lossy().ends_with('/');
    if as_dir {
        out.join(param)
    } else {
        out.to_path_buf()
    }
}

pub fn main(args: Args) -> Result<()> {
    let param = args.vary.param;
    let scene = args.vary.scene.scene()?;
    args.work.check(&scene, args.steps)?;
    let prefix = prefix(&args.out, param.name());
    work::check_parent(&prefix)?;
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
    let points = sweep_in_chunks(&scene, param, &values, args.follow, &bar);
    let spectra: Option<Vec<Result<Lyapunov, String>>> = args.lyapunov.then(|| {
        bar.set_position(0);
        bar.set_message("lyapunov");
        // the values that finished (all unless interrupted)
        lyapunov_sweep(&scene, param, &values[..points.len()], &|| bar.inc(1))
    });
    bar.finish_and_clear();
    let wall = t0.elapsed().as_secs_f64();
    let csv = prefix.with_extension("csv");
    let json = prefix.with_extension("json");
    let svg_path = prefix.with_extension("svg");
    write_csv(&csv, param.name(), &points, spectra.as_deref())
        .with_context(|| format!("writing {}", csv.display()))?;
    std::fs::write(&json, json_text(&points, spectra.as_deref())?)
        .with_context(|| format!("writing {}", json.display()))?;
    let largest: Option<Vec<(f64, f64)>> = spectra.as_ref().map(|ls| {
        values
            .iter()
            .zip(ls)
            .filter_map(|(v, l)| l.as_ref().ok().map(|l| (*v, l.exponents[0])))
            .collect()
    });
    let title = format!(
        "{} friction: y1 at drive phase 0 and progression vs {}",
        scene.model.friction.name(),
        param.name()
    );
    std::fs::write(
        &svg_path,
        svg::bifurcation(&title, param.name(), &points, largest.as_deref()),
    )
    .with_context(|| format!("writing {}", svg_path.display()))?;
    let failed: Vec<(f64, &String)> = points
        .iter()
        .filter_map(|p| p.result.as_ref().err().map(|e| (p.value, e)))
        .collect();
    println!(
        "{} values of {} in {:.2} s ({} failed); wrote {}, {}, {}",
        points.len(),
        param.name(),
        wall,
        failed.len(),
        csv.display(),
        json.display(),
        svg_path.display()
    );
    for (v, e) in failed.iter().take(5) {
        println!("  {} = {v}: {e}", param.name());
    }
    if failed.len() > 5 {
        let more = failed.len() - 5;
        println!("  ... and {more} more (all in {})", json.display());
    }
    if points.len() < values.len() {
        bail!(
            "interrupted: {} of {} values done and written",
            points.len(),
            values.len()
        );
    }
    if !failed.is_empty() && !args.allow_failures {
        bail!(
            "{} of {} values failed (listed above; --allow-failures to exit 0 anyway)",
            failed.len(),
            points.len()
        );
    }
    Ok(())
}

/// Sweeps `values` in chunks, so that Ctrl-C stops between them with what finished kept;
/// `follow`: each chunk starts from the last state of the one before.
fn sweep_in_chunks(
    scene: &Scene,
    param: Param,
    values: &[f64],
    follow: bool,
    bar: &ProgressBar,
) -> Vec<SweepPoint> {
    work::catch_ctrl_c();
    let chunk = (rayon::current_num_threads() * 8).max(16);
    let mut points: Vec<SweepPoint> = Vec::with_capacity(values.len());
    let mut start = scene.clone();
    for part in values.chunks(chunk) {
        if work::interrupted() {
            break;
        }
        let done = if follow {
            let done = sweep_following(&start, param, part, &|| bar.inc(1));
            if let Some(r) = done.iter().rev().find_map(|p| p.result.as_ref().ok()) {
                start.initial = r.final_state;
            }
            done
        } else {
            sweep(scene, param, part, &|| bar.inc(1))
        };
        points.extend(done);
    }
    points
}

/// The sweep as JSON, each point with its Lyapunov spectrum when computed.
fn json_text(
    points: &[SweepPoint],
    spectra: Option<&[Result<Lyapunov, String>]>,
) -> Result<String> {
    Ok(match spectra {
        None => serde_json::to_string(points)?,
        Some(ls) => {
            #[derive(serde::Serialize)]
            struct WithLyapunov<'a> {
                #[serde(flatten)]
                point: &'a SweepPoint,
                lyapunov: &'a Result<Lyapunov, String>,
            }
            let rows: Vec<WithLyapunov> = points
                .iter()
                .zip(ls)
                .map(|(point, lyapunov)| WithLyapunov { point, lyapunov })
                .collect();
            serde_json::to_string(&rows)?
        }
    })
}

fn write_csv(
    path: &Path,
    name: &str,
    points: &[SweepPoint],
    spectra: Option<&[Result<Lyapunov, String>]>,
) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    let extra = if spectra.is_some() {
        ",lyapunov_1,lyapunov_2,lyapunov_3"
    } else {
        ""
    };
    writeln!(
        w,
        "{name},n,x1_minus_x2,y1_minus_y2,y1,period,impacts_per_period,backward_slips_per_period,avg_progression,efficiency{extra}"
    )?;
    for (i, p) in points.iter().enumerate() {
        let Ok(r) = &p.result else { continue };
        // empty when not asked for or not computable; -inf (a direction removed by sticking)
        // is written as such
        let ly = match spectra.map(|s| &s[i]) {
            None => String::new(),
            Some(Ok(l)) => l.exponents.iter().map(|x| format!(",{x}")).collect(),
            Some(Err(_)) => ",,,".to_string(),
        };
        let period = r.period.map_or(String::new(), |k| k.to_string());
        for (n, q) in r.poincare.iter().enumerate() {
            writeln!(
                w,
                "{},{},{},{},{},{},{},{},{},{}{ly}",
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
