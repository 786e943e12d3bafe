//! `capsule simulate --device`: one run of the law closed through the scene's `[device]` sensor
//! and actuator models (the typical device when the scene has none), sampled as the plant node
//! samples a real capsule: the emulator's run (`capsule emulate-device` with the same scene)
//! reproduced offline, with the truth beside what the sensor gave.

use std::io::Write as _;
use std::path::Path;

use anyhow::{Context as _, Result};
use capsule_analysis::robustness::{
    closed_loop_observed, controller_window, LoopCase, LoopSample, Mismatch,
};
use capsule_plant::device::DeviceModel;
use capsule_plant::scene::Scene;
use serde::Serialize;

use crate::work;

/// What `--device --json` prints.
#[derive(Serialize)]
struct Output<'a> {
    scene: &'a Scene,
    device: DeviceModel,
    rate_hz: f64,
    kp: f64,
    /// Mean progression per drive period (true state, non-dimensional).
    progression: f64,
    efficiency: f64,
    period: Option<usize>,
    seen_period: Option<usize>,
    velocity_error: f64,
    velocity_window: u32,
    /// The capsule's true displacement over the whole run \[m\].
    displacement_m: f64,
    duration_s: f64,
    samples: u64,
    wall_time_s: f64,
}

/// Runs `scene` through its device at `rate_hz` (the controller's orbit watch at
/// `orbit_tolerance`); prints a summary or JSON, writes `csv`.
pub fn run(
    scene: &Scene,
    rate_hz: f64,
    orbit_tolerance: f64,
    json: bool,
    csv: Option<&Path>,
    max_samples: u64,
) -> Result<()> {
    let device = scene.device_or_typical();
    let phys = scene.physical;
    let period_s = 2.0 * std::f64::consts::PI / scene.drive.omega * phys.time_s();
    let h = &scene.horizon;
    let steps = (f64::from(h.periods) * period_s * rate_hz).ceil() as u64;
    if csv.is_some() && steps > max_samples {
        anyhow::bail!(
            "--csv with --device stores one row per sample: {steps} samples ({} periods at {rate_hz} Hz) exceed --max-samples {max_samples}",
            h.periods
        );
    }
    if let Some(p) = csv {
        work::check_parent(p)?;
    }
    let case = LoopCase {
        kp: scene.control.kp,
        device,
        mismatch: Mismatch::NONE,
        rate_hz,
        transient: h.transient,
        periods: h.periods.saturating_sub(h.transient),
        velocity_window: controller_window(period_s, rate_hz),
        orbit_tolerance,
    };
    let t0 = std::time::Instant::now();
    let mut rows: Vec<LoopSample> = Vec::new();
    let (mut first, mut last) = (None, None);
    let result = closed_loop_observed(scene, &case, &mut |s| {
        first.get_or_insert(s.truth);
        last = Some(s.truth);
        if csv.is_some() {
            rows.push(*s);
        }
    })
    .map_err(|e| anyhow::anyhow!("simulating {} through its device: {e}", scene.name))?;
    let wall = t0.elapsed().as_secs_f64();
    let (displacement_m, duration_s) = match (first, last) {
        (Some(a), Some(b)) => (b.x2_m - a.x2_m, b.t_s - a.t_s),
        _ => (0.0, 0.0),
    };
    if let Some(p) = csv {
        write_csv(p, &rows).with_context(|| format!("writing {}", p.display()))?;
    }
    let out = Output {
        scene,
        device,
        rate_hz,
        kp: case.kp,
        progression: result.progression,
        efficiency: result.efficiency,
        period: result.period,
        seen_period: result.seen_period,
        velocity_error: result.velocity_error,
        velocity_window: case.velocity_window,
        displacement_m,
        duration_s,
        samples: steps,
        wall_time_s: wall,
    };
    if json {
        println!("{}", serde_json::to_string_pretty(&out)?);
        return Ok(());
    }
    print_summary(&out, &case);
    if let Some(p) = csv {
        println!("time history   {} ({} rows)", p.display(), rows.len());
    }
    Ok(())
}

/// The run as text, one line per aspect.
fn print_summary(out: &Output, case: &LoopCase) {
    let (scene, device, rate_hz) = (out.scene, &out.device, out.rate_hz);
    let period = |p: Option<usize>| p.map_or("none".to_string(), |p| format!("period-{p}"));
    println!("scene          {}", scene.name);
    println!(
        "device         {} (the scene's [device]{}), {rate_hz} Hz",
        device.measured.names().join(", "),
        if scene.device.is_some() {
            ""
        } else {
            " is absent: the typical device"
        }
    );
    println!(
        "                noise {} m, quantum {} m, latency {} s, jitter {} s, coil lag {} s, dead band {} N",
        device.noise_m, device.quantum_m, device.latency_s, device.jitter_s, device.lag_s, device.dead_band_n
    );
    println!(
        "drive          alpha {}, omega {}, kp {}",
        scene.drive.alpha, scene.drive.omega, case.kp
    );
    println!(
        "measured       {} periods after {} transient",
        case.periods, case.transient
    );
    println!(
        "progression    {:+.6e} per period, efficiency {:.6}",
        out.progression, out.efficiency
    );
    println!(
        "orbit          {} on the true state; the controller sees {}",
        period(out.period),
        period(out.seen_period)
    );
    println!(
        "velocity       estimated over {} samples, RMS error {:.4}",
        case.velocity_window, out.velocity_error
    );
    println!(
        "capsule        {:+.3} mm in {:.3} s",
        out.displacement_m * 1e3,
        out.duration_s
    );
    println!("wall time      {:.3} s", out.wall_time_s);
}

/// The samples as CSV, SI: the truth, the reading (NaN where not measured), the command.
fn write_csv(path: &Path, rows: &[LoopSample]) -> Result<()> {
    let mut w = std::io::BufWriter::new(std::fs::File::create(path)?);
    writeln!(
        w,
        "t_s,x1_m,v1_m_per_s,x2_m,v2_m_per_s,contact,applied_force_n,read_t_s,read_displacement_m,read_capsule_m,read_mass_v,read_capsule_v,read_force_n,command_n"
    )?;
    for s in rows {
        let (t, r) = (&s.truth, &s.reading);
        writeln!(
            w,
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{}",
            t.t_s,
            t.x1_m,
            t.v1_m_per_s,
            t.x2_m,
            t.v2_m_per_s,
            u8::from(t.contact),
            t.force_n,
            r.t_s,
            r.displacement_m,
            r.capsule_m,
            r.mass_v,
            r.capsule_v,
            r.force_n,
            s.command_n
        )?;
    }
    w.flush()?;
    Ok(())
}
