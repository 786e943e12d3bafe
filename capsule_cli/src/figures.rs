//! `capsule figures --out DIR`: the paper's figures that the model covers, as SVG and PNG with
//! captions, and one Markdown page placing each beside the paper's claim and what we found.
//! Figures are computed in parallel (and each in parallel inside) under one progress bar.

use crate::basins::{self, Computed};
use crate::bench::{section3, section5};
use crate::svg::{self, Curve, Panel, Style};
use crate::switch;
use anyhow::{Context, Result};
use capsule_analysis::basin::{Grid, Method};
use capsule_analysis::switch::switch_run;
use capsule_analysis::{run_sampled, sweep, GainSchedule, Param, Pulse, SweepPoint};
use capsule_plant::model::V_S;
use capsule_plant::scene::Scene;
use capsule_plant::{Friction, Snapshot, State};
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// Regenerate the paper's figures.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Output directory (created): figNN.svg, figNN.png and figures.md.
    #[arg(long, value_name = "DIR")]
    out: PathBuf,
    /// Values per bifurcation diagram (the paper's look needs about 400-1900).
    #[arg(long, default_value_t = 191, value_parser = clap::value_parser!(u64).range(2..=4001))]
    steps: u64,
    /// Grid side of the basin maps.
    #[arg(long, default_value_t = 60, value_parser = clap::value_parser!(u64).range(2..=1000))]
    grid: u64,
    /// Only these figures, comma-separated (e.g. `2,18,20`).
    #[arg(long, value_name = "N,...")]
    only: Option<String>,
    /// PNG scale (1 = the SVG's size).
    #[arg(long, default_value_t = 1.0)]
    png_scale: f32,
}

/// One figure: what the paper says and what we found.
struct Fig {
    number: u32,
    svg: String,
    claim: &'static str,
    ours: String,
}

