//! The examples (each crate's `examples/`) run and do what their first lines say. `cargo test
//! --workspace` builds them into target/debug/examples; the minimal controller, which needs a
//! plant on DDS, runs in a network namespace with the ROS tests (`ros::example_controller`).

use crate::root;
use capsule_plant::{EventKind, Simulator, Stop};
use std::ops::ControlFlow;
use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

/// A built example; panics with the fix when it is missing.
pub fn example(name: &str) -> PathBuf {
    let dir = std::env::var_os("CAPSULE_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| root().join("target/debug"));
    let p = dir.join("examples").join(name);
    assert!(
        p.is_file(),
        "{} missing: run `cargo build --workspace --examples` (or `cargo test --workspace`) first",
        p.display()
    );
    p
}

/// Runs an example from the repository root to its end, stdin closed.
fn run_example(name: &str, args: &[&str]) -> Output {
    Command::new(example(name))
        .args(args)
        .current_dir(root())
        .stdin(Stdio::null())
        .output()
        .unwrap_or_else(|e| panic!("cannot run {name}: {e}"))
}

/// Its stdout, after asserting that it succeeded.
#[track_caller]
fn stdout_of(name: &str, o: &Output) -> String {
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{name}: {:?}\n{out}\n{err}", o.status);
    out.into_owned()
}

/// The time of the first event a whole run passes that `wanted` picks, found without stopping.
fn first_event_of_whole_run(scene_file: &str, wanted: impl Fn(EventKind) -> bool) -> f64 {
    let scene = crate::scene(scene_file);
    let mut sim = Simulator::new(scene.model(), scene.initial_state(), 0.0, scene.solver())
        .unwrap_or_else(|e| panic!("{e}"));
    let mut first = None;
    let end = 300.0 * scene.drive.period();
    let stop = sim
        .advance_until(&scene.law(), end, &mut |t| {
            if first.is_none() && wanted(t.event.kind) {
                first = Some(t.event.tau);
            }
            ControlFlow::Continue(())
        })
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(stop, Stop::Horizon);
    first.unwrap_or_else(|| panic!("no such event in {scene_file}"))
}

/// The number after `prefix` on the line of `out` that starts with it.
#[track_caller]
fn number_after(out: &str, prefix: &str) -> f64 {
    out.lines()
        .find_map(|l| l.strip_prefix(prefix))
        .and_then(|rest| rest.split([':', ' ']).next())
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no number after {prefix:?} in\n{out}"))
}

#[test]
fn stop_at_event_stops_at_the_first_event_of_the_kind_asked_for() {
    for (event, wanted) in [
        (
            "backward-slip",
            (|k| matches!(k, EventKind::BreakAway { dir } | EventKind::Reversal { dir } if dir < 0.0))
                as fn(EventKind) -> bool,
        ),
        ("impact", |k| k == EventKind::ContactOn),
    ] {
        let o = run_example("stop_at_event", &["scenes/control_point.toml", event]);
        let out = stdout_of("stop_at_event", &o);
        let tau = number_after(&out, "stopped at tau = ");
        // the same run, not stopped: the first such event is where the example stopped
        let expected = first_event_of_whole_run("control_point.toml", wanted);
        assert_eq!(tau, expected, "{event}:\n{out}");
    }
    // a bad event name is refused before anything runs
    let o = run_example("stop_at_event", &["scenes/control_point.toml", "landing"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("\"landing\": must be"));
}

#[test]
fn device_link_sends_every_frame_across_a_pty_and_skips_the_corrupted_one() {
    let o = run_example("device_link", &[]);
    let out = stdout_of("device_link", &o);
    for needle in [
        "driver: Hello(Hello { version: 1",
        "driver: measurement seq 4:",
        "device: Force(Force { force_n: 0.2, answers: 4 })",
        "driver: skipped: checksum",
        "driver: 1 frame(s) lost before seq 3",
        "ok: every frame crossed the line intact",
    ] {
        assert!(out.contains(needle), "{needle:?} missing:\n{out}");
    }
}
