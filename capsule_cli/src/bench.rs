//! `capsule bench`: timings that print figures (not timed tests).
//!
//! - `speed`: the section-5 run per method and the Fig 2a sweep (the targets);
//! - `accuracy`: work-precision per friction law and method, and the zero-order-hold error per
//!   control rate; writes CSV, JSON and log-log SVG plots;
//! - `effects`: cost per drive period as effects are added one at a time.

use crate::svg;
use crate::work;
use anyhow::{Context, Result};
use capsule_analysis::accuracy::{best_of, ladder, rate_ladder, Point, RatePoint};
use capsule_analysis::{sweep, Param};
use capsule_args::ranges;
use capsule_plant::scene::Scene;
use capsule_plant::{Capsule, Friction, Method, Model, SolverConfig};
use clap::ValueEnum;
use nix::sys::resource::{getrusage, UsageWho};
use nix::sys::time::TimeVal;
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
    /// Floquet multipliers and Lyapunov spectrum of the section-5 orbit.
    Stability,
    /// A basin of attraction at the Fig 19 scene: time per initial state, what the early stop
    /// saves, the cost per event.
    Basins,
}

/// Benchmark settings.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark.
    #[arg(value_enum, default_value_t = What::Speed)]
    what: What,
    /// Repetitions of each timed run (the best is reported), 1 to 1000.
    #[arg(long, default_value_t = 10, value_parser = ranges::count_u32(1, 1000))]
    repeat: u32,
    /// Values in the Fig 2a alpha sweep (speed), 1 to 1000000.
    #[arg(long, default_value_t = 1901, value_parser = ranges::count_usize(1, 1_000_000))]
    sweep_values: usize,
    /// Grid side of the basin benchmark (basins), 2 to 2000.
    #[arg(long, default_value_t = 200, value_parser = ranges::count_usize(2, 2000))]
    basin_grid: usize,
    /// Write the accuracy tables and plots as PREFIX.csv, PREFIX.json, PREFIX_*.svg/png (its
    /// directory must exist); without it they go to stdout only (the docs' copy: `--out
    /// docs/accuracy/accuracy`).
    #[arg(long, value_name = "PREFIX")]
    out: Option<PathBuf>,
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
        friction: Friction::COULOMB,
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
pub fn section3(friction: Friction, alpha: f64) -> Scene {
    let model = Model {
        capsule: Capsule::SECTION3,
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
        What::Stability => stability(&args),
        What::Basins => basins(&args),
    }
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

fn stability(args: &Args) -> Result<()> {
    use capsule_analysis::floquet::floquet;
    use capsule_analysis::lyapunov::lyapunov;
    let scene = section5(0.1);
    let r = capsule_analysis::run(&scene)?;
    let k = r.period.context("the section-5 orbit is not periodic")?;
    let f = r.final_state;
    let x = [f.x1 - f.x2, f.y1, f.y2];
    let mut best = f64::INFINITY;
    let mut fl = None;
    for _ in 0..args.repeat.max(1) {
        let t0 = Instant::now();
        fl = Some(floquet(&scene, x, k)?);
        best = best.min(t0.elapsed().as_secs_f64());
    }
    let fl = fl.context("no repetition ran")?;
    println!(
        "Floquet multipliers of the section-5 orbit (kp 0.1, period {k}, {} events): best of {}: {:.3} ms, largest modulus {:.6}",
        fl.events.len(),
        args.repeat.max(1),
        best * 1e3,
        fl.largest_modulus
    );
    let mut best = f64::INFINITY;
    for _ in 0..args.repeat.max(1) {
        let t0 = Instant::now();
        lyapunov(&scene)?;
        best = best.min(t0.elapsed().as_secs_f64());
    }
    println!(
        "Lyapunov spectrum of the same scene (200 transient + 100 linearized periods): best of {}: {:.3} ms (the run alone: {:.3} ms)",
        args.repeat.max(1),
        best * 1e3,
        best_of(&scene, args.repeat)?.1 * 1e3
    );
    // continuation of the Fig 2a main branch against the brute-force sweep of the same range
    use capsule_analysis::continuation::{continue_branch, ContinuationConfig};
    let mut fig2a = Scene {
        name: "Fig 2a".into(),
        ..Scene::default()
    };
    fig2a.drive.alpha = 2.0;
    let settings = ContinuationConfig::new(Param::Alpha, 0.95);
    let mut best = f64::INFINITY;
    let mut points = 0;
    for _ in 0..args.repeat.max(1) {
        let t0 = Instant::now();
        let b = continue_branch(&fig2a, &settings)?;
        best = best.min(t0.elapsed().as_secs_f64());
        points = b.points.len();
    }
    println!(
        "Fig 2a main branch, alpha 2.0 -> 0.95 by continuation (start run included): best of {}: {:.1} ms, {points} points",
        args.repeat.max(1),
        best * 1e3
    );
    let values: Vec<f64> = (0..args.sweep_values)
        .map(|i| 0.95 + 1.05 * i as f64 / (args.sweep_values.max(2) - 1) as f64)
        .collect();
    let t0 = Instant::now();
    sweep(&fig2a, Param::Alpha, &values, &|| {});
    println!(
        "the same range by brute-force sweep: {} values, 300 periods each, {} threads: {:.2} s",
        values.len(),
        rayon::current_num_threads(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

/// Work-precision per friction law and method, then the zero-order hold's error per control
/// rate: tables on stdout; with `--out`, CSV, JSON and log-log plots there.
fn accuracy(args: &Args) -> Result<()> {
    if let Some(out) = &args.out {
        work::check_parent(out)?;
    }
    let scenes = accuracy_scenes();
    let all = accuracy_table(&scenes, args.repeat)?;
    let zoh = zero_order_hold()?;
    let Some(out) = &args.out else {
        eprintln!("no files written (--out PREFIX writes the CSV, JSON and plots)");
        return Ok(());
    };
    let (csv, json) = write_accuracy_tables(out, &all)?;
    plot_accuracy(out, &scenes, &all)?;
    let zpath = write_zero_order_hold(out, &zoh)?;
    println!(
        "wrote {}, {}, {}{}",
        csv.display(),
        json.display(),
        zpath.display(),
        png_beside(&zpath)
    );
    Ok(())
}

/// One periodic scene per friction law: the section-5 control point (Coulomb, `k_p = 0.1`) and
/// the section-3 set for viscous, Stribeck and seven-parameter friction.
fn accuracy_scenes() -> [Scene; 4] {
    [
        section5(0.1),
        section3(
            Friction::Viscous(capsule_plant::friction::Viscous { mu_v: 0.1 }),
            1.6,
        ),
        section3(
            Friction::Stribeck(capsule_plant::friction::Stribeck { v_s: 0.1 }),
            1.9,
        ),
        section3(
            Friction::SevenParameter(capsule_plant::friction::SevenParameter {
                mu_v: 0.1,
                v_s: 0.1,
                tau_d: 0.05,
                k_s: 4e4,
            }),
            1.9,
        ),
    ]
}

/// Every method's ladder of settings on each scene (best of `repeat`), printed as a table.
fn accuracy_table(scenes: &[Scene], repeat: u32) -> Result<Vec<Point>> {
    let mut all: Vec<Point> = Vec::new();
    println!(
        "{:<40} {:<9} {:>8} {:>11} {:>11} {:>11} {:>10} {:>10}",
        "scene", "method", "setting", "err prog", "err x2", "err poinc", "ms", "rhs evals"
    );
    for scene in scenes {
        let points =
            ladder(scene, repeat).with_context(|| format!("accuracy ladder for {}", scene.name))?;
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
    Ok(all)
}

/// The work-precision points as `PREFIX.csv` and `PREFIX.json`; their paths.
fn write_accuracy_tables(out: &std::path::Path, all: &[Point]) -> Result<(PathBuf, PathBuf)> {
    let csv = out.with_extension("csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&csv).with_context(|| format!("writing {}", csv.display()))?,
    );
    writeln!(w, "scene,friction,method,setting,err_progression,err_final_x2,err_poincare,wall_s,steps,rejected,rhs_evals,events")?;
    for p in all {
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
    let json = out.with_extension("json");
    std::fs::write(&json, serde_json::to_string_pretty(all)?)
        .with_context(|| format!("writing {}", json.display()))?;
    Ok((csv, json))
}

/// Log-log plots per law: the error of the progression against wall time and against
/// right-hand-side evaluations, a curve per method (`PREFIX_LAW.svg`, `PREFIX_LAW_work.svg`).
fn plot_accuracy(out: &std::path::Path, scenes: &[Scene], all: &[Point]) -> Result<()> {
    type Cost = fn(&Point) -> f64;
    let costs: [(&str, &str, Cost); 2] = [
        ("", "wall time [s]", |p| p.wall_s),
        ("_work", "right-hand-side evaluations", |p| {
            p.work.rhs_evals as f64
        }),
    ];
    for scene in scenes {
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
            let path = PathBuf::from(format!("{}_{law}{suffix}.svg", out.display()));
            let title = format!("{}: error of average progression vs cost", scene.name);
            std::fs::write(
                &path,
                svg::loglog(&title, xlabel, "|error| of progression per period", &series),
            )
            .with_context(|| format!("writing {}", path.display()))?;
            println!("wrote {}{}", path.display(), png_beside(&path));
        }
    }
    Ok(())
}

/// The sampled controller: the error against the continuous law per control rate (section 5,
/// `k_p = 0.1`), printed.
fn zero_order_hold() -> Result<Vec<RatePoint>> {
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
    Ok(zoh)
}

/// The zero-order hold's errors plotted (`PREFIX_zoh.svg`) and written (`PREFIX_zoh.json`);
/// the plot's path.
fn write_zero_order_hold(out: &std::path::Path, zoh: &[RatePoint]) -> Result<PathBuf> {
    let zpath = PathBuf::from(format!("{}_zoh.svg", out.display()));
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
        PathBuf::from(format!("{}_zoh.json", out.display())),
        serde_json::to_string_pretty(zoh)?,
    )?;
    Ok(zpath)
}

/// Render `svg` to a PNG beside it (in-process, [`svg::png`]); says what it did.
fn png_beside(svg: &std::path::Path) -> String {
    let png = svg.with_extension("png");
    let made = std::fs::read_to_string(svg)
        .map_err(|e| e.to_string())
        .and_then(|doc| svg::png(&doc, 1.0))
        .and_then(|bytes| std::fs::write(&png, bytes).map_err(|e| e.to_string()));
    match made {
        Ok(()) => format!(" and {}", png.display()),
        Err(e) => format!(" (no PNG: {e})"),
    }
}

/// The effects benchmark's rows: a name, the contact spring's `beta`, the friction law, the
/// feedback gain and the method, each row adding one effect.
fn effect_rows() -> [(&'static str, f64, Friction, f64, Method); 9] {
    use capsule_plant::friction::{SevenParameter, Stribeck, Viscous};
    let seven = |tau_d, k_s| {
        Friction::SevenParameter(SevenParameter {
            mu_v: 0.1,
            v_s: 0.1,
            tau_d,
            k_s,
        })
    };
    let (coulomb, viscous) = (Friction::COULOMB, Friction::Viscous(Viscous { mu_v: 0.1 }));
    let stribeck = Friction::Stribeck(Stribeck { v_s: 0.1 });
    // memory without pre-sliding: k_s = 0 (not a valid scene value, built here directly)
    let (memory_off, memory, full) = (seven(0.0, 0.0), seven(0.05, 0.0), seven(0.05, 4e4));
    let (exact, adaptive) = (Method::Exact, Method::Adaptive);
    [
        ("Coulomb, no contact spring", 0.0, coulomb, 0.0, exact),
        ("+ contact spring", 15.0, coulomb, 0.0, exact),
        ("+ viscous", 15.0, viscous, 0.0, exact),
        ("Coulomb + contact, adaptive", 15.0, coulomb, 0.0, adaptive),
        ("Stribeck (adaptive)", 15.0, stribeck, 0.0, adaptive),
        (
            "seven-parameter, tau_d = 0, k_s = 0",
            15.0,
            memory_off,
            0.0,
            adaptive,
        ),
        ("+ memory (tau_d 0.05)", 15.0, memory, 0.0, adaptive),
        ("+ pre-sliding (k_s 4e4)", 15.0, full, 0.0, adaptive),
        ("+ feedback (k_p 0.1)", 15.0, full, 0.1, adaptive),
    ]
}

fn effects(args: &Args) -> Result<()> {
    println!(
        "cost per drive period, section-3 set, alpha 1.9, 300 periods, best of {}",
        args.repeat.max(1)
    );
    println!(
        "{:<38} {:>9} {:>12} {:>12} {:>10} {:>12}",
        "scene", "method", "us/period", "rhs/period", "events/p", "ns/rhs eval"
    );
    for (name, beta, friction, kp, method) in effect_rows() {
        let capsule = Capsule {
            beta,
            ..Capsule::SECTION3
        };
        let mut s = Scene {
            model: Model { capsule, friction },
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

/// The Fig 19 (a) basin (Coulomb, alpha 1.5, k_p 0, (x1 - x2, y1 - y2) over [-2, 2]^2) on an
/// `N x N` grid; then, on a sample of its initial states, the plain 300-period run, the early
/// stop without recognising known attractors, and the cost per event.
fn basins(args: &Args) -> Result<()> {
    use capsule_analysis::attractor::{settle, Catalogue, SettleConfig};
    use capsule_analysis::basin::{basins, BasinRun, Grid};
    use capsule_analysis::run;
    let mut scene = Scene::default();
    scene.drive.alpha = 1.5;
    let n = args.basin_grid.max(2);
    let grid = Grid::paper(n);
    grid.validate()
        .map_err(|(k, r)| anyhow::anyhow!("--basin-grid: {k}: {r}"))?;
    let job = BasinRun::new(&scene, grid);
    let (cfg, schedule) = (job.config, job.schedule);
    let cancel = std::sync::atomic::AtomicBool::new(false);
    let (t0, c0) = (Instant::now(), cpu_s(UsageWho::RUSAGE_SELF));
    let map = basins(&job, &|| {}, &cancel);
    let wall = t0.elapsed().as_secs_f64();
    let cpu = cpu_s(UsageWho::RUSAGE_SELF) - c0;
    let w = &map.work;
    let threads = rayon::current_num_threads();
    println!(
        "Fig 19a basin, {n} x {n} initial states, {threads} threads: {wall:.2} s wall, {cpu:.2} s CPU ({:.3} ms CPU per state); on a shared machine the CPU time / threads is the wall time it would take alone",
        1e3 * cpu / w.runs as f64,
    );
    println!(
        "  {:.1} periods per run (of {}); {} settled on their own, {} on a known attractor, {} at the horizon; {} attractors",
        w.periods as f64 / w.runs as f64,
        cfg.max_periods,
        w.settled,
        w.recognised,
        w.horizon,
        map.catalogue.attractors.len()
    );
    // one thread from here on, on every 97th state of the grid
    let sample: Vec<Scene> = (0..n * n).step_by(97).map(|c| job.scene_at(c)).collect();
    let per_state = |f: &dyn Fn(&Scene) -> Result<(u64, u64)>| -> Result<(f64, f64, f64)> {
        let c0 = cpu_s(UsageWho::RUSAGE_THREAD);
        let (mut periods, mut events) = (0u64, 0u64);
        for s in &sample {
            let (p, e) = f(s)?;
            periods += p;
            events += e;
        }
        let t = cpu_s(UsageWho::RUSAGE_THREAD) - c0;
        let m = sample.len() as f64;
        Ok((
            1e3 * t / m,
            periods as f64 / m,
            1e6 * t / events.max(1) as f64,
        ))
    };
    let plain = per_state(&|s| {
        let r = run(s)?;
        Ok((u64::from(s.horizon.periods), r.work.events))
    })?;
    let own = SettleConfig {
        known_tol: 0.0,
        ..cfg
    };
    let alone = per_state(&|s| {
        let o = settle(s, &schedule, &own, &Catalogue::default())?;
        Ok((u64::from(o.periods_run), o.work.events))
    })?;
    let known = per_state(&|s| {
        let o = settle(s, &schedule, &cfg, &map.catalogue)?;
        Ok((u64::from(o.periods_run), o.work.events))
    })?;
    println!(
        "one thread, {} states of the grid, CPU time:\n  {:<44} {:>9} {:>9} {:>12}",
        sample.len(),
        "",
        "ms/state",
        "periods",
        "us/event"
    );
    for (name, (ms, periods, us)) in [
        ("plain 300-period run (capsule simulate)", plain),
        ("early stop, own recurrence only", alone),
        ("early stop, known attractors recognised", known),
    ] {
        println!("  {name:<44} {ms:>9.3} {periods:>9.1} {us:>12.3}");
    }
    Ok(())
}

/// CPU time in seconds of the process (`RUSAGE_SELF`) or the calling thread (`RUSAGE_THREAD`):
/// on a machine shared with other work, wall time measures the others too.
fn cpu_s(who: UsageWho) -> f64 {
    match getrusage(who) {
        Ok(u) => {
            let t = |v: TimeVal| v.tv_sec() as f64 + v.tv_usec() as f64 * 1e-6;
            t(u.user_time()) + t(u.system_time())
        }
        Err(_) => f64::NAN,
    }
}