/// A figure job: its numbers and how to make them.
type Job = (&'static [u32], fn(&Ctx) -> Result<Vec<Fig>>);

struct Ctx {
    steps: usize,
    grid: usize,
}

fn values(from: f64, to: f64, n: usize) -> Vec<f64> {
    (0..n)
        .map(|i| from + (to - from) * i as f64 / (n - 1) as f64)
        .collect()
}

/// Values of a sweep whose run ended periodic, as a share.
fn periodic_share(points: &[SweepPoint]) -> f64 {
    let n = points
        .iter()
        .filter(|p| p.result.as_ref().is_ok_and(|r| r.period.is_some()))
        .count();
    n as f64 / points.len().max(1) as f64
}

/// The value with the largest progression.
fn best(points: &[SweepPoint]) -> (f64, f64) {
    points
        .iter()
        .filter_map(|p| p.result.as_ref().ok().map(|r| (p.value, r.avg_progression)))
        .fold(
            (f64::NAN, f64::NEG_INFINITY),
            |a, b| if b.1 > a.1 { b } else { a },
        )
}

fn caption_params(s: &Scene) -> String {
    let c = &s.model.capsule;
    format!(
        "gamma {}, omega {}, alpha {}, beta {}, delta {}, xi {}, k_p {}; 300 periods, 200 transient, {} method",
        c.gamma,
        s.drive.omega,
        s.drive.alpha,
        c.beta,
        c.delta,
        c.xi,
        s.control.kp,
        s.solver.method.name()
    )
}

fn figs_2_7(ctx: &Ctx) -> Result<Vec<Fig>> {
    let v = values(0.1, 2.0, ctx.steps);
    let sweeps: Vec<Vec<SweepPoint>> = (0..4)
        .map(|i| {
            sweep(
                &section3(Friction::PAPER_LAWS[i], 0.8),
                Param::Alpha,
                &v,
                &|| {},
            )
        })
        .collect();
    let (mut dots, mut lines) = (Vec::new(), Vec::new());
    let mut ours2 = String::new();
    let mut ours7 = String::new();
    for (i, pts) in sweeps.iter().enumerate() {
        let (mut d, mut l) = svg::bifurcation_panels("alpha", pts);
        d.title = format!(
            "({}) {}",
            (b'a' + i as u8) as char,
            Friction::PAPER_LAWS[i].title()
        );
        l.title = d.title.clone();
        dots.push(d);
        lines.push(l);
        let _ = write!(
            ours2,
            "{}: periodic at {:.0} % of the values; ",
            Friction::PAPER_LAWS[i].title(),
            100.0 * periodic_share(pts)
        );
        let (a, p) = best(pts);
        let _ = write!(
            ours7,
            "{}: fastest {p:+.3}/period at alpha {a:.3}; ",
            Friction::PAPER_LAWS[i].title()
        );
    }
    let cap = vec![format!(
        "{} values of alpha in [0.1, 2.0], each from rest; {}",
        ctx.steps,
        caption_params(&section3(Friction::COULOMB, 0.8))
            .replace("alpha 0.8, ", "")
            .replace(
                "exact method",
                "exact method (adaptive at 1e-10 for Stribeck, seven-parameter)"
            )
    )];
    Ok(vec![
        Fig {
            number: 2,
            svg: svg::panels("Fig 2: bifurcation diagrams over alpha", &cap, 2, (420.0, 240.0), &dots),
            claim: "Periodic for alpha in [0.1, 0.132) and [0.928, 2.0] (Coulomb), [0.942, 2.0] (viscous); Stribeck and seven-parameter chaotic over [0.84, 1.65) and [0.914, 1.722), ending in period 3 with five impacts.",
            ours: ours2,
        },
        Fig {
            number: 7,
            svg: svg::panels("Fig 7: average progression per period over alpha", &cap, 2, (420.0, 240.0), &lines),
            claim: "Progression grows with alpha; dry and thinly lubricated surfaces alike, thicker lubrication slower.",
            ours: ours7,
        },
    ])
}

fn fig_8(ctx: &Ctx) -> Result<Vec<Fig>> {
    let v = values(0.1, 2.0, ctx.steps);
    let mut dots = Vec::new();
    let mut ours = String::new();
    for (i, xi) in [0.01, 0.02, 0.03, 0.05].into_iter().enumerate() {
        let mut s = section3(Friction::COULOMB, 0.8);
        s.model.capsule.xi = xi;
        let pts = sweep(&s, Param::Alpha, &v, &|| {});
        let (mut d, _) = svg::bifurcation_panels("alpha", &pts);
        d.title = format!("({}) xi = {xi}", (b'a' + i as u8) as char);
        dots.push(d);
        let _ = write!(
            ours,
            "xi {xi}: periodic at {:.0} % of the values; ",
            100.0 * periodic_share(&pts)
        );
    }
    let cap = vec![format!(
        "Coulomb friction, {} values of alpha in [0.1, 2.0] from rest.",
        ctx.steps
    )];
    Ok(vec![Fig {
        number: 8,
        svg: svg::panels(
            "Fig 8: bifurcation diagrams for growing damping xi",
            &cap,
            2,
            (420.0, 240.0),
            &dots,
        ),
        claim: "More damping makes the behaviour less complicated (fewer non-periodic values).",
        ours,
    }])
}

fn fig_9(ctx: &Ctx) -> Result<Vec<Fig>> {
    let v = values(0.8, 1.2, ctx.steps);
    let mut panels = Vec::new();
    let mut ours = String::new();
    for (i, law) in Friction::PAPER_LAWS.iter().enumerate() {
        let name = law.title();
        let pts = sweep(&section3(*law, 0.8), Param::Omega, &v, &|| {});
        let (mut d, mut l) = svg::bifurcation_panels("omega", &pts);
        d.title = format!("({}) {}", (b'a' + i as u8) as char, name);
        l.title = format!("{}: progression", name);
        panels.push(d);
        panels.push(l);
        let (w, p) = best(&pts);
        let _ = write!(ours, "{}: fastest {p:+.3}/period at omega {w:.3}; ", name);
    }
    let cap = vec![format!(
        "{} values of omega in [0.8, 1.2] from rest, alpha 0.8; only the attractor reached from rest (the paper's red coexisting branches need other starts).",
        ctx.steps
    )];
    Ok(vec![Fig {
        number: 9,
        svg: svg::panels("Fig 9: bifurcation and progression over omega", &cap, 2, (420.0, 200.0), &panels),
        claim: "Period 1 with two impacts, grazing, period doubling to chaos, inverse cascade to period 1 with one impact; global optimum near omega 0.846 (coexisting, Coulomb/viscous), local optima near 1.124.",
        ours,
    }])
}

/// The last `periods` periods of a sampled run from rest: phase plane and displacements.
fn history(scene: &Scene, periods: usize) -> Result<(capsule_analysis::RunReport, Vec<Snapshot>)> {
    let per = 100;
    let mut rows = Vec::new();
    let r = run_sampled(scene, per, &mut |s| rows.push(*s))?;
    let keep = (periods * per as usize + 1).min(rows.len());
    let tail = rows.split_off(rows.len() - keep);
    Ok((r, tail))
}

fn phase_and_time(title: &str, rows: &[Snapshot], delta: f64) -> (Panel, Panel) {
    let phase = Panel::new(
        format!("{title}: phase plane"),
        "x1 - x2",
        "y1 - y2",
        vec![Curve::new(
            "",
            "black",
            Style::Line,
            rows.iter()
                .map(|s| (s.state.x1 - s.state.x2, s.state.y1 - s.state.y2))
                .collect(),
        )],
    )
    .with_vline(delta, "#2ca02c");
    let time = Panel::new(
        format!("{title}: displacements"),
        "tau",
        "x1 (solid), x2 (dashed)",
        vec![
            Curve::new(
                "",
                "black",
                Style::Line,
                rows.iter().map(|s| (s.tau, s.state.x1)).collect(),
            ),
            Curve::new(
                "",
                "#d62728",
                Style::Dashed,
                rows.iter().map(|s| (s.tau, s.state.x2)).collect(),
            ),
        ],
    );
    (phase, time)
}

fn four_laws_at(number: u32, omega: f64, claim: &'static str) -> Result<Fig> {
    let mut panels = Vec::new();
    let mut ours = String::new();
    for (i, law) in Friction::PAPER_LAWS.iter().enumerate() {
        let name = law.title();
        let mut s = section3(*law, 0.8);
        s.drive.omega = omega;
        let (r, rows) = history(&s, 5)?;
        let (p, t) = phase_and_time(
            &format!("({}) {}", (b'a' + i as u8) as char, name),
            &rows,
            s.model.capsule.delta,
        );
        panels.push(p);
        panels.push(t);
        let _ = write!(
            ours,
            "{}: period {}, {:.2} impacts/period, progression {:+.4}; ",
            name,
            r.period.map_or("none".into(), |k| k.to_string()),
            r.impacts_per_period,
            r.avg_progression
        );
    }
    let cap = vec![format!(
        "The last 5 of 300 periods from rest; alpha 0.8, omega {omega}; green: impact surface x1 - x2 = delta."
    )];
    Ok(Fig {
        number,
        svg: svg::panels(
            &format!("Fig {number}: trajectories at omega {omega}"),
            &cap,
            4,
            (300.0, 200.0),
            &panels,
        ),
        claim,
        ours,
    })
}

fn figs_10_12_13(_: &Ctx) -> Result<Vec<Fig>> {
    Ok(vec![
        four_laws_at(10, 0.846, "The coexisting (red) attractors of Fig 9 at omega 0.846, grazing at the second impact; the global optimum for Coulomb and viscous.")?,
        four_laws_at(12, 0.842, "Main attractors at omega 0.842: period 1 with two impacts; backward motion for Coulomb and viscous.")?,
        four_laws_at(13, 1.124, "Local optima at omega 1.124, before the inverse period doubling from period 2 with three impacts to period 1 with one impact.")?,
    ])
}

fn basin_fig(
    number: u32,
    title: &str,
    scenes: Vec<(Option<f64>, Scene)>,
    param: &str,
    ctx: &Ctx,
    claim: &'static str,
) -> Result<Fig> {
    let g = ctx.grid;
    let grid = Grid::paper(g);
    let cancel = AtomicBool::new(false);
    let maps: Vec<Computed> =
        basins::compute_with(&scenes, &grid, 1e-4, &Method::PerState, &cancel, &|| {});
    let panels: Vec<svg::BasinPanel> = maps
        .iter()
        .map(|m| svg::BasinPanel {
            title: m
                .value
                .map_or_else(|| basins::title_of(&m.scene), |v| format!("{param} = {v}")),
            map: &m.map,
            labels: m.map.catalogue.ordered(),
        })
        .collect();
    let mut ours = String::new();
    for m in &maps {
        if let Some(v) = m.value {
            let _ = write!(ours, "{param} {v}: ");
        }
        for (i, label) in m.map.catalogue.ordered() {
            let _ = write!(ours, "{label} {:.0} %, ", 100.0 * m.map.fraction(i));
        }
        ours.push_str("; ");
    }
    let s = &scenes[0].1;
    let cap = vec![format!(
        "(x1 - x2, y1 - y2) over [-2, 2]^2 with the capsule at rest, {g} x {g} starts; {}",
        caption_params(s)
    )];
    Ok(Fig {
        number,
        svg: svg::basins(title, &cap, &panels),
        claim,
        ours,
    })
}

/// `base` at each of `values` of `param`, each labelled with its value (a figure's panels).
fn over(base: &Scene, param: Param, values: &[f64]) -> Vec<(Option<f64>, Scene)> {
    values
        .iter()
        .map(|&v| (Some(v), param.apply(base, v)))
        .collect()
}

fn fig_11(ctx: &Ctx) -> Result<Vec<Fig>> {
    let mut s = section3(Friction::COULOMB, 0.8);
    s.drive.omega = 0.85;
    Ok(vec![basin_fig(
        11,
        "Fig 11: basins at alpha 0.8, omega 0.85 (Coulomb)",
        vec![(None, s)],
        "",
        ctx,
        "Period 1 with one impact and period 1 with two impacts coexist; the global optimum's basin is very limited.",
    )?])
}

fn fig_18(ctx: &Ctx) -> Result<Vec<Fig>> {
    let base = section3(Friction::COULOMB, 0.8);
    let scenes = over(&base, Param::Alpha, &[0.682, 0.9, 1.1, 1.3, 1.5, 1.64]);
    Ok(vec![basin_fig(
        18,
        "Fig 18: basins over alpha (Coulomb, k_p 0)",
        scenes,
        "alpha",
        ctx,
        "Period 3 emerges at alpha 0.682 beside the dominant chaos, the chaos turns period 2 then period 1 whose basin grows; the period-3 basin shrinks until it disappears at alpha 1.654.",
    )?])
}

fn fig_19(ctx: &Ctx) -> Result<Vec<Fig>> {
    let base = section3(Friction::COULOMB, 1.5);
    let scenes = over(&base, Param::Kp, &[0.0, 0.05, 0.1]);
    Ok(vec![basin_fig(
        19,
        "Fig 19: basins at alpha 1.5 for k_p 0, 0.05, 0.1 (Coulomb)",
        scenes,
        "k_p",
        ctx,
        "Without control the period-3 and period-1 basins are about equal; k_p 0.05 turns period 3 into period 6 with a smaller basin; at k_p 0.1 period 3 again, small and fractal, the period-1 basin much larger.",
    )?])
}

fn fig_14(ctx: &Ctx) -> Result<Vec<Fig>> {
    let s = section5(0.0);
    let pts = sweep(
        &s,
        Param::Gamma,
        &values(0.1, 0.6, ctx.steps.min(101)),
        &|| {},
    );
    let (_, mut l) = svg::bifurcation_panels("gamma", &pts);
    l.title = "(a) progression over gamma".into();
    let mut at = s.clone();
    at.model.capsule.gamma = 0.235;
    let (r, rows) = history(&at, 3)?;
    let (p, t) = phase_and_time("(b, c) gamma 0.235", &rows, at.model.capsule.delta);
    let cap = vec![format!(
        "Section 5: {}",
        caption_params(&s).replace("gamma 5, ", "")
    )];
    Ok(vec![Fig {
        number: 14,
        svg: svg::panels("Fig 14: the control point", &cap, 3, svg::PANEL, &[l, p, t]),
        claim: "No average progression at gamma 0.235 (the control point): mass and capsule oscillate around their origins.",
        ours: format!("at gamma 0.235: progression {:+.2e}/period, period {}", r.avg_progression, r.period.map_or("none".into(), |k| k.to_string())),
    }])
}

fn fig_15(ctx: &Ctx) -> Result<Vec<Fig>> {
    let pts = sweep(
        &section5(0.0),
        Param::Kp,
        &values(-0.2, 0.2, ctx.steps.min(101)),
        &|| {},
    );
    let (d, l) = svg::bifurcation_panels("k_p", &pts);
    let cap = vec![format!(
        "Section 5, gamma 0.235: {}",
        caption_params(&section5(0.0))
    )];
    let back = pts
        .iter()
        .filter(|p| p.value < 0.0 && p.result.as_ref().is_ok_and(|r| r.avg_progression < 0.0))
        .count();
    Ok(vec![Fig {
        number: 15,
        svg: svg::panels("Fig 15: y1* and progression over the gain k_p", &cap, 2, svg::PANEL, &[d, l]),
        claim: "Period 1 for every k_p in [-0.2, 0.2]; negative gains move the capsule backward (one impact), positive forward (two impacts).",
        ours: format!(
            "periodic at {:.0} % of the gains; {back} of the negative gains move backward",
            100.0 * periodic_share(&pts)
        ),
    }])
}

fn figs_16_17(_: &Ctx) -> Result<Vec<Fig>> {
    let off = section3(Friction::PAPER_LAWS[2], 1.3);
    let mut on = off.clone();
    on.control.kp = 1.0;
    let (r0, h0) = history(&off, 10)?;
    let (r1, h1) = history(&on, 10)?;
    // every panel: one point of each snapshot of both runs, k_p 0 grey and k_p 1 red
    let both = |point: fn(&Snapshot) -> (f64, f64)| {
        vec![
            Curve::new(
                "k_p 0",
                "#999999",
                Style::Line,
                h0.iter().map(point).collect(),
            ),
            Curve::new(
                "k_p 1",
                "#d62728",
                Style::Line,
                h1.iter().map(point).collect(),
            ),
        ]
    };
    let a = Panel::new(
        "(a) phase plane",
        "x1 - x2",
        "y1 - y2",
        both(|s| (s.state.x1 - s.state.x2, s.state.y1 - s.state.y2)),
    )
    .with_vline(off.model.capsule.delta, "#2ca02c");
    let b = Panel::new(
        "(b) capsule displacement",
        "tau",
        "x2",
        both(|s| (s.tau, s.state.x2)),
    );
    let f = Panel::new(
        "Fig 17(a) actuator force",
        "tau",
        "f_a",
        both(|s| (s.tau, s.actuator_force)),
    );
    let cap = vec![format!(
        "Coulomb Stribeck (v_s {}), the last 10 of 300 periods from rest; {}",
        V_S.paper,
        caption_params(&on)
    )];
    let per = |r: &capsule_analysis::RunReport| {
        format!(
            "period {}, {:.2} impacts/period, progression {:+.4}, efficiency {:+.4}",
            r.period.map_or("none".into(), |k| k.to_string()),
            r.impacts_per_period,
            r.avg_progression,
            r.efficiency
        )
    };
    Ok(vec![
        Fig {
            number: 16,
            svg: svg::panels("Fig 16: chaos control, Stribeck, alpha 1.3", &cap, 2, svg::PANEL, &[a, b]),
            claim: "Chaos without control; k_p 1 gives period 2 with four impacts, slower but forward only.",
            ours: format!("k_p 0: {}; k_p 1: {}", per(&r0), per(&r1)),
        },
        Fig {
            number: 17,
            svg: svg::panels("Fig 17: actuator force with and without control", &cap, 1, (860.0, 240.0), &[f]),
            claim: "Much smaller excitation amplitude with control, and higher control efficiency (17b: efficiency per period; here as one number over the measured periods).",
            ours: format!("efficiency k_p 0 {:+.4}, k_p 1 {:+.4}", r0.efficiency, r1.efficiency),
        },
    ])
}

fn fig_20(_: &Ctx) -> Result<Vec<Fig>> {
    let mut scene = section3(Friction::COULOMB, 1.3);
    scene.initial = State {
        x1: -1.5,
        y1: 0.0,
        x2: 0.0,
        y2: 0.0,
    };
    scene.horizon.periods = 600;
    let schedule = GainSchedule {
        before: 0.0,
        pulse: Some(Pulse {
            kp: 0.1,
            at: 300,
            periods: 1,
        }),
        after: 0.1,
    };
    let mut rows = Vec::new();
    let r = switch_run(&scene, &schedule, 100, &mut |s| rows.push(*s))?;
    Ok(vec![Fig {
        number: 20,
        svg: switch::figure(&scene, &schedule, &r, &rows),
        claim: "Control from period 3 (five impacts) to period 1 (one impact) by the feedback applied at period 300, with a transient.",
        ours: format!(
            "start (-1.5, 0, 0, 0): period {} with {:.2} impacts/period before, period {} with {:.2} after k_p 0.1 from period 300 on ({}). At alpha 1.3 there is no period-1 orbit at k_p 0, so the gain must stay on; a released one-period pulse moves P3 to P2 at two phases of three (docs/attractors.md).",
            r.before.period.map_or("none".into(), |k| k.to_string()),
            r.before.impacts_per_period,
            r.after.period.map_or("none".into(), |k| k.to_string()),
            r.after.impacts_per_period,
            if r.switched { "switched" } else { "not switched" }
        ),
    }])
}

const JOBS: [Job; 11] = [
    (&[2, 7], figs_2_7),
    (&[8], fig_8),
    (&[9], fig_9),
    (&[10, 12, 13], figs_10_12_13),
    (&[11], fig_11),
    (&[14], fig_14),
    (&[15], fig_15),
    (&[16, 17], figs_16_17),
    (&[18], fig_18),
    (&[19], fig_19),
    (&[20], fig_20),
];

pub fn main(args: Args) -> Result<()> {
    if !(args.png_scale > 0.0 && args.png_scale <= 4.0) {
        anyhow::bail!("--png-scale {}: must be in (0, 4]", args.png_scale);
    }
    let wanted: Option<Vec<u32>> = match &args.only {
        None => None,
        Some(list) => Some(
            list.split(',')
                .map(|s| {
                    let n: u32 = s.trim().trim_start_matches("fig").parse().map_err(|_| {
                        anyhow::anyhow!("--only `{list}`: `{s}` is not a figure number")
                    })?;
                    if !JOBS.iter().any(|j| j.0.contains(&n)) {
                        anyhow::bail!(
                            "--only: the model does not cover Fig {n} (covered: 2, 7-20)"
                        );
                    }
                    Ok(n)
                })
                .collect::<Result<_>>()?,
        ),
    };
    let jobs: Vec<&Job> = JOBS
        .iter()
        .filter(|j| {
            wanted
                .as_ref()
                .is_none_or(|w| j.0.iter().any(|n| w.contains(n)))
        })
        .collect();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("creating {}", args.out.display()))?;
    let ctx = Ctx {
        steps: args.steps as usize,
        grid: args.grid as usize,
    };
    let bar = ProgressBar::new(jobs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} figure jobs, {elapsed} elapsed {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let t0 = std::time::Instant::now();
    let results: Vec<Result<Vec<Fig>>> = jobs
        .par_iter()
        .map(|(numbers, make)| {
            let r = make(&ctx).with_context(|| format!("Fig {numbers:?}"));
            bar.inc(1);
            r
        })
        .collect();
    bar.finish_and_clear();
    let mut figs: Vec<Fig> = Vec::new();
    for r in results {
        figs.extend(r?);
    }
    figs.sort_by_key(|f| f.number);
    let mut md = String::from(
        "# The paper's figures, regenerated\n\nMade by `capsule figures` (see docs/attractors.md for the method of the basin and switching figures). Each figure beside the paper's claim and what this model gives.\n\n",
    );
    for f in &figs {
        if wanted.as_ref().is_some_and(|w| !w.contains(&f.number)) {
            continue;
        }
        let stem = format!("fig{:02}", f.number);
        let svg_path = args.out.join(format!("{stem}.svg"));
        std::fs::write(&svg_path, &f.svg)
            .with_context(|| format!("writing {}", svg_path.display()))?;
        let png = svg::png(&f.svg, args.png_scale)
            .map_err(|e| anyhow::anyhow!("rasterising Fig {}: {e}", f.number))?;
        let png_path = args.out.join(format!("{stem}.png"));
        std::fs::write(&png_path, png)
            .with_context(|| format!("writing {}", png_path.display()))?;
        let _ = write!(
            md,
            "## Fig {}\n\n![Fig {}]({stem}.png)\n\n- **Paper:** {}\n- **Here:** {}\n\n",
            f.number, f.number, f.claim, f.ours
        );
    }
    let md_path = args.out.join("figures.md");
    std::fs::write(&md_path, md).with_context(|| format!("writing {}", md_path.display()))?;
    println!(
        "{} figures in {:.1} s; wrote {} (SVG, PNG) and {}",
        figs.len(),
        t0.elapsed().as_secs_f64(),
        args.out.display(),
        md_path.display()
    );
    Ok(())
}
