//! `capsule switch`: move the capsule between coexisting attractors with a gain schedule and
//! draw it as the paper's Fig 20 (Poincaré `y1` per period, phase plane before and after, time
//! history). Without flags: Coulomb, section-3 set, alpha 1.3, start (-1.5, 0, 0, 0) in the
//! period-3 basin, k_p 0 switched to 0.1 at period 300 and kept, 600 periods. `--scan N` tries
//! N consecutive pulse starts instead.

use crate::basins;
use crate::simulate::RunArgs;
use crate::svg::{self, Curve, Panel, Style};
use anyhow::{bail, Context, Result};
use capsule_analysis::switch::{switch_run, SwitchReport};
use capsule_analysis::{GainSchedule, Pulse};
use capsule_plant::scene::Scene;
use capsule_plant::Snapshot;
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Switch attractors with a gain schedule.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    run: RunArgs,
    /// Try the pulse at N consecutive starts (--pulse-at, +1, ...) and report which switch.
    #[arg(long, value_name = "N")]
    scan: Option<u32>,
    /// Output prefix: writes PREFIX.svg, PREFIX.png and PREFIX.json (no files without it).
    #[arg(long, value_name = "PREFIX")]
    out: Option<PathBuf>,
    /// Print the report as JSON on stdout.
    #[arg(long)]
    json: bool,
}

/// Time-history samples per drive period.
const SAMPLES: u32 = 100;

/// The scene and schedule: the flags, with Fig 20's values where none are given.
fn setup(args: &mut Args) -> Result<(Scene, GainSchedule)> {
    let a = &mut args.run.scene;
    if a.scene.is_none() {
        a.alpha.get_or_insert(1.3);
        // on the period-3 orbit's basin (x1 - x2 = -1.5, all at rest): from rest the motion
        // ends on the coexisting period-2 orbit instead
        a.x0.get_or_insert_with(|| "-1.5,0,0,0".into());
        if a.periods.is_none() {
            a.periods = Some(600);
            a.transient.get_or_insert(0);
        }
    }
    let s = &mut args.run.schedule;
    if s.pulse_kp.is_none() && s.pulse_at.is_none() && s.kp_after.is_none() {
        s.pulse_kp = Some(0.1);
        s.pulse_at = Some(300);
        s.kp_after = Some(0.1);
    }
    let (scene, schedule) = args.run.resolve()?;
    if schedule.pulse.is_none() {
        bail!("capsule switch needs a pulse (--pulse-kp, --pulse-at)");
    }
    Ok((scene, schedule))
}

#[derive(Serialize)]
struct ScanRow {
    pulse_at: u32,
    switched: bool,
    before_period: Option<usize>,
    after_period: Option<usize>,
    after_impacts_per_period: f64,
    after_progression: f64,
}

pub fn main(mut args: Args) -> Result<()> {
    let (scene, schedule) = setup(&mut args)?;
    if let Some(n) = args.scan {
        return scan(&scene, &schedule, n, args.json);
    }
    let mut rows: Vec<Snapshot> = Vec::new();
    let report = switch_run(&scene, &schedule, SAMPLES, &mut |s| rows.push(*s))
        .with_context(|| format!("simulating {}", scene.name))?;
    let written = match &args.out {
        Some(prefix) => Some(write(
            prefix,
            &figure(&scene, &schedule, &report, &rows),
            &report,
        )?),
        None => None,
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        let describe = |a: &capsule_analysis::attractor::Attractor| {
            format!(
                "period {}, {:.2} impacts/period, progression {:+.5}",
                a.period.map_or("none".into(), |p| p.to_string()),
                a.impacts_per_period,
                a.avg_progression
            )
        };
        println!("before  {}", describe(&report.before));
        println!("after   {}", describe(&report.after));
        let verdict = if report.switched {
            "switched"
        } else {
            "not switched"
        };
        match written {
            Some(w) => println!("{verdict}; wrote {w}"),
            None => println!("{verdict}"),
        }
    }
    Ok(())
}

fn scan(scene: &Scene, schedule: &GainSchedule, n: u32, json: bool) -> Result<()> {
    let Some(p) = schedule.pulse else {
        bail!("--scan needs a pulse");
    };
    let last = schedule.with_pulse_at(p.at + n.saturating_sub(1));
    last.validate(scene.horizon.periods)
        .map_err(|(k, r)| anyhow::anyhow!("--scan {n}: {k}: {r}"))?;
    let rows: Vec<ScanRow> = (0..n)
        .into_par_iter()
        .map(|j| {
            let s = schedule.with_pulse_at(p.at + j);
            let r = switch_run(scene, &s, 0, &mut |_| {})?;
            Ok(ScanRow {
                pulse_at: p.at + j,
                switched: r.switched,
                before_period: r.before.period,
                after_period: r.after.period,
                after_impacts_per_period: r.after.impacts_per_period,
                after_progression: r.after.avg_progression,
            })
        })
        .collect::<Result<_, capsule_plant::SimError>>()?;
    if json {
        println!("{}", serde_json::to_string_pretty(&rows)?);
        return Ok(());
    }
    for r in &rows {
        println!(
            "pulse at {:>5}: period {} -> {} ({:.2} impacts/period, progression {:+.5}){}",
            r.pulse_at,
            r.before_period.map_or("none".into(), |p| p.to_string()),
            r.after_period.map_or("none".into(), |p| p.to_string()),
            r.after_impacts_per_period,
            r.after_progression,
            if r.switched { "  switched" } else { "" }
        );
    }
    Ok(())
}

