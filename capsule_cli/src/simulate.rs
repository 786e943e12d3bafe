//! `capsule simulate`: one run, a summary, optionally JSON and a CSV time history. A run that
//! lasts shows its progress on stderr; Ctrl-C stops it, writes the time history sampled so far
//! and exits non-zero saying so. `--device` runs through a device instead (`simulate_device`).

use crate::scene_args::SceneArgs;
use crate::simulate_recording;
use crate::work::{self, WorkArgs};
use anyhow::{bail, Context, Result};
use capsule_analysis::stability::{self, RunStability};
use capsule_analysis::{run_scheduled_until, GainSchedule, Pulse, RunReport};
use capsule_args::ranges;
use capsule_plant::scene::Scene;
use capsule_plant::Snapshot;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use serde::Serialize;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;

/// Simulate one scene.
#[derive(Debug, clap::Args)]
pub struct Args {
    #[command(flatten)]
    run: RunArgs,
    /// Print one JSON object instead of the summary.
    #[arg(long)]
    json: bool,
    /// Also analyse the stability of the attractor the run ends on: the Floquet multipliers of a
    /// periodic result and the Lyapunov spectrum over the measured periods (JSON fields
    /// floquet, lyapunov and stability_note). Without it neither runs.
    #[arg(long, conflicts_with = "device")]
    stability: bool,
    /// Close the law through the scene's [device] sensor and actuator models (the typical
    /// device when the scene has none), sampled at --rate-hz on measured positions, as the
    /// plant node runs a real capsule: an emulate-device run offline. --csv then holds the
    /// truth and the readings per sample.
    #[arg(long, conflicts_with_all = ["record", "pulse_kp"])]
    device: bool,
    /// With --device: the sample rate [Hz], 1 to 1e6.
    #[arg(long, default_value_t = 1000.0, requires = "device", value_parser = ranges::within(1.0, 1e6))]
    rate_hz: f64,
    /// With --device: the controller's orbit-watch tolerance (non-dim), 1e-6 to 0.2.
    #[arg(long, default_value_t = capsule_controller::switch::SwitchConfig::DEFAULT.tol, requires = "device", value_parser = ranges::within(1e-6, 0.2))]
    orbit_tolerance: f64,
    /// Write the time history to this CSV file.
    #[arg(long, value_name = "FILE")]
    csv: Option<PathBuf>,
    /// Also write the sampled run as a ROS 2 MCAP recording: /capsule/state in SI units (the
    /// scene's physical scale) and /clock, with the scene attached, as the plant node would.
    #[arg(long, value_name = "FILE")]
    record: Option<PathBuf>,
    /// Time-history samples per drive period (with --csv or --record), 1 to 1000000.
    #[arg(long, default_value_t = 100, value_parser = ranges::count_u32(1, 1_000_000))]
    samples_per_period: u32,
    /// Most time-history samples one run may store (with --csv or --record), 1 to 1e9.
    #[arg(long, default_value_t = work::DEFAULT_MAX_SAMPLES, value_parser = ranges::count(1, 1_000_000_000))]
    max_samples: u64,
    #[command(flatten)]
    work: WorkArgs,
    /// Print the resolved scene as a complete scene file (every default filled in) and exit.
    #[arg(long)]
    print_scene: bool,
    /// With --record: compression and splitting
    #[command(flatten)]
    storage: capsule_args::storage::StorageArgs,
}

/// One scheduled run's flags (`simulate`, `switch`): the scene and the gain schedule on it.
#[derive(Debug, Clone, clap::Args)]
pub struct RunArgs {
    #[command(flatten)]
    pub scene: SceneArgs,
    #[command(flatten)]
    pub schedule: ScheduleArgs,
}

impl RunArgs {
    /// The scene, and the schedule checked against its horizon.
    pub fn resolve(&self) -> Result<(Scene, GainSchedule)> {
        let scene = self.scene.scene()?;
        let schedule = self.schedule.schedule(&scene)?;
        Ok((scene, schedule))
    }
}

