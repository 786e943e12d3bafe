//! `capsule bench`: timings that print figures (not timed tests).
//!
//! - `speed`: the section-5 run per method and the Fig 2a sweep (the targets);
//! - `accuracy`: work-precision per friction law and method, and the zero-order-hold error per
//!   control rate; writes CSV, JSON and log-log SVG plots;
//! - `effects`: cost per drive period as effects are added one at a time.

use crate::svg;
use anyhow::{Context, Result};
use capsule_analysis::accuracy::{ladder, rate_ladder, Point};
use capsule_analysis::{run, sweep, Param};
use capsule_plant::scene::Scene;
use capsule_plant::{Capsule, Friction, Method, Model, SolverConfig};
use clap::ValueEnum;
use std::io::Write;
use std::path::PathBuf;
use std::time::Instant;

/// Which benchmark.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum What {
    /// Section-5 run per method, and the 1901-value Fig 2a sweep.
    Speed,
    /// Error against the tightest reference versus time and work, per law and method.
    Accuracy,
    /// Cost per drive period as scene effects are added one at a time.
    Effects,
}

/// Benchmark settings.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark.
    #[arg(value_enum, default_value_t = What::Speed)]
    what: What,
    /// Repetitions of each timed run (the best is reported).
    #[arg(long, default_value_t = 10)]
    repeat: u32,
    /// Values in the Fig 2a alpha sweep (speed).
    #[arg(long, default_value_t = 1901)]
    sweep_values: usize,
    /// Output prefix for the accuracy tables and plots.
    #[arg(long, value_name = "PREFIX", default_value = "docs/accuracy/accuracy")]
    out: PathBuf,
}

/// Section 5 control point (Fig 14-15) with the given gain.
pub fn section5(kp: f64) -> Scene {
    let model = Model {
        capsule: Capsule {
            gamma: 0.235,
            beta: 3.05,
            delta: 0.02,
            xi: 0.05,
        },
        friction: Friction::Coulomb,
    };
    let mut s = Scene {
        model,
        solver: SolverConfig::most_accurate_for(&model),
        ..Scene::default()
    };
    s.name = format!("section 5, kp = {kp}");
    s.drive.alpha = 1.6;
    s.drive.omega = 1.1;
    s.control.kp = kp;
    s
}

/// The section-3 set with a friction law, at a drive amplitude where the motion is periodic.
fn section3(friction: Friction, alpha: f64) -> Scene {
    let model = Model {
        capsule: Capsule {
            gamma: 5.0,
            beta: 15.0,
            delta: 0.02,
            xi: 0.01,
        },
        friction,
    };
    let mut s = Scene {
        model,
        solver: SolverConfig::most_accurate_for(&model),
        ..Scene::default()
    };
    s.name = format!("section 3, {}, alpha {alpha}", friction.name());
    s.drive.alpha = alpha;
    s
}

pub fn main(args: Args) -> Result<()> {
    match args.what {
        What::Speed => speed(&args),
        What::Accuracy => accuracy(&args),
        What::Effects => effects(&args),
    }
}

fn best_of(scene: &Scene, repeat: u32) -> Result<(capsule_analysis::RunReport, f64)> {
    let mut best = f64::INFINITY;
    let mut report = None;
    for _ in 0..repeat.max(1) {
        let t0 = Instant::now();
        let r = run(scene)?;
        best = best.min(t0.elapsed().as_secs_f64());
        report = Some(r);
    }
    report.map(|r| (r, best)).context("no run")
}

fn speed(args: &Args) -> Result<()> {
    println!("300 periods of the section-5 scene (Coulomb, alpha 1.6, omega 1.1, kp 0.1):");
    for (method, tol) in [
        (Method::Exact, 0.0),
        (Method::Adaptive, 1e-10),
        (Method::Adaptive, 1e-12),
    ] {
        let mut scene = section5(0.1);
        scene.solver.method = method;
        if tol > 0.0 {
            scene.solver.tol = tol;
        }
        let (r, best) = best_of(&scene, args.repeat)?;
        println!(
            "  {:<9} tol {:<7} best of {:>3}: {:>9.3} ms   progression {:+.12e}   {} steps, {} events",
            method.name(),
            if tol > 0.0 { format!("{tol:e}") } else { "-".into() },
            args.repeat.max(1),
            best * 1e3,
            r.avg_progression,
            r.work.steps,
            r.work.events
        );
    }
    println!();
    let fig2a = Scene {
        name: "Fig 2a".into(),
        ..Scene::default()
    };
    let values: Vec<f64> = (0..args.sweep_values)
        .map(|i| 0.1 + 1.9 * i as f64 / (args.sweep_values.max(2) - 1) as f64)
        .collect();
    let t0 = Instant::now();
    let points = sweep(&fig2a, Param::Alpha, &values, &|| {});
    let wall = t0.elapsed().as_secs_f64();
    let failed = points.iter().filter(|p| p.result.is_err()).count();
    println!(
        "Fig 2a sweep: {} values of alpha in [0.1, 2.0], 300 periods each, exact method, {} threads: {:.2} s ({} failed)",
        values.len(),
        rayon::current_num_threads(),
        wall,
        failed
    );
    Ok(())
}

