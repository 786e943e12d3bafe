//! `capsule robustness`: what the swap to a real capsule costs. The paper's law closed offline
//! around a simulated prototype (`capsule_analysis::robustness`) for FORWARD, BACKWARD and
//! CHAOS_CONTROL: a noise x delay grid per mode (a heat map), and one row each for the scene's
//! own `[device]` (when it has one), the typical device, quantisation, coil lag, a dead band,
//! and friction and stiffness off by +-20 %.
//! Writes PREFIX.md (the tables), PREFIX.svg and PREFIX.png (the heat maps).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context as _, Result};
use capsule_analysis::robustness::{
    closed_loop, controller_window, LoopCase, LoopResult, Mismatch,
};
use capsule_args::ranges;
use capsule_controller::switch::SwitchConfig;
use capsule_plant::device::{DeviceModel, Measured};
use capsule_plant::scene::{PhysicalScale, Scene};
use rayon::prelude::*;

use crate::svg;

/// `capsule robustness`'s arguments.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene TOML (default: the section-5 control point, the demo's scene)
    #[arg(long, value_name = "FILE")]
    scene: Option<PathBuf>,
    /// Drive periods measured per run, 1 to 100000
    #[arg(long, default_value_t = 30, value_parser = ranges::count_u32(1, 100_000))]
    periods: u32,
    /// Drive periods run first and not measured, 0 to 100000
    #[arg(long, default_value_t = 10, value_parser = ranges::count_u32(0, 100_000))]
    transient: u32,
    /// Control rate [Hz], 1 to 1e6
    #[arg(long, default_value_t = 1000.0, value_parser = ranges::within(1.0, 1e6))]
    rate_hz: f64,
    /// Samples in the controller's velocity estimate (a least-squares line, read at its
    /// middle) [default: an eighth of a drive period at --rate-hz], 2 to 100000
    #[arg(long, value_parser = ranges::count_u32(2, 100_000))]
    velocity_window: Option<u32>,
    /// The controller's orbit-watch tolerance for the period it sees (non-dim), 1e-6 to 0.2
    #[arg(long, default_value_t = SwitchConfig::DEFAULT.tol, value_parser = ranges::within(1e-6, 0.2))]
    orbit_tolerance: f64,
    /// Also write PREFIX.md, PREFIX.svg, PREFIX.png (its directory must exist); without it the
    /// report goes to stdout only (the docs' copy: `--out docs/robustness/robustness`)
    #[arg(long, value_name = "PREFIX")]
    out: Option<PathBuf>,
}

/// Position noise on the grid, in % of the length unit `P_f / k1`.
const NOISE_PCT: [f64; 7] = [0.0, 5.0, 20.0, 50.0, 100.0, 200.0, 500.0];
/// Measurement latency on the grid \[ms\].
const DELAY_MS: [f64; 7] = [0.0, 2.0, 5.0, 10.0, 22.0, 45.0, 90.0];
/// The modes and their default gains (`capsule_controller::mode::ModeConfig::DEFAULT`).
const MODES: [(&str, f64); 3] = [("FORWARD", 0.2), ("BACKWARD", -0.2), ("CHAOS_CONTROL", 1.0)];

/// A Markdown table's header row and rule: `first` over the row labels, then `columns`.
fn table_head(md: &mut String, first: &str, columns: impl Iterator<Item = String>) {
    let columns: Vec<String> = columns.collect();
    let _ = writeln!(md, "| {first} | {} |", columns.join(" | "));
    let _ = writeln!(md, "|---|{}", "---|".repeat(columns.len()));
}

/// The orbit tables' header: `first`, then per mode its period, the period seen and the
/// velocity estimate's error.
fn orbit_head(md: &mut String, first: &str) {
    let columns = MODES
        .iter()
        .map(|(m, _)| format!("{m}: period, seen, velocity error"));
    table_head(md, first, columns);
}

/// An orbit table's cell: the period, the period seen (`-`: none) and the velocity error.
fn orbit_cell(run: Option<LoopResult>) -> String {
    let p = |p: Option<usize>| p.map_or("-".to_string(), |p| p.to_string());
    run.map_or("failed".into(), |x| {
        format!(
            "{}, {}, {:.3}",
            p(x.period),
            p(x.seen_period),
            x.velocity_error
        )
    })
}

