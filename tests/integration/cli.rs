//! The `capsule` command as a user runs it (needs `cargo build -p capsule_cli` first, as the
//! README's test command does; `CAPSULE_BIN` names another directory of binaries).

use crate::common::{
    assert_ok, assert_refused, capsule, capsule_in, files_in, json, line, TempDir,
};

#[test]
fn simulate_json_reports_what_the_issue_lists() {
    let v = json(&line(
        "simulate --scene scenes/control_point.toml --kp 0.1 --json",
        &[],
    ));
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
    let v = json(&line(
        "simulate --friction viscous --mu-v 0.2 --alpha 1.5 --periods 30 --json",
        &[],
    ));
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
        assert_refused(&capsule(args), 2, words, &format!("{args:?}"));
    }
}

#[test]
fn sweep_writes_csv_json_and_svg_and_csv_history_has_rows() {
    let dir = TempDir::new("cli_sweep");
    let prefix = dir.arg("kp");
    assert_ok(&capsule(&line(
        "sweep --scene scenes/control_point.toml --param kp --from -0.2 --to 0.2 --steps 5 --out",
        &[&prefix],
    )));
    let read = |ext: &str| std::fs::read_to_string(format!("{prefix}.{ext}")).unwrap_or_default();
    assert_eq!(
        read("csv").lines().count(),
        1 + 5 * 100,
        "header + 100 Poincaré points per value"
    );
    let js: serde_json::Value =
        serde_json::from_str(&read("json")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(js.as_array().map(Vec::len), Some(5));
    let svg = read("svg");
    assert!(svg.starts_with("<svg") && svg.contains("<path d=\"M"));
    let hist = dir.arg("h.csv");
    let out = capsule(&line(
        "simulate --periods 3 --samples-per-period 10 --csv",
        &[&hist],
    ));
    assert!(out.status.success());
    let rows = std::fs::read_to_string(&hist).unwrap_or_default();
    assert_eq!(rows.lines().count(), 1 + 1 + 3 * 10);
}

#[test]
fn simulate_record_writes_a_ros2_recording_of_the_run() {
    let dir = TempDir::new("cli_rec");
    let file = dir.file("run.mcap");
    let path = file.to_str().unwrap_or_default();
    let args = line(
        "simulate --scene scenes/fig15_forward.toml --periods 4 --transient 2",
        &[],
    );
    let out = capsule(&[&args[..], &["--samples-per-period", "25", "--record", path]].concat());
    assert_ok(&out);
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
}

#[test]
fn simulate_device_runs_the_law_through_the_scenes_device() {
    let dir = TempDir::new("cli_device");
    let exact = json(&line(
        "simulate --scene scenes/control_point.toml --kp 0.2 --periods 40 --transient 10 --json",
        &[],
    ));
    let csv = dir.arg("device.csv");
    let typical = json(&line(
        "simulate --scene scenes/control_point.toml --kp 0.2 --periods 40 --transient 10 --device --json --csv",
        &[&csv],
    ));
    let p = |v: &serde_json::Value, k: &str| v[k].as_f64().unwrap_or(f64::NAN);
    // the typical device (no [device] table) keeps most of the exact law's progression
    let ratio = p(&typical, "progression") / p(&exact, "avg_progression");
    assert!((0.9..1.02).contains(&ratio), "{ratio}");
    assert_eq!(typical["period"], 1);
    assert_eq!(typical["device"]["latency_s"], 0.002);
    assert!(p(&typical, "displacement_m") > 0.0);
    // one CSV row per sample, the velocities not measured
    let rows = std::fs::read_to_string(&csv).unwrap_or_default();
    assert_eq!(
        rows.lines().count() as u64,
        1 + typical["samples"].as_u64().unwrap_or(0)
    );
    let second: Vec<&str> = rows.lines().nth(2).unwrap_or("").split(',').collect();
    assert_eq!((second.len(), second[11]), (14, "NaN"), "{second:?}");
    // the scene's own [device] is the one used: a quarter period late costs progression
    let scene = dir.file("late.toml");
    let text = std::fs::read_to_string("scenes/control_point.toml").unwrap_or_default();
    std::fs::write(&scene, format!("{text}\n[device]\nlatency_s = 0.022\n"))
        .unwrap_or_else(|e| panic!("{e}"));
    let late = json(&line(
        "simulate --kp 0.2 --periods 40 --transient 10 --device --json --scene",
        &[scene.to_str().unwrap_or_default()],
    ));
    assert_eq!(late["device"]["latency_s"], 0.022);
    assert!(
        (p(&late, "progression") - p(&typical, "progression")).abs() > 0.05,
        "{} {}",
        p(&late, "progression"),
        p(&typical, "progression")
    );
    // a device run has no recording or gain schedule (yet): refused, not ignored
    let rec = dir.arg("x.mcap");
    let refused = capsule(&line(
        "simulate --scene scenes/control_point.toml --device --record",
        &[&rec],
    ));
    assert_refused(&refused, 2, "cannot be used with", "--device --record");
    assert!(!dir.file("x.mcap").exists());
}

#[test]
fn robustness_writes_files_only_where_asked() {
    // a docs/robustness/ of its own beside the run: where the command wrote by default before
    let dir = TempDir::new("cli_robustness");
    let docs = dir.join("docs/robustness");
    std::fs::create_dir_all(&docs).unwrap_or_else(|e| panic!("{}: {e}", docs.display()));
    let quick = line("robustness --periods 1 --transient 0", &[]);
    let o = capsule_in(&dir, &quick);
    assert_ok(&o);
    let report = String::from_utf8_lossy(&o.stdout);
    assert!(
        report.contains("# What the swap to a real capsule costs"),
        "{report}"
    );
    assert!(files_in(&docs).is_empty(), "{:?}", files_in(&docs));
    let prefix = dir.arg("r");
    assert_ok(&capsule(&[quick.as_slice(), &["--out", &prefix]].concat()));
    for ext in ["md", "svg", "png"] {
        let f = dir.file(&format!("r.{ext}"));
        assert!(f.is_file(), "{} missing", f.display());
    }
}
