//! How closely the Move action's law lands at the section-5 control point
//! (scenes/control_point.toml): goals of ±0.5 to ±50 mm, each arriving at four drive phases,
//! closed around the exact capsule at 1 kHz under a zero-order hold (as the controller drives
//! the simulated plant in lock-step). Prints one line per goal and the summary that
//! docs/perf/ros.md records (the figure behind the default tolerance, docs/ros.md).
//!
//! `cargo run --release -p capsule_analysis --example move_landing [TOLERANCE_M]`

use capsule_analysis::move_landing::{land, LandingCase};
use capsule_controller::move_goal::{MoveConfig, MoveEnd, MoveRequest};

mod common;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let tolerance_m = common::first_arg_or(0.0)?;
    let scene = common::control_point()?;
    let config = MoveConfig::DEFAULT;
    let period_s = std::f64::consts::TAU / scene.drive.omega * scene.physical.time_s();
    let mut worst: f64 = 0.0;
    let mut worst_settled: f64 = 0.0;
    let mut worst_time: f64 = 0.0;
    let mut errors = Vec::new();
    let mut failed = 0;
    println!("distance_mm phase end error_mm settled_error_mm elapsed_s");
    for mm in [0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 50.0] {
        for sign in [1.0, -1.0] {
            for quarter in 0..4 {
                let distance_m = sign * mm * 1e-3;
                let case = LandingCase {
                    request: MoveRequest {
                        distance_m,
                        tolerance_m,
                        timeout_s: 0.0,
                    },
                    start_s: 0.5 + period_s * f64::from(quarter) / 4.0,
                    rate_hz: 1000.0,
                    horizon_s: 30.0,
                    after_periods: 20,
                };
                let r = land(&scene, &case, config)?;
                let Some(out) = r.outcome else {
                    println!("{:+} {quarter}/4 no end within 30 s", sign * mm);
                    failed += 1;
                    continue;
                };
                if out.end != MoveEnd::Reached {
                    failed += 1;
                }
                let settled = r.settled_travel_m - distance_m;
                println!(
                    "{:+} {quarter}/4 {:?} {:+.4} {:+.4} {:.3}",
                    sign * mm,
                    out.end,
                    out.error_m * 1e3,
                    settled * 1e3,
                    out.elapsed_s
                );
                worst = worst.max(out.error_m.abs());
                worst_settled = worst_settled.max(settled.abs());
                worst_time = worst_time.max(out.elapsed_s - distance_m.abs() / 0.0166);
                errors.push(out.error_m.abs());
            }
        }
    }
    errors.sort_by(f64::total_cmp);
    let median = errors.get(errors.len() / 2).copied().unwrap_or(f64::NAN);
    println!(
        "goals {} not reached {failed}; |error| median {:.4} mm, max {:.4} mm; 10 periods after the end max {:.4} mm; worst time beyond cruising at 16.6 mm/s {:.2} s",
        errors.len() + failed,
        median * 1e3,
        worst * 1e3,
        worst_settled * 1e3,
        worst_time
    );
    Ok(())
}