fn accuracy(args: &Args) -> Result<()> {
    let scenes = [
        section5(0.1),
        section3(Friction::Viscous { mu_v: 0.1 }, 1.6),
        section3(Friction::Stribeck { v_s: 0.1 }, 1.9),
        section3(
            Friction::SevenParameter {
                mu_v: 0.1,
                v_s: 0.1,
                tau_d: 0.05,
                k_s: 4e4,
            },
            1.9,
        ),
    ];
    let mut all: Vec<Point> = Vec::new();
    println!(
        "{:<40} {:<9} {:>8} {:>11} {:>11} {:>11} {:>10} {:>10}",
        "scene", "method", "setting", "err prog", "err x2", "err poinc", "ms", "rhs evals"
    );
    for scene in &scenes {
        let points = ladder(scene, args.repeat)
            .with_context(|| format!("accuracy ladder for {}", scene.name))?;
        for p in &points {
            println!(
                "{:<40} {:<9} {:>8.0e} {:>11.3e} {:>11.3e} {:>11.3e} {:>10.3} {:>10}",
                p.scene,
                p.method,
                p.setting,
                p.err_progression,
                p.err_final_x2,
                p.err_poincare,
                p.wall_s * 1e3,
                p.work.rhs_evals
            );
        }
        all.extend(points);
    }
    if let Some(dir) = args.out.parent() {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let csv = args.out.with_extension("csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&csv).with_context(|| format!("writing {}", csv.display()))?,
    );
    writeln!(w, "scene,friction,method,setting,err_progression,err_final_x2,err_poincare,wall_s,steps,rejected,rhs_evals,events")?;
    for p in &all {
        writeln!(
            w,
            "\"{}\",{},{},{},{},{},{},{},{},{},{},{}",
            p.scene,
            p.friction,
            p.method,
            p.setting,
            p.err_progression,
            p.err_final_x2,
            p.err_poincare,
            p.wall_s,
            p.work.steps,
            p.work.rejected,
            p.work.rhs_evals,
            p.work.events
        )?;
    }
    w.flush()?;
    let json = args.out.with_extension("json");
    std::fs::write(&json, serde_json::to_string_pretty(&all)?)
        .with_context(|| format!("writing {}", json.display()))?;
    // log-log plots per law: error of the progression against wall time and against
    // right-hand-side evaluations, a curve per method
    type Cost = fn(&Point) -> f64;
    let costs: [(&str, &str, Cost); 2] = [
        ("", "wall time [s]", |p| p.wall_s),
        ("_work", "right-hand-side evaluations", |p| {
            p.work.rhs_evals as f64
        }),
    ];
    for scene in &scenes {
        let law = scene.model.friction.name();
        for (suffix, xlabel, cost) in costs {
            let mut series = Vec::new();
            for (method, colour) in [
                ("exact", "black"),
                ("adaptive", "steelblue"),
                ("fixed", "firebrick"),
            ] {
                let pts: Vec<(f64, f64)> = all
                    .iter()
                    .filter(|p| p.friction == law && p.method == method)
                    .map(|p| (cost(p), p.err_progression.max(1e-16)))
                    .collect();
                if !pts.is_empty() {
                    series.push(svg::Series {
                        name: method.to_string(),
                        colour,
                        points: pts,
                    });
                }
            }
            let path = PathBuf::from(format!("{}_{law}{suffix}.svg", args.out.display()));
            let title = format!("{}: error of average progression vs cost", scene.name);
            std::fs::write(
                &path,
                svg::loglog(&title, xlabel, "|error| of progression per period", &series),
            )
            .with_context(|| format!("writing {}", path.display()))?;
            println!("wrote {}{}", path.display(), png_beside(&path));
        }
    }
    // the sampled controller: error against the continuous law per control rate
    let rates = [16, 32, 64, 128, 256, 512, 1024, 4096];
    let zoh = rate_ladder(&section5(0.1), &rates)?;
    println!();
    println!(
        "zero-order hold, section-5 scene (kp 0.1): relative error of progression per control rate"
    );
    for r in &zoh {
        println!(
            "  {:>5} samples/period: progression {:+.9e}, relative error {:.3e}",
            r.samples_per_period, r.avg_progression, r.rel_error
        );
    }
    let zpath = PathBuf::from(format!("{}_zoh.svg", args.out.display()));
    let series = [svg::Series {
        name: "zero-order hold".into(),
        colour: "darkgreen",
        points: zoh
            .iter()
            .map(|r| (r.samples_per_period as f64, r.rel_error.max(1e-16)))
            .collect(),
    }];
    std::fs::write(
        &zpath,
        svg::loglog(
            "Sampled feedback: error vs control rate (section 5, kp 0.1)",
            "samples per drive period",
            "relative error of progression",
            &series,
        ),
    )
    .with_context(|| format!("writing {}", zpath.display()))?;
    std::fs::write(
        PathBuf::from(format!("{}_zoh.json", args.out.display())),
        serde_json::to_string_pretty(&zoh)?,
    )?;
    println!(
        "wrote {}, {}, {}{}",
        csv.display(),
        json.display(),
        zpath.display(),
        png_beside(&zpath)
    );
    Ok(())
}

/// Render `svg` to a PNG beside it with `rsvg-convert` (Debian: librsvg2-bin) when that is
/// installed; says what it did. Rasterising in-process would pull a font and imaging stack
/// into the build for a few pictures.
fn png_beside(svg: &std::path::Path) -> String {
    let png = svg.with_extension("png");
    match std::process::Command::new("rsvg-convert")
        .args(["-w", "900", "-o"])
        .arg(&png)
        .arg(svg)
        .status()
    {
        Ok(s) if s.success() => format!(" and {}", png.display()),
        _ => " (no PNG: install rsvg-convert, Debian package librsvg2-bin)".to_string(),
    }
}

fn effects(args: &Args) -> Result<()> {
    let cap = |beta| Capsule {
        gamma: 5.0,
        beta,
        delta: 0.02,
        xi: 0.01,
    };
    let stribeck = Friction::Stribeck { v_s: 0.1 };
    // memory without pre-sliding: k_s = 0 (not a valid scene value, built here directly)
    let memory = Friction::SevenParameter {
        mu_v: 0.1,
        v_s: 0.1,
        tau_d: 0.05,
        k_s: 0.0,
    };
    let memory_off = Friction::SevenParameter {
        mu_v: 0.1,
        v_s: 0.1,
        tau_d: 0.0,
        k_s: 0.0,
    };
    let full = Friction::SevenParameter {
        mu_v: 0.1,
        v_s: 0.1,
        tau_d: 0.05,
        k_s: 4e4,
    };
    let rows: Vec<(&str, Model, f64, Method)> = vec![
        (
            "Coulomb, no contact spring",
            Model {
                capsule: cap(0.0),
                friction: Friction::Coulomb,
            },
            0.0,
            Method::Exact,
        ),
        (
            "+ contact spring",
            Model {
                capsule: cap(15.0),
                friction: Friction::Coulomb,
            },
            0.0,
            Method::Exact,
        ),
        (
            "+ viscous",
            Model {
                capsule: cap(15.0),
                friction: Friction::Viscous { mu_v: 0.1 },
            },
            0.0,
            Method::Exact,
        ),
        (
            "Coulomb + contact, adaptive",
            Model {
                capsule: cap(15.0),
                friction: Friction::Coulomb,
            },
            0.0,
            Method::Adaptive,
        ),
        (
            "Stribeck (adaptive)",
            Model {
                capsule: cap(15.0),
                friction: stribeck,
            },
            0.0,
            Method::Adaptive,
        ),
        (
            "seven-parameter, tau_d = 0, k_s = 0",
            Model {
                capsule: cap(15.0),
                friction: memory_off,
            },
            0.0,
            Method::Adaptive,
        ),
        (
            "+ memory (tau_d 0.05)",
            Model {
                capsule: cap(15.0),
                friction: memory,
            },
            0.0,
            Method::Adaptive,
        ),
        (
            "+ pre-sliding (k_s 4e4)",
            Model {
                capsule: cap(15.0),
                friction: full,
            },
            0.0,
            Method::Adaptive,
        ),
        (
            "+ feedback (k_p 0.1)",
            Model {
                capsule: cap(15.0),
                friction: full,
            },
            0.1,
            Method::Adaptive,
        ),
    ];
    println!(
        "cost per drive period, section-3 set, alpha 1.9, 300 periods, best of {}",
        args.repeat.max(1)
    );
    println!(
        "{:<38} {:>9} {:>12} {:>12} {:>10} {:>12}",
        "scene", "method", "us/period", "rhs/period", "events/p", "ns/rhs eval"
    );
    for (name, model, kp, method) in rows {
        let mut s = Scene {
            model,
            ..Scene::default()
        };
        s.drive.alpha = 1.9;
        s.control.kp = kp;
        s.solver = SolverConfig {
            method,
            tol: 1e-10,
            step: 1e-3,
        };
        let (r, best) = best_of(&s, args.repeat)?;
        let n = s.horizon.periods as f64;
        println!(
            "{:<38} {:>9} {:>12.2} {:>12.1} {:>10.2} {:>12.1}",
            name,
            method.name(),
            best / n * 1e6,
            r.work.rhs_evals as f64 / n,
            r.work.events as f64 / n,
            best / r.work.rhs_evals as f64 * 1e9
        );
    }
    Ok(())
}