/// Runs the study and writes its files.
pub fn main(args: Args) -> Result<()> {
    let scene = match &args.scene {
        Some(p) => capsule_args::scene_file::SceneFile::read(p)?.scene,
        None => crate::bench::section5(0.0),
    };
    if let Some(out) = &args.out {
        crate::work::check_parent(out)?;
    }
    let plan = Plan::new(&args, &scene);
    let n = plan.grid.len() + plan.row_cases.len() + plan.window_cases.len();
    eprintln!(
        "robustness: {n} closed-loop runs of {} + {} periods at {} Hz",
        args.transient, args.periods, args.rate_hz
    );
    let bar = indicatif::ProgressBar::new(n as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} runs, {elapsed}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let results = Results {
        grid: run_cases(&scene, &plan.grid, &bar)?,
        rows: run_cases(&scene, &plan.row_cases, &bar)?,
        windows: run_cases(&scene, &plan.window_cases, &bar)?,
    };
    bar.finish_and_clear();
    let md = report(&args, &plan, &results, scene.physical.length_m() * 1e3);
    if let Some(out) = &args.out {
        write_files(out, &md, &results)?;
    }
    print!("{md}");
    match &args.out {
        Some(out) => eprintln!("wrote {}.md, .svg, .png", out.display()),
        None => eprintln!("no files written (--out PREFIX writes PREFIX.md, .svg, .png)"),
    }
    Ok(())
}

/// Writes the report and its heat maps to `PREFIX.md`, `PREFIX.svg` and `PREFIX.png`.
fn write_files(prefix: &std::path::Path, md: &str, results: &Results) -> Result<()> {
    let write = |ext: &str, bytes: &[u8]| {
        let path = crate::basins::with_ext(prefix, ext);
        std::fs::write(&path, bytes).with_context(|| format!("cannot write {}", path.display()))
    };
    write("md", md.as_bytes())?;
    let doc = heat_maps(results);
    write("svg", doc.as_bytes())?;
    write(
        "png",
        &svg::png(&doc, 1.5).map_err(|e| anyhow::anyhow!("PNG: {e}"))?,
    )
}

/// The study's closed-loop runs: the noise x delay grid (mode, delay, noise), one row per
/// device or plant (row, mode) and one per velocity window (window, mode).
struct Plan {
    /// The controller's velocity window at --rate-hz.
    window: u32,
    grid: Vec<((usize, usize, usize), LoopCase)>,
    /// The rows' labels, devices and mismatches.
    rows: Vec<(String, DeviceModel, Mismatch)>,
    row_cases: Vec<((usize, usize), LoopCase)>,
    /// The windows compared on the typical device.
    windows: Vec<u32>,
    window_cases: Vec<((usize, usize), LoopCase)>,
}

impl Plan {
    fn new(args: &Args, scene: &Scene) -> Plan {
        let phys = scene.physical;
        // the grid's device: positions only, exact but for noise and latency, an ideal actuator
        let base = DeviceModel {
            measured: Measured::POSITIONS,
            ..DeviceModel::ideal(&phys)
        };
        let period_s = 2.0 * std::f64::consts::PI / scene.drive.omega * phys.time_s();
        // the controller's window (an eighth of a drive period) in samples at --rate-hz
        let window = args
            .velocity_window
            .unwrap_or_else(|| controller_window(period_s, args.rate_hz));
        let case = |kp: f64, device: DeviceModel, mismatch: Mismatch| LoopCase {
            kp,
            device,
            mismatch,
            rate_hz: args.rate_hz,
            transient: args.transient,
            periods: args.periods,
            velocity_window: window,
            orbit_tolerance: args.orbit_tolerance,
        };
        let mut grid = Vec::new();
        for (m, (_, kp)) in MODES.iter().enumerate() {
            for (i, d) in DELAY_MS.iter().enumerate() {
                for (j, n) in NOISE_PCT.iter().enumerate() {
                    let device = DeviceModel {
                        noise_m: n / 100.0 * phys.length_m(),
                        latency_s: d / 1000.0,
                        ..base
                    };
                    grid.push(((m, i, j), case(*kp, device, Mismatch::NONE)));
                }
            }
        }
        let typical = DeviceModel::typical(&phys);
        let mut rows = device_rows(&phys, base, typical);
        // the scene's own device, so that one run of the emulator can be reproduced offline
        if let Some(d) = scene.device {
            rows.insert(0, ("the scene's [device] table".into(), d, Mismatch::NONE));
        }
        let mut row_cases = Vec::new();
        for (r, (_, device, mismatch)) in rows.iter().enumerate() {
            for (m, (_, kp)) in MODES.iter().enumerate() {
                row_cases.push(((r, m), case(*kp, *device, *mismatch)));
            }
        }
        // the velocity estimate's window against the backward difference (2), typical device
        let mut windows = vec![2, 3, 5, window / 2, window, window * 3 / 2, 3 * window];
        windows.retain(|&w| w >= 2);
        windows.sort_unstable();
        windows.dedup();
        let mut window_cases = Vec::new();
        for (w, &n) in windows.iter().enumerate() {
            for (m, (_, kp)) in MODES.iter().enumerate() {
                let c = LoopCase {
                    velocity_window: n,
                    ..case(*kp, typical, Mismatch::NONE)
                };
                window_cases.push(((w, m), c));
            }
        }
        Plan {
            window,
            grid,
            rows,
            row_cases,
            windows,
            window_cases,
        }
    }
}

