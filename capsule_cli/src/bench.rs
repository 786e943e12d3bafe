//! `capsule bench`: time the integrators on the paper's scenes and print the figures.

use anyhow::Result;
use capsule_analysis::{run, sweep, Param};
use capsule_plant::scene::Scene;
use capsule_plant::{Capsule, Friction, Method, Model, SolverConfig};
use std::time::Instant;

/// Benchmark settings.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Repetitions of the single-run timing (the best is reported).
    #[arg(long, default_value_t = 20)]
    repeat: u32,
    /// Values in the Fig. 2a alpha sweep.
    #[arg(long, default_value_t = 1901)]
    sweep_values: usize,
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

pub fn main(args: Args) -> Result<()> {
    println!(
        "capsule bench (release build recommended: cargo run --release -p capsule_cli -- bench)"
    );
    println!();
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
        let mut best = f64::INFINITY;
        let mut report = None;
        for _ in 0..args.repeat.max(1) {
            let t0 = Instant::now();
            let r = run(&scene)?;
            best = best.min(t0.elapsed().as_secs_f64());
            report = Some(r);
        }
        if let Some(r) = report {
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
