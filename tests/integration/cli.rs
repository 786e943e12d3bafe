//! The `capsule` command as a user runs it (needs `cargo build -p capsule_cli` first, as the
//! README's test command does; `CAPSULE_BIN` overrides the path).

use crate::root;
use std::path::PathBuf;
use std::process::{Command, Output};

fn bin() -> PathBuf {
    if let Ok(p) = std::env::var("CAPSULE_BIN") {
        return PathBuf::from(p);
    }
    let p = root().join("target").join("debug").join("capsule");
    assert!(
        p.exists(),
        "{} missing: run `cargo build -p capsule_cli` first",
        p.display()
    );
    p
}

pub(crate) fn capsule(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .current_dir(root())
        .output()
        .unwrap_or_else(|e| panic!("cannot run capsule: {e}"))
}

pub(crate) fn json(args: &[&str]) -> serde_json::Value {
    let out = capsule(args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap_or_else(|e| panic!("not JSON: {e}"))
}

#[test]
fn simulate_json_reports_what_the_issue_lists() {
    let v = json(&[
        "simulate",
        "--scene",
        "scenes/control_point.toml",
        "--kp",
        "0.1",
        "--json",
    ]);
    for key in [
        "avg_progression",
        "period",
        "impacts_per_period",
        "backward_slips_per_period",
        "efficiency",
        "poincare",
        "final_state",
        "work",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["period"], 1);
    assert!(v["avg_progression"].as_f64().unwrap_or(0.0) > 0.5);
    assert_eq!(v["poincare"].as_array().map(Vec::len), Some(100));
    assert!(v["work"]["events"].as_u64().unwrap_or(0) > 0);
}

#[test]
fn flags_named_after_the_paper_override_the_defaults() {
    let v = json(&[
        "simulate",
        "--friction",
        "viscous",
        "--mu-v",
        "0.2",
        "--alpha",
        "1.5",
        "--periods",
        "30",
        "--json",
    ]);
    assert_eq!(v["scene"]["model"]["friction"]["law"], "viscous");
    assert_eq!(v["scene"]["model"]["friction"]["mu_v"], 0.2);
    assert_eq!(v["scene"]["drive"]["omega"], 0.95);
    assert_eq!(v["scene"]["solver"]["method"], "exact");
    assert_eq!(v["measured_periods"], 10);
}

#[test]
fn bad_flags_and_files_fail_with_a_clear_message() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["simulate", "--gamma", "-1"],
            "--gamma <GAMMA>': must be > 0",
        ),
        (
            &["simulate", "--mu-v", "0.2"],
            "--mu-v does not apply to the coulomb friction law",
        ),
        (
            &["simulate", "--scene", "no/such.toml"],
            "no/such.toml: (file): cannot read",
        ),
        (
            &["simulate", "--x0", "1,2,3"],
            "expected four comma-separated numbers",
        ),
        (
            &["simulate", "--friction", "stribeck", "--method", "exact"],
            "piecewise-linear",
        ),
        (
            &["sweep", "--param", "zeta", "--from", "0", "--to", "1"],
            "possible values: alpha, omega, gamma, beta, delta, xi, kp",
        ),
    ];
    for (args, words) in cases {
        let out = capsule(args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(words),
            "{args:?}: stderr `{err}` lacks `{words}`"
        );
        assert!(!err.contains("panicked"), "{args:?} panicked: {err}");
    }
}

#[test]
fn sweep_writes_csv_json_and_svg_and_csv_history_has_rows() {
    let dir = std::env::temp_dir().join(format!("capsule-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let prefix = dir.join("kp");
    let out = capsule(&[
        "sweep",
        "--scene",
        "scenes/control_point.toml",
        "--param",
        "kp",
        "--from",
        "-0.2",
        "--to",
        "0.2",
        "--steps",
        "5",
        "--out",
        prefix.to_str().unwrap_or_default(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(prefix.with_extension("csv")).unwrap_or_default();
    assert_eq!(
        csv.lines().count(),
        1 + 5 * 100,
        "header + 100 Poincaré points per value"
    );
    let js: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(prefix.with_extension("json")).unwrap_or_default(),
    )
    .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(js.as_array().map(Vec::len), Some(5));
    let svg = std::fs::read_to_string(prefix.with_extension("svg")).unwrap_or_default();
    assert!(svg.starts_with("<svg") && svg.contains("<path d=\"M"));
    let hist = dir.join("h.csv");
    let out = capsule(&[
        "simulate",
        "--periods",
        "3",
        "--csv",
        hist.to_str().unwrap_or_default(),
        "--samples-per-period",
        "10",
    ]);
    assert!(out.status.success());
    let rows = std::fs::read_to_string(&hist).unwrap_or_default();
    assert_eq!(rows.lines().count(), 1 + 1 + 3 * 10);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn simulate_record_writes_a_ros2_recording_of_the_run() {
    let dir = std::env::temp_dir().join(format!("capsule-cli-rec-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let file = dir.join("run.mcap");
    let path = file.to_str().unwrap_or_default();
    let args = [
        "simulate",
        "--scene",
        "scenes/fig15_forward.toml",
        "--periods",
        "4",
        "--transient",
        "2",
    ];
    let out = capsule(&[&args[..], &["--samples-per-period", "25", "--record", path]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let info = capsule_record::info(&file).unwrap_or_else(|e| panic!("{e}"));
    let count = |topic: &str| {
        info.topics
            .iter()
            .find(|t| t.topic == topic)
            .map(|t| t.count)
    };
    assert_eq!(count("/capsule/state"), Some(1 + 4 * 25));
    assert_eq!(count("/clock"), Some(1 + 4 * 25));
    assert_eq!(
        info.scene_name.as_deref(),
        Some("Section 5.2 forward motion, k_p = 0.1 (Fig 15)")
    );
    // an existing recording is never overwritten
    let again = capsule(&[&args[..], &["--record", path]].concat());
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("File exists"));
    let _ = std::fs::remove_dir_all(&dir);
}