/// A gain schedule on top of the scene's `--kp`: a pulse of another gain for some drive
/// periods, then a gain after it.
#[derive(Debug, Clone, clap::Args)]
pub struct ScheduleArgs {
    /// Gain during a pulse starting at --pulse-at (the gain before it is --kp).
    #[arg(long, requires = "pulse_at")]
    pub pulse_kp: Option<f64>,
    /// Length of the pulse in drive periods.
    #[arg(long, default_value_t = 1, requires = "pulse_kp")]
    pub pulse_periods: u32,
    /// First drive period of the pulse (0-based, transient included).
    #[arg(long, requires = "pulse_kp")]
    pub pulse_at: Option<u32>,
    /// Gain after the pulse [default: --kp, the gain before].
    #[arg(long, requires = "pulse_kp")]
    pub kp_after: Option<f64>,
}

impl ScheduleArgs {
    /// The schedule for `scene`, checked against its horizon.
    pub fn schedule(&self, scene: &Scene) -> Result<GainSchedule> {
        let before = scene.control.kp;
        let schedule = match (self.pulse_kp, self.pulse_at) {
            (Some(kp), Some(at)) => GainSchedule {
                before,
                pulse: Some(Pulse {
                    kp,
                    at,
                    periods: self.pulse_periods,
                }),
                after: self.kp_after.unwrap_or(before),
            },
            (None, None) => GainSchedule::constant(before),
            _ => bail!("--pulse-kp and --pulse-at go together"),
        };
        schedule
            .validate(scene.horizon.periods)
            .map_err(|(k, r)| anyhow::anyhow!("--{k}: {r}"))?;
        Ok(schedule)
    }
}

#[derive(Serialize)]
struct Output<'a> {
    scene: &'a Scene,
    schedule: &'a GainSchedule,
    #[serde(flatten)]
    report: &'a RunReport,
    /// Only when asked (`--stability`): absent, it adds no field.
    #[serde(flatten)]
    stability: Option<&'a RunStability>,
    wall_time_s: f64,
}

pub fn main(args: Args) -> Result<()> {
    let (scene, schedule) = args.run.resolve()?;
    if args.print_scene {
        print!("{}", scene.to_toml());
        return Ok(());
    }
    args.work.check(&scene, 1)?;
    if args.device {
        return crate::simulate_device::run(
            &scene,
            args.rate_hz,
            args.orbit_tolerance,
            args.json,
            args.csv.as_deref(),
            args.max_samples,
        );
    }
    let storage = args.storage.options();
    let mut rows: Vec<Snapshot> = Vec::new();
    let sampled = args.csv.is_some() || args.record.is_some();
    let samples = if sampled { args.samples_per_period } else { 0 };
    if sampled {
        work::check_samples(&scene, samples, args.max_samples)?;
    }
    for path in args.csv.iter().chain(&args.record) {
        work::check_parent(path)?;
    }
    let t0 = std::time::Instant::now();
    let mut progress = Progress::new(scene.horizon.periods);
    work::catch_ctrl_c();
    let report = run_scheduled_until(
        &scene,
        &schedule,
        samples,
        &mut |s| rows.push(*s),
        &mut |n| progress.go_on(n),
    );
    // from here on Ctrl-C ends the process as usual (the stability analysis, if asked)
    work::release_ctrl_c();
    progress.finish();
    let report = report.with_context(|| format!("simulating {}", scene.name))?;
    let wall = t0.elapsed().as_secs_f64();
    let mut written = Vec::new();
    if let Some(path) = &args.csv {
        write_csv(path, &rows).with_context(|| format!("writing {}", path.display()))?;
        written.push(format!("{} ({} rows)", path.display(), rows.len()));
    }
    if let Some(path) = &args.record {
        let n = simulate_recording::write(
            path,
            &scene,
            args.run.scene.scene_text(&scene),
            &rows,
            storage,
        )?;
        if report.is_some() && !args.json {
            println!("recording      {} ({n} messages)", path.display());
        }
        written.push(format!("{} ({n} messages)", path.display()));
    }
    let Some(report) = report else {
        let done = progress.done;
        let what = if written.is_empty() {
            "nothing written (no --csv or --record)".to_string()
        } else {
            format!("the time history so far is in {}", written.join(" and "))
        };
        bail!(
            "interrupted: {done} of {} periods done after {wall:.1} s, no summary; {what}",
            scene.horizon.periods
        );
    };
    let stability = args
        .stability
        .then(|| stability::of_run(&scene, &schedule, &report));
    tracing::debug!(
        linearizations = capsule_analysis::floquet::linearizations(),
        "stability analysis"
    );
    if args.json {
        let out = Output {
            scene: &scene,
            schedule: &schedule,
            report: &report,
            stability: stability.as_ref(),
            wall_time_s: wall,
        };
        println!("{}", serde_json::to_string_pretty(&out)?);
    } else {
        print_summary(&scene, &report, wall);
        print_stability(stability.as_ref(), &schedule);
        if let Some(path) = &args.csv {
            println!("time history   {} ({} rows)", path.display(), rows.len());
        }
    }
    Ok(())
}

