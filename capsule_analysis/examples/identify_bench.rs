//! Times `capsule_analysis::identify` on its acceptance case: four keys (gamma, beta, delta,
//! xi) from 30 s of 1 kHz positions-only data of the typical device, FORWARD at the control
//! point, the device's capsule off the nominal one by 10-30 %. Prints the fit, the truth and
//! the wall time (docs/perf/identify.md has the figures).
//!
//! `cargo run --release -p capsule_analysis --example identify_bench [SECONDS [G B D X
//! [KEY=VALUE...]]]` (G B D X: the factors on gamma, beta, delta and xi; KEY=VALUE: the
//! device's `jitter_s`, `latency_s`, `noise_m`, `quantum_m`, `lag_s` or `seed`, or `window`,
//! the identification's window in drive periods, or `mixture=0`, the pick's mean weighted
//! instead of its mixture; for the experiments docs/perf/identify.md reports)

use capsule_analysis::identify::{identify, Settings};
use capsule_analysis::twin::emulated_run;
use capsule_plant::device::DeviceModel;

mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let seconds = common::first_arg_or(30.0)?;
    let mut nominal = common::control_point()?;
    let mut device = DeviceModel::typical(&nominal.physical);
    let mut settings = Settings::default();
    for a in std::env::args().skip(6) {
        let (k, v) = a.split_once('=').ok_or(format!("{a}: KEY=VALUE"))?;
        let v: f64 = v.parse()?;
        match k {
            "jitter_s" => device.jitter_s = v,
            "latency_s" => device.latency_s = v,
            "noise_m" => device.noise_m = v,
            "quantum_m" => device.quantum_m = v,
            "lag_s" => device.lag_s = v,
            "seed" => device.seed = v as u32,
            "window" => settings.window_periods = v,
            "mixture" => settings.mixture = v != 0.0,
            _ => return Err(format!("{k}: not a setting of this bench").into()),
        }
    }
    nominal.device = Some(device);
    let mut truth = nominal.clone();
    // the factors on gamma, beta, delta, xi: arguments 2 to 5, or the acceptance case's
    let mut factors = [1.2, 0.8, 1.3, 1.15];
    for (i, a) in std::env::args().skip(2).take(4).enumerate() {
        factors[i] = a.parse()?;
    }
    let keys = [
        "capsule.gamma",
        "capsule.beta",
        "capsule.delta",
        "capsule.xi",
    ];
    for (k, f) in keys.iter().zip(factors) {
        truth.set_number(k, nominal.number(k)? * f)?;
    }
    let t0 = std::time::Instant::now();
    let rec = emulated_run(&truth, 0.2, &device, 1000.0, seconds)?;
    let made = t0.elapsed().as_secs_f64();
    let keys: Vec<String> = keys.iter().map(|k| k.to_string()).collect();
    let t1 = std::time::Instant::now();
    let fit = identify(&nominal, &rec, &keys, &settings)?;
    let wall = t1.elapsed().as_secs_f64();
    println!(
        "{} samples ({seconds} s at 1 kHz) made in {made:.2} s; {} threads",
        rec.len(),
        rayon::current_num_threads()
    );
    for e in &fit.report.parameters {
        let t = truth.number(&e.key)?;
        let v = e.raw_value;
        let Some(sd) = e.std_error else {
            // withheld (not told apart): the raw value, no error in standard errors
            println!(
                "{:<14} true {:.6} withheld (raw {:.6}: error {:+.2} %): {}",
                e.key,
                t,
                v,
                100.0 * (v / t - 1.0),
                e.statement.as_deref().unwrap_or("")
            );
            continue;
        };
        println!(
            "{:<14} true {:.6} fitted {:.6} +- {:.6} (textbook {:.6}): error {:+.2} %, {:.2} s.e.",
            e.key,
            t,
            v,
            sd,
            e.textbook_std_error,
            100.0 * (v / t - 1.0),
            (v - t) / sd
        );
    }
    let d = &fit.report.delay;
    println!(
        "delay          {:.3} ms +- {} (device latency {} ms)",
        d.raw_value * 1e3,
        d.std_error
            .map_or("withheld".into(), |sd| format!("{:.3} ms", sd * 1e3)),
        device.latency_s * 1e3
    );
    println!(
        "residual RMS {:.2} um; {} windows; {} evaluations ({}); identify took {wall:.2} s",
        fit.report.residual_rms_m * 1e6,
        fit.report.windows,
        fit.report.evaluations,
        fit.report.termination
    );
    for s in &fit.report.statements {
        println!("statement: {s}");
    }
    Ok(())
}
