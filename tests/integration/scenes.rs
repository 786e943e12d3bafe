//! Scene files: every bundled scene loads; bad scenes are refused with file, key and reason.

use crate::common::files_in;
use crate::root;
use capsule_plant::scene::Scene;

#[test]
fn every_bundled_scene_loads_and_runs_its_first_period() {
    let mut n = 0;
    for path in files_in(&root().join("scenes")) {
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).unwrap_or_default();
            let mut s = Scene::from_toml_str(&text, &path.display().to_string())
                .unwrap_or_else(|e| panic!("{e}"));
            s.horizon.periods = 2;
            s.horizon.transient = 1;
            capsule_analysis::run(&s).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            n += 1;
        }
    }
    assert!(n >= 8, "expected the paper's scenes, found {n}");
}

#[test]
fn bad_scenes_are_refused_with_key_and_reason() {
    // the control point's scene, each case one edit away from it
    let good = std::fs::read_to_string(root().join("scenes/control_point.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    assert!(Scene::from_toml_str(&good, "good.toml").is_ok());
    let table: &[(&str, &str, &str)] = &[
        // (edit, expected key, expected words in the reason)
        (
            "gamma = 0.235|gamma = -0.235",
            "capsule.gamma",
            "must be > 0",
        ),
        ("gamma = 0.235|gamma = 0.0", "capsule.gamma", "must be > 0"),
        ("gamma = 0.235|gamma = nan", "capsule.gamma", "finite"),
        ("omega = 1.1|omega = 0.0", "drive.omega", "must be > 0"),
        ("alpha = 1.6|alpha = inf", "drive.alpha", "finite"),
        (
            "delta = 0.02|delta = -0.01",
            "capsule.delta",
            "must be >= 0",
        ),
        ("beta = 3.05|beta = -1.0", "capsule.beta", "must be >= 0"),
        ("xi = 0.05|xi = -0.05", "capsule.xi", "must be >= 0"),
        (
            "xi = 0.05|xi = 0.05\ngama = 1.0",
            "capsule.gama",
            "unknown field `gama`",
        ),
        (
            "law = \"coulomb\"|law = \"coulomb\"\nmu_v = 0.1",
            "friction.mu_v",
            "not used by law `coulomb`",
        ),
        (
            "law = \"coulomb\"|law = \"teflon\"",
            "friction.law",
            "unknown law `teflon`",
        ),
        (
            "law = \"coulomb\"|law = \"stribeck\"\nv_s = 0.1\n[solver]\nmethod = \"exact\"",
            "solver.method",
            "piecewise-linear",
        ),
        (
            "periods = 300\ntransient = 200|periods = 10\ntransient = 10",
            "horizon.transient",
            "less than",
        ),
        (
            "omega = 1.1|omega = 1.1\n[solver]\nmethod = \"adaptive\"\ntol = 2.0",
            "solver.tol",
            "(0, 1)",
        ),
        (
            "omega = 1.1|omega = 1.1\n[initial]\nstate = [0.0, nan, 0.0, 0.0]",
            "initial.state[1] (y1)",
            "finite",
        ),
        (
            "omega = 1.1|omega = \"fast\"",
            "drive.omega",
            "invalid type",
        ),
    ];
    for (edit, key, words) in table {
        let (from, to) = edit.split_once('|').unwrap_or((edit, ""));
        // the edit applies to whole lines (the description also says `gamma = 0.235`)
        let from = format!("\n{from}");
        assert!(good.contains(&from), "test table: {from}");
        let text = good.replacen(&from, &format!("\n{to}"), 1);
        match Scene::from_toml_str(&text, "bad.toml") {
            Ok(_) => panic!("accepted a bad scene ({edit})"),
            Err(e) => {
                assert_eq!(e.file, "bad.toml");
                assert_eq!(e.key, *key, "{edit}: {e}");
                let reason = e.reason.to_string();
                assert!(
                    reason.contains(words),
                    "{edit}: reason `{reason}` lacks `{words}`"
                );
            }
        }
    }
}