/// The stability analysis (when asked) and the gain schedule, as the text summary prints them.
fn print_stability(stability: Option<&RunStability>, schedule: &GainSchedule) {
    let (floquet, lyapunov, stability_note) = match stability {
        Some(s) => (&s.floquet, &s.lyapunov, &s.stability_note),
        None => (&None, &None, &None),
    };
    if let Some(f) = floquet {
        let mus: Vec<String> = f
            .multipliers
            .iter()
            .map(|m| {
                if m[1] == 0.0 {
                    format!("{:.6}", m[0])
                } else {
                    format!("{:.6}{:+.6}i", m[0], m[1])
                }
            })
            .collect();
        println!(
            "floquet        {} (largest modulus {:.6}: {})",
            mus.join(", "),
            f.largest_modulus,
            if f.largest_modulus < 1.0 {
                "stable"
            } else {
                "unstable"
            }
        );
    }
    if let Some(l) = lyapunov {
        let ls: Vec<String> = l.exponents.iter().map(|x| format!("{x:.6}")).collect();
        println!(
            "lyapunov       {} per unit tau (largest over half the run {:.6})",
            ls.join(", "),
            l.largest_half_run
        );
    }
    if let Some(n) = stability_note {
        println!("stability      {n}");
    }
    if let Some(p) = schedule.pulse {
        println!(
            "gain schedule  kp {} until period {}, {} for {} period(s), then {}",
            schedule.before, p.at, p.kp, p.periods, schedule.after
        );
    }
}

/// Progress of one run: a bar on a terminal once the run has lasted a second, a line every
/// ten seconds when stderr is not a terminal (a log), nothing for a short run; and the stop
/// asked by Ctrl-C.
struct Progress {
    periods: u32,
    done: u32,
    start: std::time::Instant,
    bar: Option<ProgressBar>,
    terminal: bool,
    next_line_s: f64,
}

impl Progress {
    /// Seconds a run lasts before its progress shows.
    const QUIET_S: f64 = 1.0;
    /// Seconds between two progress lines when stderr is not a terminal.
    const LINE_EVERY_S: f64 = 10.0;

    fn new(periods: u32) -> Self {
        Progress {
            periods,
            done: 0,
            start: std::time::Instant::now(),
            bar: None,
            terminal: std::io::stderr().is_terminal(),
            next_line_s: Self::LINE_EVERY_S,
        }
    }

    /// Called before period `n`: shows the progress, and says whether to go on (no Ctrl-C).
    fn go_on(&mut self, n: u32) -> bool {
        self.done = n;
        let elapsed = self.start.elapsed().as_secs_f64();
        if let Some(bar) = &self.bar {
            bar.set_position(n.into());
        } else if self.terminal && elapsed >= Self::QUIET_S {
            let bar = ProgressBar::with_draw_target(
                Some(self.periods.into()),
                ProgressDrawTarget::stderr(),
            );
            bar.set_style(
                ProgressStyle::with_template(
                    "{bar:40} {pos}/{len} periods, {elapsed} elapsed, eta {eta} (Ctrl-C stops and writes what is done)",
                )
                .unwrap_or_else(|_| ProgressStyle::default_bar()),
            );
            bar.set_position(n.into());
            self.bar = Some(bar);
        } else if !self.terminal && elapsed >= self.next_line_s {
            eprintln!(
                "simulate: period {n} of {} ({:.1} %), {elapsed:.0} s elapsed",
                self.periods,
                100.0 * f64::from(n) / f64::from(self.periods)
            );
            self.next_line_s += Self::LINE_EVERY_S;
        }
        !work::interrupted()
    }

    fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

fn print_summary(scene: &Scene, r: &RunReport, wall: f64) {
    let m = &scene.model;
    println!("scene          {}", scene.name);
    println!(
        "model          {} friction, {}",
        m.friction.name(),
        m.capsule
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