/// One effect at a time (a table of cases): the ideal device, positions only, the typical
/// device, quantisation, coil lag, a dead band, friction and stiffness off by +-20 %.
fn device_rows(
    phys: &PhysicalScale,
    base: DeviceModel,
    typical: DeviceModel,
) -> Vec<(String, DeviceModel, Mismatch)> {
    let plant = |friction: f64, stiffness: f64| Mismatch {
        friction,
        stiffness,
    };
    let none = Mismatch::NONE;
    vec![
        (
            "ideal (every quantity, exact, at once)".into(),
            DeviceModel::ideal(phys),
            none,
        ),
        ("positions only, exact".into(), base, none),
        ("typical device (docs/hardware.md)".into(), typical, none),
        (
            "quantised 10 um".into(),
            DeviceModel {
                quantum_m: 10e-6,
                ..base
            },
            none,
        ),
        (
            "quantised 50 um".into(),
            DeviceModel {
                quantum_m: 50e-6,
                ..base
            },
            none,
        ),
        (
            "coil lag 2 ms".into(),
            DeviceModel {
                lag_s: 2e-3,
                ..base
            },
            none,
        ),
        (
            "coil lag 10 ms".into(),
            DeviceModel {
                lag_s: 10e-3,
                ..base
            },
            none,
        ),
        (
            "dead band 0.2 P_f".into(),
            DeviceModel {
                dead_band_n: 0.2 * phys.force_n(),
                ..base
            },
            none,
        ),
        ("friction -20 %".into(), base, plant(0.8, 1.0)),
        ("friction +20 %".into(), base, plant(1.2, 1.0)),
        ("stiffness k1 -20 %".into(), base, plant(1.0, 0.8)),
        ("stiffness k1 +20 %".into(), base, plant(1.0, 1.2)),
    ]
}

/// Runs `cases` in parallel, each result under its case's key.
fn run_cases<K: Copy + Send + Sync>(
    scene: &Scene,
    cases: &[(K, LoopCase)],
    bar: &indicatif::ProgressBar,
) -> Result<Vec<(K, LoopResult)>> {
    cases
        .par_iter()
        .map(|(k, c)| {
            let r = closed_loop(scene, c).map_err(|e| anyhow::anyhow!("closed loop: {e}"));
            bar.inc(1);
            r.map(|r| (*k, r))
        })
        .collect()
}

/// The runs' results, by the keys of [`Plan`].
struct Results {
    grid: Vec<((usize, usize, usize), LoopResult)>,
    rows: Vec<((usize, usize), LoopResult)>,
    windows: Vec<((usize, usize), LoopResult)>,
}

impl Results {
    /// The grid's progression for mode `m`, delay `i`, noise `j`.
    fn at(&self, m: usize, i: usize, j: usize) -> f64 {
        self.grid
            .iter()
            .find(|(k, _)| *k == (m, i, j))
            .map_or(f64::NAN, |(_, r)| r.progression)
    }

    fn row(&self, r: usize, m: usize) -> Option<LoopResult> {
        self.rows
            .iter()
            .find(|(k, _)| *k == (r, m))
            .map(|(_, r)| *r)
    }

    fn window(&self, w: usize, m: usize) -> Option<LoopResult> {
        self.windows
            .iter()
            .find(|(k, _)| *k == (w, m))
            .map(|(_, x)| *x)
    }
}

