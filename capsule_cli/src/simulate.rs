//! `capsule simulate`: one run, a summary, optionally JSON and a CSV time history.

use crate::offline_record as record;
use crate::scene_args::SceneArgs;
use anyhow::{Context, Result};
use capsule_analysis::{run_sampled, RunReport};
use capsule_plant::scene::Scene;
use capsule_plant::Snapshot;
use serde::Serialize;
use std::io::Write;
use std::path::PathBuf;

/// Simulate one scene.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    scene: SceneArgs,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
    /// Write the time history to this CSV file.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Also write the sampled run as a ROS 2 MCAP recording: /capsule/state in SI units (the
    /// scene's physical scale) and /clock, with the scene attached, as the plant node would.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Time-history samples per drive period (with --csv or --record).
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..))]
    samples_per_period: u32,
}

#[derive(Serialize)]
struct Output<'a> {
    scene: &'a Scene,
    #[serde(flatten)]
    report: &'a RunReport,
    wall_time_s: f64,
}

pub fn main(args: Args) -> Result<()> {
    let scene = args.scene.scene()?;
    let mut rows: Vec<Snapshot> = Vec::new();
    let sampled = args.csv.is_some() || args.record.is_some();
    let samples = if sampled { args.samples_per_period } else { 0 };
    let t0 = std::time::Instant::now();
    let report = run_sampled(&scene, samples, &mut |s| rows.push(*s))
        .with_context(|| format!("simulating {}", scene.name))?;
    let wall = t0.elapsed().as_secs_f64();
    if let Some(path) = &args.csv {
        write_csv(path, &rows).with_context(|| format!("writing {}", path.display()))?;
    }
    if let Some(path) = &args.record {
        let n = record::write(path, &scene, args.scene.scene_text()?, &rows)?;
        if !args.json {
            println!("recording      {} ({n} messages)", path.display());
        }
    }
    if args.json {
        let out = Output {
            scene: &scene,
            report: &report,
            wall_time_s: wall,
        };
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_summary(&scene, &report, wall);
        if let Some(path) = &args.csv {
            println!("time history   {} ({} rows)", path.display(), rows.len());
        }
    }
    Ok(())
}

fn print_summary(scene: &Scene, r: &RunReport, wall: f64) {
    let m = &scene.model;
    let c = &m.capsule;
    println!("scene          {}", scene.name);
    println!(
        "model          {} friction, gamma {}, beta {}, delta {}, xi {}",
        m.friction.name(),
        c.gamma,
        c.beta,
        c.delta,
        c.xi
    );
    println!(
        "drive          alpha {}, omega {}, kp {}",
        scene.drive.alpha, scene.drive.omega, scene.control.kp
    );
    println!(
        "measured       {} periods after {} transient",
        r.measured_periods, scene.horizon.transient
    );
    println!("progression    {:+.6e} per period", r.avg_progression);
    match r.period {
        Some(k) => println!("motion         period-{k}"),
        None => println!("motion         no period <= 64 (chaotic or not settled)"),
    }
    println!("impacts        {:.3} per period", r.impacts_per_period);
    println!(
        "backward slips {:.3} per period",
        r.backward_slips_per_period
    );
    println!(
        "efficiency     {:+.6e} (progression / actuator work)",
        r.efficiency
    );
    let w = &r.work;
    println!(
        "solver         {} : {} steps, {} rejected, {} rhs evaluations, {} events, {:.3} ms",
        scene.solver.method.name(),
        w.steps,
        w.rejected,
        w.rhs_evals,
        w.events,
        wall * 1e3
    );
}

fn write_csv(path: &PathBuf, rows: &[Snapshot]) -> Result<()> {
    let file = std::fs::File::create(path)?;
    let mut w = std::io::BufWriter::new(file);
    writeln!(
        w,
        "tau,x1,y1,x2,y2,stuck,contact,friction_force,contact_force,actuator_force"
    )?;
    for s in rows {
        let st = &s.state;
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{}",
            s.tau,
            st.x1,
            st.y1,
            st.x2,
            st.y2,
            u8::from(s.stuck),
            u8::from(s.contact),
            s.friction_force,
            s.contact_force,
            s.actuator_force
        )?;
    }
    w.flush()?;
    Ok(())
}