/// Fig 20 for a scheduled run: Poincaré `y1` per period, phase plane before and after, time
/// history around the pulse.
pub fn figure(
    scene: &Scene,
    schedule: &GainSchedule,
    report: &SwitchReport,
    rows: &[Snapshot],
) -> String {
    let p = schedule.pulse.unwrap_or(Pulse {
        kp: schedule.before,
        at: 0,
        periods: 0,
    });
    let at = p.at as usize;
    let y1: Vec<(f64, f64)> = report
        .poincare
        .iter()
        .enumerate()
        .map(|(i, q)| ((i + 1) as f64, q[2]))
        .collect();
    let a = Panel::new(
        "(a) Poincaré y1 per drive period",
        "period n",
        "y1*",
        vec![Curve::new("", "black", Style::Dots, y1)],
    )
    .with_vline(at as f64, RED);
    let b = phase_panel(scene, report, rows, at);
    let c = history_panel(scene, report, rows, at);
    let caption = vec![
        format!(
            "{} friction, alpha {}, omega {}, {}; k_p {} until period {}, {} for {} period(s), then {}.",
            scene.model.friction.name(),
            scene.drive.alpha,
            scene.drive.omega,
            scene.model.capsule,
            schedule.before,
            p.at,
            p.kp,
            p.periods,
            schedule.after
        ),
        format!(
            "Before: period {}, {:.2} impacts/period; after: period {}, {:.2} impacts/period ({}). Green: impact surface x1 - x2 = delta; red line: the pulse.",
            fmt_period(report.before.period),
            report.before.impacts_per_period,
            fmt_period(report.after.period),
            report.after.impacts_per_period,
            if report.switched { "switched" } else { "not switched" }
        ),
    ];
    svg::panels(
        "Switching attractors by position feedback (Fig 20)",
        &caption,
        3,
        svg::PANEL,
        &[a, b, c],
    )
}

/// The pulse's colour.
const RED: &str = "#d62728";

/// The samples of drive periods `from` to `to` (both ends included).
fn window(rows: &[Snapshot], from: usize, to: usize) -> &[Snapshot] {
    let per = SAMPLES as usize;
    &rows[(from * per).min(rows.len())..(to * per + 1).min(rows.len())]
}

/// Panel (b): the last orbit before the pulse and the last after, with the Poincaré points.
fn phase_panel(scene: &Scene, report: &SwitchReport, rows: &[Snapshot], at: usize) -> Panel {
    let k_before = report.before.period.unwrap_or(1).max(1);
    let k_after = report.after.period.unwrap_or(1).max(1);
    let n = report.poincare.len();
    let phase = |r: &[Snapshot]| -> Vec<(f64, f64)> {
        r.iter()
            .map(|s| (s.state.x1 - s.state.x2, s.state.y1 - s.state.y2))
            .collect()
    };
    let sec = |c: &[[f64; 3]]| c.iter().map(|q| (q[0], q[1])).collect::<Vec<_>>();
    Panel::new(
        "(b) phase plane before (grey) and after (red)",
        "x1 - x2",
        "y1 - y2",
        vec![
            Curve::new(
                format!("before: period {}", fmt_period(report.before.period)),
                "#999999",
                Style::Line,
                phase(window(rows, at.saturating_sub(k_before), at)),
            ),
            Curve::new(
                format!("after: period {}", fmt_period(report.after.period)),
                RED,
                Style::Line,
                phase(window(rows, n.saturating_sub(k_after), n)),
            ),
            Curve::new(
                "Poincaré section",
                "#1f5fd6",
                Style::Dots,
                [sec(&report.before.poincare), sec(&report.after.poincare)].concat(),
            ),
        ],
    )
    .with_vline(scene.model.capsule.delta, "#2ca02c")
}

/// Panel (c): the displacements from 15 periods before the pulse to 45 after.
fn history_panel(scene: &Scene, report: &SwitchReport, rows: &[Snapshot], at: usize) -> Panel {
    let n = report.poincare.len();
    let (from, to) = (at.saturating_sub(15), (at + 45).min(n));
    let hist = window(rows, from, to);
    Panel::new(
        format!("(c) displacements, periods {from} to {to}"),
        "tau",
        "x1 (solid), x2 (dashed)",
        vec![
            Curve::new(
                "x1",
                "black",
                Style::Line,
                hist.iter().map(|s| (s.tau, s.state.x1)).collect(),
            ),
            Curve::new(
                "x2",
                RED,
                Style::Dashed,
                hist.iter().map(|s| (s.tau, s.state.x2)).collect(),
            ),
        ],
    )
    .with_vline(at as f64 * scene.drive.period(), RED)
}

fn fmt_period(p: Option<usize>) -> String {
    p.map_or("none".into(), |k| k.to_string())
}

/// Write PREFIX.svg, .png and .json; the list of files.
pub fn write(prefix: &Path, doc: &str, report: &SwitchReport) -> Result<String> {
    if let Some(dir) = prefix.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let svg_path = basins::with_ext(prefix, "svg");
    let png_path = basins::with_ext(prefix, "png");
    let json_path = basins::with_ext(prefix, "json");
    std::fs::write(&svg_path, doc).with_context(|| format!("writing {}", svg_path.display()))?;
    let png = svg::png(doc, 1.5).map_err(|e| anyhow::anyhow!("rasterising the picture: {e}"))?;
    std::fs::write(&png_path, png).with_context(|| format!("writing {}", png_path.display()))?;
    std::fs::write(&json_path, serde_json::to_string(report)?)
        .with_context(|| format!("writing {}", json_path.display()))?;
    Ok(format!(
        "{}, {}, {}",
        svg_path.display(),
        png_path.display(),
        json_path.display()
    ))
}
