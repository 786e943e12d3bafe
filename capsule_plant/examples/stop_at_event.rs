//! Drive the simulator from your own code and stop it at an event: an observer handed to
//! `Simulator::advance_until` sees every located event (impacts, break-aways, slip ends, ...)
//! with the state on both sides, and breaks the run at the one it waits for; the simulator is
//! then just after that event and can go on from there.
//!
//!   cargo run -p capsule_plant --example stop_at_event -- [SCENE] [impact|backward-slip|stick]
//!
//! Defaults: scenes/control_point.toml, backward-slip (the capsule's first slip backwards).

use std::ops::ControlFlow;
use std::process::ExitCode;

use capsule_plant::scene::Scene;
use capsule_plant::{EventKind, Simulator, Stop};

/// Whether `kind` is the event asked for by name.
fn is_wanted(wanted: &str, kind: EventKind) -> bool {
    match (wanted, kind) {
        ("impact", EventKind::ContactOn) => true,
        ("backward-slip", EventKind::BreakAway { dir } | EventKind::Reversal { dir }) => dir < 0.0,
        ("stick", EventKind::SlipEnd) => true,
        _ => false,
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let default = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/control_point.toml");
    let path = args.first().map_or(default, String::as_str);
    let wanted = args.get(1).map_or("backward-slip", String::as_str);
    if !["impact", "backward-slip", "stick"].contains(&wanted) {
        eprintln!("stop_at_event: event {wanted:?}: must be impact, backward-slip or stick");
        return ExitCode::from(2);
    }
    let scene = match std::fs::read_to_string(path)
        .map_err(|e| format!("{path}: {e}"))
        .and_then(|text| Scene::from_toml_str(&text, path).map_err(|e| e.to_string()))
    {
        Ok(s) => s,
        Err(e) => {
            eprintln!("stop_at_event: {e}");
            return ExitCode::from(2);
        }
    };
    let law = scene.law();
    let horizon = 300.0 * scene.drive.period();
    let mut sim = match Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver()) {
        Ok(sim) => sim,
        Err(e) => {
            eprintln!("stop_at_event: {path}: {e}");
            return ExitCode::from(2);
        }
    };

    // the observer: count what passes, break at the first event of the kind asked for
    let mut seen = 0u32;
    let stop = sim.advance_until(&law, horizon, &mut |t| {
        seen += 1;
        if is_wanted(wanted, t.event.kind) {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    match stop {
        Ok(Stop::Requested(event)) => {
            let s = sim.state();
            println!("scene {path}, {} friction", scene.model().friction.name());
            println!("events seen: {seen}");
            println!("stopped at tau = {:?}: {:?}", event.tau, event.kind);
            println!("drive periods: {:.3}", event.tau / scene.drive.period());
            println!(
                "state after it: x1 {:?} y1 {:?} x2 {:?} y2 {:?}",
                s.x1, s.y1, s.x2, s.y2
            );
            ExitCode::SUCCESS
        }
        Ok(Stop::Horizon) => {
            eprintln!("stop_at_event: no {wanted} in 300 drive periods ({seen} events)");
            ExitCode::from(1)
        }
        Err(e) => {
            eprintln!("stop_at_event: the run failed: {e}");
            ExitCode::from(1)
        }
    }
}