/// The Markdown report; `mm` is the length unit in millimetres.
fn report(args: &Args, plan: &Plan, results: &Results, mm: f64) -> String {
    let window = plan.window;
    let mut md = String::new();
    let _ = writeln!(
        md,
        "# What the swap to a real capsule costs\n\nMade by `capsule robustness{}` ({} + {} drive periods per run at {} Hz, the law on measured positions only, progression and efficiency on the true state; non-dimensional, 1 length unit = {:.3} mm). The law: `alpha cos(omega tau) + k_p |x2 - x1|`, FORWARD k_p 0.2, BACKWARD -0.2, CHAOS_CONTROL 1.0.\n",
        args.scene.as_ref().map(|p| format!(" --scene {}", p.display())).unwrap_or_default(),
        args.transient,
        args.periods,
        args.rate_hz,
        mm
    );
    let _ = writeln!(md, "## One effect at a time\n\nProgression per drive period (efficiency: progression over the actuator's work).\n");
    table_head(
        &mut md,
        "device / plant",
        MODES.iter().map(|(m, _)| m.to_string()),
    );
    for (r, (label, _, _)) in plan.rows.iter().enumerate() {
        let cells: Vec<String> = (0..MODES.len())
            .map(|m| {
                results.row(r, m).map_or("failed".into(), |x| {
                    format!("{:+.3} ({:.3})", x.progression, x.efficiency)
                })
            })
            .collect();
        let _ = writeln!(md, "| {label} | {} |", cells.join(" | "));
    }
    let _ = writeln!(md, "\n## The orbit\n\nThe orbit's period in drive periods, as the controller's orbit watch (the status's `orbit_period`) reads it on the true state, then as it sees it from the measured positions and its velocity estimate (a least-squares line over {window} samples, read at its middle; `capsule_controller::velocity`), and that estimate's RMS error on the mass velocity against the truth when the sensor sampled (non-dimensional: the filter's error, the latency left out). `-`: no period up to 12 (chaos, or too noisy to tell) within the watch's tolerance on the section, 0.02 on the true state and {} as the controller sees it (`--orbit-tolerance`).\n", args.orbit_tolerance);
    orbit_head(&mut md, "device / plant");
    for (r, (label, _, _)) in plan.rows.iter().enumerate() {
        let cells: Vec<String> = (0..MODES.len())
            .map(|m| orbit_cell(results.row(r, m)))
            .collect();
        let _ = writeln!(md, "| {label} | {} |", cells.join(" | "));
    }
    let _ = writeln!(md, "\n## The velocity estimate's window\n\nThe typical device (positions only, 1 % noise, 1 um resolution, 2 ms late): the period seen and the estimate's RMS velocity error for windows from the backward difference (2 samples) up. The default, {window} samples, is an eighth of a drive period at {} Hz.\n", args.rate_hz);
    orbit_head(&mut md, "window (samples)");
    for (w, n) in plan.windows.iter().enumerate() {
        let cells: Vec<String> = (0..MODES.len())
            .map(|m| orbit_cell(results.window(w, m)))
            .collect();
        let _ = writeln!(md, "| {n} | {} |", cells.join(" | "));
    }
    noise_delay_tables(&mut md, results);
    md
}

/// The report's noise x delay section: one table per mode.
fn noise_delay_tables(md: &mut String, results: &Results) {
    let _ = writeln!(md, "\n## Noise x delay\n\nPositions only, no quantisation or lag: progression per period for position noise (standard deviation, % of the length unit) against measurement latency. `*`: below half of the exact positions' progression or of the wrong sign (the mode has stopped working).\n");
    for (m, (mode, _)) in MODES.iter().enumerate() {
        let reference = results.at(m, 0, 0);
        let _ = writeln!(md, "### {mode} (exact positions: {reference:+.3})\n");
        table_head(
            md,
            "latency \\ noise",
            NOISE_PCT.iter().map(|n| format!("{n} %")),
        );
        for (i, d) in DELAY_MS.iter().enumerate() {
            let cells: Vec<String> = (0..NOISE_PCT.len())
                .map(|j| {
                    let v = results.at(m, i, j);
                    let works = v * reference.signum() >= 0.5 * reference.abs();
                    format!("{v:+.3}{}", if works { "" } else { "*" })
                })
                .collect();
            let _ = writeln!(md, "| {d} ms | {} |", cells.join(" | "));
        }
        let _ = writeln!(md);
    }
}

/// The noise x delay heat maps, one per mode (SVG).
fn heat_maps(results: &Results) -> String {
    let maps: Vec<(String, Vec<Vec<f64>>, f64)> = MODES
        .iter()
        .enumerate()
        .map(|(m, (mode, _))| {
            let cells = (0..DELAY_MS.len())
                .map(|i| (0..NOISE_PCT.len()).map(|j| results.at(m, i, j)).collect())
                .collect();
            (mode.to_string(), cells, results.at(m, 0, 0))
        })
        .collect();
    svg::heat_maps(
        "Progression per drive period: position noise x measurement latency",
        &NOISE_PCT.map(|n| format!("{n} %")),
        &DELAY_MS.map(|d| format!("{d} ms")),
        "noise (% of P_f/k1)",
        "latency",
        &maps,
    )
}
