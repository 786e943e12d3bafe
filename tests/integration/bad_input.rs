//! Bad input, as a careless or hostile user gives it (issue 15): every binary that takes a scene
//! refuses each malformed scene of `tests/fixtures/scenes_bad/` the same way (exit status 2, the
//! file, the key and the reason, before anything starts); every numeric flag refuses what is out
//! of its documented range at parse time; runs over their work limits are refused before they
//! start, runs that leave the adaptive method's envelope stop with a clear error; sweeps with
//! failed values exit non-zero. Needs the binaries (`cargo build --workspace`); no DDS starts
//! (the nodes run with `--check`, which stops after the same checks a real start makes).

use crate::common::{
    assert_holds, assert_ok, assert_refused, command, files_in, json_of, line, run, stderr, TempDir,
};
use crate::root;
use capsule_args::controller_settings::CONTROLLER;
use capsule_args::plant_settings::PLANT;
use capsule_args::settings::{Kind, Setting};
use capsule_plant::scene::Rule;
use proptest::prelude::*;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The command lines that take a scene, `{}` standing for the scene path.
fn scene_takers(out: &str) -> Vec<(&'static str, Vec<String>)> {
    let v = |words: &str, tail: &[&str]| {
        line(words, tail)
            .into_iter()
            .map(String::from)
            .collect::<Vec<_>>()
    };
    vec![
        ("capsule", v("simulate --scene {}", &[])),
        (
            "capsule",
            v(
                "sweep --scene {} --param alpha --from 1 --to 1 --steps 1 --out",
                &[out],
            ),
        ),
        ("capsule_plant", v("--scene {} --check", &[])),
        ("capsule_controller", v("--scene {} --check", &[])),
        (
            "capsule_recorder",
            v("--scene {} --check --record-dir", &[out]),
        ),
        ("capsule_ros", v("period --scene {}", &[])),
        (
            "capsule",
            v("emulate-device --scene {} --until-s 0.01", &[]),
        ),
        (
            "capsule",
            v(
                "robustness --scene {} --periods 1 --transient 0 --out",
                &[out],
            ),
        ),
        (
            "capsule_plant",
            v("--scene {} --source serial:/dev/null/none --check", &[]),
        ),
    ]
}

#[test]
fn device_flags_are_refused_with_the_reason_before_any_line_opens() {
    let tmp = TempDir::new("bad_device_flags");
    let scene = "scenes/control_point.toml";
    let o = run(
        "capsule_plant",
        &[
            "--scene",
            scene,
            "--source",
            "serial:/dev/ttyUSB0,12345",
            "--check",
        ],
    );
    assert_refused(&o, 2, "`12345`: not a baud rate", "bad baud");
    let o = run(
        "capsule_plant",
        &["--scene", scene, "--source", "usb", "--check"],
    );
    assert_refused(&o, 2, "expected sim or serial:PATH[,BAUD]", "bad source");
    let o = run("capsule_plant", &["--scene", scene, "--dry-run", "--check"]);
    assert_refused(
        &o,
        2,
        "--dry-run and --max-travel-m are for --source serial",
        "dry sim",
    );
    // the pause holds a simulated plant's loop only: a device keeps its own time
    for extra in [
        &["--source", "serial:/dev/null/none", "--pacing", "lockstep"][..],
        &["--pacing", "realtime"][..],
    ] {
        let mut args = vec!["--scene", scene, "--start-paused", "--check"];
        args.extend_from_slice(extra);
        let o = run("capsule_plant", &args);
        assert_refused(
            &o,
            2,
            "--start-paused holds a simulated plant in lock-step",
            "start paused",
        );
    }
    // the emulator never replaces a file that is not its own link
    let file = tmp.arg("not_a_link");
    std::fs::write(&file, "keep").unwrap_or_else(|e| panic!("{e}"));
    let o = run(
        "capsule",
        &[
            "emulate-device",
            "--scene",
            scene,
            "--link",
            &file,
            "--until-s",
            "0.01",
        ],
    );
    assert_refused(
        &o,
        2,
        "exists and is not a symbolic link; not replaced",
        "link",
    );
    assert_eq!(std::fs::read_to_string(&file).ok().as_deref(), Some("keep"));
    let o = run(
        "capsule_plant",
        &[
            "--scene",
            scene,
            "--source",
            "serial:/tmp/x,115200",
            "--dry-run",
            "--check",
        ],
    );
    assert_ok(&o);
    assert!(
        stderr(&o).contains("serial /tmp/x at 115200 baud (dry run)")
            || String::from_utf8_lossy(&o.stdout)
                .contains("serial /tmp/x at 115200 baud (dry run)"),
        "{o:?}"
    );
}

#[test]
fn every_binary_refuses_every_bad_scene_the_same_way() {
    let dir = root().join("tests/fixtures/scenes_bad");
    let table = std::fs::read_to_string(dir.join("expect.tsv")).unwrap_or_default();
    let tmp = TempDir::new("bad_input_scenes");
    let out = tmp.arg("sweep");
    let mut n = 0;
    for line in table
        .lines()
        .filter(|l| !l.starts_with('#') && !l.is_empty())
    {
        let cols: Vec<&str> = line.split('\t').collect();
        let [file, key, words] = cols[..] else {
            panic!("expect.tsv: bad line {line:?}")
        };
        let path = format!("tests/fixtures/scenes_bad/{file}");
        let mut refusals = Vec::new();
        for (name, args) in scene_takers(&out) {
            let args: Vec<String> = args.iter().map(|a| a.replace("{}", &path)).collect();
            let args: Vec<&str> = args.iter().map(String::as_str).collect();
            let o = run(name, &args);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{name} {args:?}: {err}");
            assert!(!err.contains("panicked"), "{name} {args:?} panicked: {err}");
            let head = format!("{path}: {key}: ");
            let Some(at) = err.find(&head) else {
                panic!("{name} {args:?}: stderr `{err}` lacks `{head}`")
            };
            let refusal = err[at..].lines().next().unwrap_or_default().to_string();
            assert!(
                refusal.contains(words),
                "{name} {args:?}: `{refusal}` lacks `{words}`"
            );
            assert!(o.stdout.is_empty(), "{name} {args:?} printed results");
            refusals.push((name, refusal));
        }
        let first = &refusals[0].1;
        for (name, r) in &refusals {
            assert_eq!(r, first, "{file}: {name} refuses differently");
        }
        n += 1;
    }
    assert!(
        n >= 40,
        "expected the malformed-scene corpus, found {n} cases"
    );
    assert!(
        !tmp.file("sweep.csv").exists(),
        "a refused sweep wrote output"
    );
}

/// Flag values out of range, a case a line: binary | arguments | words of the refusal (`{rec}`
/// stands for a recording that is never written).
const OUT_OF_RANGE: &str = "
capsule | simulate --periods -5 | from 1 to
capsule | simulate --periods 0 | from 1 to
capsule | simulate --alpha nan | finite
capsule | simulate --alpha -1 | must be in
capsule | simulate --omega inf | finite
capsule | simulate --gamma 0 | must be > 0 (got 0)
capsule | simulate --alpha 101 | must be in [0, 100] (got 101)
capsule | simulate --gamma -1 | must be > 0
capsule | simulate --kp 1e308 | must be in
capsule | simulate --friction seven-parameter --mu-v 1e308 | must be in
capsule | simulate --friction seven-parameter --k-s 1e308 | <= 1e12
capsule | simulate --tol 0 | (0, 1)
capsule | simulate --step=-1e-3 | must be > 0
capsule | simulate --samples-per-period 100000000 --csv never.csv | from 1 to 1000000
capsule | simulate --x0 1,2,3 | four comma-separated
capsule | simulate --x0 0,0,0,0,0 | four comma-separated
capsule | simulate --x0 0,nan,0,0 | finite
capsule | simulate --mu-v 0.2 | does not apply
capsule | simulate --friction gaussian-stribeck --k-s 1 | does not apply
capsule | simulate --device --rate-hz 0 | must be in
capsule | simulate --device --orbit-tolerance nan | finite
capsule | simulate --device --orbit-tolerance 0.5 | must be in
capsule | robustness --velocity-window 1 | from 2 to
capsule | robustness --orbit-tolerance 0 | must be in
capsule | sweep --param alpha --from 1 --to 2 --steps 4294967296 | from 1 to
capsule | sweep --param alpha --from 1 --to 2 --steps 18446744073709551615 | from 1 to
capsule | sweep --param alpha --from 1 --to 2 --steps 0 | from 1 to
capsule | sweep --param alpha --from 1 --to 2 --threads 100000 | from 1 to 1024
capsule | sweep --param alpha --from 1 --to 2 --threads 0 | from 1 to 1024
capsule | sweep --param kp --from nan --to 1 | finite
capsule | sweep --param kp --from 1e308 --to -1e308 | must be in
capsule | bench --repeat 0 | from 1 to
capsule | bench --sweep-values 0 | from 1 to
capsule | bench accuracy --out /nonexistent/dir/acc | does not exist
capsule | replay {rec} --rate 1e-300 | must be in
capsule | replay {rec} --rate 0 | must be in
capsule | replay {rec} --delay-s 1e308 | must be in
capsule | replay {rec} --duration -1 | must be > 0
capsule_plant | --scene scenes/control_point.toml --check --startup-timeout-s 1e308 | <= 1e6
capsule_plant | --scene scenes/control_point.toml --check --rate-hz 1e-300 | must be in
capsule_plant | --scene scenes/control_point.toml --check --rate-hz nan | finite
capsule_controller | --scene scenes/control_point.toml --check --orbit-tolerance 0.5 | must be in
capsule_plant | --scene scenes/control_point.toml --check --command-timeout-s 0 | must be in [1e-6, 1e6] (got 0)
capsule_plant | --scene scenes/control_point.toml --check --until-s -1 | must be > 0
capsule_plant | --scene scenes/control_point.toml --check --retransmit-ms 4294967296 | from 1 to 60000
capsule_plant | --scene scenes/control_point.toml --check --flush-ms 0 | from 1 to 60000
capsule_plant | --scene scenes/control_point.toml --check --clock-every 0 | from 1 to
capsule_plant | --scene scenes/control_point.toml --check --wait-subscribers 100000 | from 0 to 1000
capsule_controller | --scene scenes/control_point.toml --check --alpha -1 | must be in
capsule_controller | --scene scenes/control_point.toml --check --gain nan | finite
capsule_controller | --scene scenes/control_point.toml --check --gain inf | finite
capsule_controller | --scene scenes/control_point.toml --check --direction-gain nan | '--direction-gain <DIRECTION_GAIN>': must be a finite number
capsule_controller | --scene scenes/control_point.toml --check --direction-gain -1 | '--direction-gain <DIRECTION_GAIN>': must be in [0, 1e12]
capsule_controller | --scene scenes/control_point.toml --check --chaos-gain inf | '--chaos-gain <CHAOS_GAIN>': must be a finite number
capsule_controller | --scene scenes/control_point.toml --check --chaos-gain -1e308 | '--chaos-gain <CHAOS_GAIN>': must be in [-1e12, 1e12]
capsule_controller | --scene scenes/control_point.toml --check --gain-limit 1e308 | '--gain-limit <GAIN_LIMIT>': must be in [0, 1e12]
capsule_controller | --scene scenes/control_point.toml --check --gain-limit -1 | '--gain-limit <GAIN_LIMIT>': must be in [0, 1e12]
capsule_controller | --scene scenes/control_point.toml --check --direction-gain 3 | --direction-gain 3: beyond gain_limit (--gain-limit 2)
capsule_controller | --scene scenes/control_point.toml --check --chaos-gain -5 --gain-limit 4 | --chaos-gain -5: beyond gain_limit (--gain-limit 4)
capsule | replay {rec} --gain-limit nan | '--gain-limit <GAIN_LIMIT>': must be a finite number
capsule_controller | --scene scenes/control_point.toml --check --omega 0 | must be > 0 (got 0)
capsule_controller | --scene scenes/control_point.toml --check --m1-kg -1 | must be > 0 (got -1)
capsule_plant | --scene scenes/control_point.toml --check --views-rate-hz 0 | must be in [1e-3, 1e6] (got 0)
capsule_controller | --scene scenes/control_point.toml --check --state-timeout-s 1e308 | must be in [1e-6, 1e6] (got 1e308)
capsule_controller | --scene scenes/control_point.toml --check --status-period-ms 4294967296 | from 1 to 60000
capsule_recorder | --check --wait-publishers-s 1e308 | must be in
capsule_recorder | --check --idle-stop-s 1e308 | must be in
capsule_recorder | --check --flush-ms 4294967296 | from 1 to 60000
capsule_recorder | --check --poll-ms 0 | from 1 to 60000
capsule_foxglove | --check --max-rate-hz inf | finite
capsule_foxglove | --check --port 70000 | 0..=65535
capsule_foxglove | --check --host 0.0.0.0 | 127.0.0.1 only
capsule_container | --scene scenes/control_point.toml --check --foxglove-port 70000 | 0..=65535
capsule_container | --scene scenes/control_point.toml --check --foxglove-port -1 | --foxglove-port
capsule_recorder | --check --queue-depth 0 | from 1 to 1000000
capsule_recorder | --check --queue-depth 18446744073709551616 | from 1 to 1000000
capsule_ros | period --scene scenes/control_point.toml --periods -5 | must be > 0
capsule_ros | set-mode forward --gain nan | finite
capsule_ros | set-mode forward --timeout-s 1e308 | <= 1e6
capsule_ros | demo --scene scenes/control_point.toml --settle-periods inf | finite
";

#[test]
fn every_numeric_flag_refuses_values_out_of_its_range() {
    let tmp = TempDir::new("bad_input_flags");
    let rec = tmp.arg("never.mcap");
    let mut n = 0;
    for case in OUT_OF_RANGE.lines().filter(|l| !l.is_empty()) {
        let cols: Vec<&str> = case.split('|').map(str::trim).collect();
        let [name, args, words] = cols[..] else {
            panic!("OUT_OF_RANGE: bad line {case:?}")
        };
        let args: Vec<&str> = args
            .split_whitespace()
            .map(|a| if a == "{rec}" { rec.as_str() } else { a })
            .collect();
        assert_refused(&run(name, &args), 2, words, &format!("{name} {args:?}"));
        n += 1;
    }
    assert_eq!(n, 80, "OUT_OF_RANGE lost cases");
}

#[test]
fn the_controller_gain_flags_state_their_range_in_help() {
    let o = run("capsule_controller", &["--help"]);
    assert_ok(&o);
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    for (flag, range) in [
        ("--direction-gain", "[0, 1e12] and at most gain_limit"),
        ("--chaos-gain", "[-1e12, 1e12] and |k_p| at most gain_limit"),
        ("--gain-limit", "[0, 1e12]"),
    ] {
        let at = help
            .find(&format!("{flag} <"))
            .unwrap_or_else(|| panic!("--help lacks {flag}:\n{help}"));
        let entry: String = help[at..].lines().take(3).collect::<Vec<_>>().join(" ");
        assert!(entry.contains(range), "{flag}: `{entry}` lacks `{range}`");
    }
    // within the ranges, the defaults go
    let o = run(
        "capsule_controller",
        &line(
            "--scene scenes/control_point.toml --check --direction-gain 0.5 --chaos-gain -1.5",
            &[],
        ),
    );
    assert_ok(&o);
}

/// A value just outside a setting's range, as a parameter's text writes it (`None` for any
/// finite number, a switch or text).
fn outside(s: &Setting) -> Option<(f64, String)> {
    let v = match s.kind {
        Kind::Number { min, .. } if min > -1e300 => min - 1.0,
        Kind::Number { max, .. } => max * 1.5,
        Kind::Count { min, max } => {
            return Some(if min > 0 {
                (0.0, "0".into())
            } else {
                ((max + 1) as f64, (max + 1).to_string())
            })
        }
        Kind::Positive { .. } | Kind::Rule(Rule::Positive) => 0.0,
        Kind::Rule(Rule::NonNegative) => -1.0,
        Kind::Rule(Rule::Tolerance) => 1.5,
        Kind::Rule(Rule::Within((_, max))) => max * 1.5 + 1.0,
        Kind::Rule(Rule::Finite) | Kind::Finite | Kind::Switch | Kind::Choice(_) | Kind::Text => {
            return None
        }
    };
    Some((v, format!("{v:?}")))
}

/// The scene file text that gives `key` (`drive.alpha`) the value `text`.
fn scene_text(key: &str, text: &str) -> String {
    let (table, name) = key.split_once('.').unwrap_or(("", key));
    format!("[{table}]\n{name} = {text}\n")
}

/// One truth per range (issue 39): every numeric setting of both nodes (the flags that are not
/// parameters and the plant's views included: every flag of both is a row), given a value just
/// outside its range as a flag, as a ROS parameter at start when it is one (`-p`, which goes
/// through the check `ros2 param set` uses: ros::params sets one on the running node) and, when
/// the scene gives it,
/// as the scene file's key, is refused with the same reason everywhere; a scene key is refused
/// alike by both nodes and by the offline tool, which reads the same scene.
#[test]
fn every_setting_is_refused_the_same_way_by_flag_parameter_and_scene() {
    let tmp = TempDir::new("bad_input_ranges");
    let good = "scenes/control_point.toml";
    let tables: [(&str, &[Setting]); 2] = [
        ("capsule_controller", &CONTROLLER),
        ("capsule_plant", &PLANT),
    ];
    let mut checked = 0;
    for (node, table) in tables {
        for s in table.iter().filter(|s| s.flag) {
            let Some((v, text)) = outside(s) else {
                continue;
            };
            let why = s.check(v).expect_err("the value is outside the range");
            let flag = format!("--{}", s.flag_name());
            let param = format!("{}:={text}", s.name);
            let mut cases: Vec<(&str, Vec<String>, String)> = vec![(
                node,
                vec![
                    "--scene".into(),
                    good.into(),
                    "--check".into(),
                    flag.clone(),
                    text.clone(),
                ],
                format!("{flag} <"),
            )];
            if s.parameter {
                cases.push((
                    node,
                    vec![
                        "--scene".into(),
                        good.into(),
                        "--check".into(),
                        "--ros-args".into(),
                        "-p".into(),
                        param.clone(),
                    ],
                    format!("-p {param}: parameter '{}': {why}", s.name),
                ));
            }
            if let Some(key) = s.scene {
                let file = tmp.file(&format!("{}.toml", s.name));
                std::fs::write(&file, scene_text(key, &text)).unwrap_or_else(|e| panic!("{e}"));
                let f = file.display().to_string();
                let said = format!("{f}: {key}: {why}");
                for reader in ["capsule_controller", "capsule_plant"] {
                    cases.push((
                        reader,
                        vec!["--scene".into(), f.clone(), "--check".into()],
                        said.clone(),
                    ));
                }
                cases.push((
                    "capsule",
                    vec![
                        "simulate".into(),
                        "--scene".into(),
                        f.clone(),
                        "--json".into(),
                    ],
                    said.clone(),
                ));
            }
            for (bin, args, words) in cases {
                let args: Vec<&str> = args.iter().map(String::as_str).collect();
                let o = run(bin, &args);
                let err = stderr(&o);
                assert_eq!(o.status.code(), Some(2), "{bin} {args:?}: {err}");
                assert!(
                    err.contains(&words) && err.contains(&why),
                    "{bin} {args:?}: `{err}` lacks `{words}` or `{why}`"
                );
                checked += 1;
            }
        }
    }
    // every numeric setting was fed to every source that gives it
    assert!(checked >= 40, "only {checked} refusals checked");
    // the help says the range, and where else the value comes from
    let o = run("capsule_controller", &["--help"]);
    let help = String::from_utf8_lossy(&o.stdout).into_owned();
    assert_holds(
        &help,
        &["[0, 100] [scene: drive.alpha; parameter alpha, writable]"],
    );
}

#[test]
fn runs_over_their_work_limits_are_refused_before_they_start() {
    let tmp = TempDir::new("bad_input_limits");
    let csv = tmp.file("big.csv");
    let csv_s = csv.display().to_string();
    let sweep_out = tmp.file("sweep").display().to_string();
    let cases = [
        (
            line(
                "simulate --periods 20 --transient 5 --method fixed --step 1e-12",
                &[],
            ),
            "--max-work",
        ),
        (
            line(
                "simulate --periods 200000 --samples-per-period 1000 --csv",
                &[&csv_s],
            ),
            "--max-samples",
        ),
        (
            line(
                "sweep --param alpha --from 0.5 --to 1 --steps 10000000 --out",
                &[&sweep_out],
            ),
            "--max-work",
        ),
        (
            line(
                "simulate --periods 3 --method fixed --step 1e-3 --max-work 1000",
                &[],
            ),
            "--max-work",
        ),
        (
            line("simulate --periods 3 --csv /nonexistent/dir/h.csv", &[]),
            "does not exist",
        ),
    ];
    for (args, words) in &cases {
        let o = run("capsule", args);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(words), "{args:?}: `{err}` lacks `{words}`");
    }
    assert!(!csv.exists(), "a refused run wrote its CSV");
    // the plant node: a fixed step that would take more than 1e6 steps per sample
    let tiny = tmp.file("tiny_step.toml");
    std::fs::write(&tiny, "[solver]\nmethod = \"fixed\"\nstep = 1e-300\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let o = run(
        "capsule_plant",
        &["--scene", &tiny.display().to_string(), "--check"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("solver.step = 1e-300"),
        "{}",
        stderr(&o)
    );
    assert!(stderr(&o).contains("more than the plant's limit of 1e6"));
    // raised explicitly, the same run goes
    let o = run(
        "capsule",
        &line(
            "simulate --periods 3 --method fixed --step 1e-3 --max-work 1e5",
            &[],
        ),
    );
    assert_ok(&o);
}

#[test]
fn runs_that_leave_the_adaptive_envelope_stop_with_a_clear_error() {
    let mut n = 0;
    for path in files_in(&root().join("tests/fixtures/scenes_stiff")) {
        let p = path.display().to_string();
        let t0 = Instant::now();
        let o = run("capsule", &["simulate", "--scene", &p]);
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{p}: {err}");
        assert!(
            err.contains("envelope") || err.contains("step size underflow"),
            "{p}: {err}"
        );
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "{p} took {:?}",
            t0.elapsed()
        );
        n += 1;
    }
    assert!(n >= 3);
    let o = run(
        "capsule",
        &line(
            "simulate --periods 20 --transient 5 --friction seven-parameter --k-s 1e10",
            &[],
        ),
    );
    assert!(stderr(&o).contains("envelope"), "{}", stderr(&o));
}

#[test]
fn sweeps_with_failed_values_exit_non_zero_and_name_them() {
    let tmp = TempDir::new("bad_input_sweeps");
    let out = tmp.arg("fail");
    let args = line(
        "sweep --param alpha --from -1 --to 1 --steps 3 --periods 3 --out",
        &[&out],
    );
    let o = run("capsule", &args);
    let text = String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{text}");
    assert!(
        text.contains("alpha = -1: drive.alpha: must be in [0, 100] (got -1)"),
        "{text}"
    );
    assert!(text.contains("1 of 3 values failed"), "{text}");
    let o = run("capsule", &[&args[..], &["--allow-failures"]].concat());
    assert_ok(&o);
    // a value out of the parameter's range among good ones, and a range from +max to -max
    for (param, from, to, named) in [
        ("omega", "0", "1", "omega = 0: drive.omega: must be > 0"),
        ("gamma", "-1", "3", "gamma = -1: capsule.gamma: must be > 0"),
    ] {
        let o = run(
            "capsule",
            &[
                &["sweep", "--param", param, "--from", from, "--to", to][..],
                &line("--steps 3 --periods 3 --out", &[&out]),
            ]
            .concat(),
        );
        let text = String::from_utf8_lossy(&o.stdout).into_owned() + &stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{text}");
        assert!(text.contains(named), "{param}: {text}");
        assert!(text.contains("1 of 3 values failed"), "{param}: {text}");
    }
    // --out DIR/ writes into the directory
    let dir = tmp.file("outdir");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let d = format!("{}/", dir.display());
    let o = run(
        "capsule",
        &line(
            "sweep --param kp --from 0 --to 0.1 --steps 2 --periods 3 --out",
            &[&d],
        ),
    );
    assert_ok(&o);
    assert!(dir.join("kp.csv").is_file() && dir.join("kp.svg").is_file());
}

/// Runs `capsule` with these arguments, sends it SIGINT after 1.5 s, and waits (at most 60 s)
/// for it to stop.
fn interrupted(args: &[&str]) -> std::process::Output {
    interrupted_after(args, Duration::from_millis(1500))
}

/// [`interrupted`], with SIGINT sent after `delay`.
fn interrupted_after(args: &[&str], delay: Duration) -> std::process::Output {
    let mut child = command("capsule")
        .args(args)
        .spawn()
        .unwrap_or_else(|e| panic!("{e}"));
    std::thread::sleep(delay);
    let killed = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .map(|s| s.success());
    assert_eq!(killed.ok(), Some(true));
    let t0 = Instant::now();
    while child.try_wait().ok().flatten().is_none() {
        if t0.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{args:?} still running 60 s after SIGINT");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap_or_else(|e| panic!("{e}"))
}

/// An interrupted run: exit status 1, `words` on stderr, and more than `lines` lines in `csv`.
fn assert_interrupted(o: &std::process::Output, words: &str, csv: &std::path::Path, lines: usize) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains(words), "{err}");
    let text = std::fs::read_to_string(csv).unwrap_or_default();
    assert!(text.lines().count() > lines, "nothing written: {err}");
}

#[test]
fn an_interrupted_sweep_or_basin_map_writes_what_finished_and_exits_non_zero() {
    let tmp = TempDir::new("bad_input_interrupted_sweep");
    let prefix = tmp.arg("interrupted");
    // long enough on one thread (basins: 250,000 initial states) that the signal finds it running
    for (command, words) in [
        (
            "sweep --param alpha --from 0.5 --to 1.5 --steps 20000 --periods 30 --threads 1",
            "interrupted:",
        ),
        (
            "basins --alpha 1.5 --grid 500,500 --basin-method per-state --threads 1",
            "initial states not computed; the finished ones are in",
        ),
    ] {
        let o = interrupted(&line(command, &["--out", &prefix]));
        assert_interrupted(&o, words, &tmp.file("interrupted.csv"), 1);
        let _ = std::fs::remove_file(tmp.file("interrupted.csv"));
    }
}

#[test]
fn an_interrupted_continuation_writes_the_branch_so_far_and_exits_non_zero() {
    let tmp = TempDir::new("bad_input_interrupted_continuation");
    let out = tmp.file("branch");
    // the period-3 isola of Fig 18 in steps 40 times below the default: thousands of points, 1.3
    // s of CPU since the numerical crates are optimised in dev builds, so the signal comes at
    // 0.4 s (at 1.5 s it could find the run writing its files, with Ctrl-C's default action back)
    let scene = root().join("scenes/switch_alpha15.toml");
    let o = interrupted_after(
        &line(
            "continue --param alpha --to 1.75 --arc-step 0.0005 --max-arc-step 0.0005 --scene",
            &[
                &scene.display().to_string(),
                "--out",
                &out.display().to_string(),
            ],
        ),
        Duration::from_millis(400),
    );
    let words = ": interrupted; the branch so far is written";
    assert_interrupted(&o, words, &out.with_extension("csv"), 2);
    let json = std::fs::read_to_string(out.with_extension("json")).unwrap_or_default();
    assert_holds(&json, &["interrupted", "\"closed\": false"]);
}

#[test]
fn an_interrupted_simulation_writes_its_time_history_so_far_and_exits_non_zero() {
    let tmp = TempDir::new("bad_input_interrupted_sim");
    let csv = tmp.arg("interrupted_sim.csv");
    // a million periods: minutes even in release, so the signal finds it running
    let o = interrupted(&line(
        "simulate --periods 1000000 --samples-per-period 1 --csv",
        &[&csv],
    ));
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let line = err
        .lines()
        .find(|l| l.contains("interrupted:"))
        .unwrap_or_else(|| panic!("no `interrupted:` in `{err}`"));
    assert!(
        line.contains("of 1000000 periods done") && line.contains(&csv),
        "{line}"
    );
    assert!(o.stdout.is_empty(), "printed a summary of a partial run");
    // the CSV is whole: the header, then complete rows in time order, fewer than a full run's
    let text = std::fs::read_to_string(&csv).unwrap_or_else(|e| panic!("{csv}: {e}"));
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("tau,x1,y1,x2,y2,stuck,contact,friction_force,contact_force,actuator_force")
    );
    let mut last = f64::NEG_INFINITY;
    let mut rows = 0usize;
    for l in lines {
        let v: Vec<f64> = l
            .split(',')
            .map(|x| x.parse().unwrap_or_else(|_| panic!("row `{l}`")))
            .collect();
        assert_eq!(v.len(), 10, "row `{l}`");
        assert!(v[0] > last, "tau not increasing at `{l}`");
        last = v[0];
        rows += 1;
    }
    assert!(rows > 1 && rows < 1_000_001, "{rows} rows");
    assert!(line.contains(&format!("({rows} rows)")), "{line}");
}

#[test]
fn partial_scenes_take_the_defaults_and_say_which() {
    let tmp = TempDir::new("bad_input_partial");
    let f = tmp.arg("partial.toml");
    std::fs::write(&f, "[capsule]\ngamma = 0.5\n").unwrap_or_else(|e| panic!("{e}"));
    let o = run("capsule", &["simulate", "--scene", &f, "--print-scene"]);
    assert_ok(&o);
    let text = String::from_utf8_lossy(&o.stdout);
    for line in [
        "gamma = 0.5",
        "beta = 15.0",
        "alpha = 0.8",
        "law = \"coulomb\"",
        "periods = 300",
        "transient = 200",
    ] {
        assert!(text.contains(line), "--print-scene lacks `{line}`:\n{text}");
    }
    // an empty scene file is all defaults, for every binary that takes a scene
    let empty_s = tmp.arg("empty.toml");
    std::fs::write(&empty_s, "").unwrap_or_else(|e| panic!("{e}"));
    let rec_dir = tmp.arg("empty_rec");
    for (name, args) in [
        (
            "capsule",
            vec!["simulate", "--scene", &empty_s, "--print-scene"],
        ),
        ("capsule_plant", vec!["--scene", &empty_s, "--check"]),
        ("capsule_controller", vec!["--scene", &empty_s, "--check"]),
        (
            "capsule_recorder",
            vec!["--scene", &empty_s, "--check", "--record-dir", &rec_dir],
        ),
    ] {
        let o = run(name, &args);
        assert!(o.status.success(), "{name} {args:?}: {}", stderr(&o));
    }
    // what --print-scene prints is a scene that reads back the same
    let back = capsule_plant::scene::Scene::from_toml_str(&text, "printed")
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back.model.capsule.gamma, 0.5);
}

#[test]
fn one_rule_for_periods_and_transient_with_and_without_a_scene() {
    let measured = |args: &[&str]| {
        let v = json_of(&run(
            "capsule",
            &[&["simulate", "--json"][..], args].concat(),
        ));
        (
            v["scene"]["horizon"]["transient"].as_u64(),
            v["measured_periods"].as_u64(),
        )
    };
    assert_eq!(measured(&["--periods", "30"]), (Some(20), Some(10)));
    assert_eq!(
        measured(&["--scene", "scenes/control_point.toml", "--periods", "50"]),
        measured(&["--periods", "50"])
    );
    assert_eq!(
        measured(&["--scene", "scenes/control_point.toml", "--periods", "30"]),
        (Some(20), Some(10))
    );
    assert_eq!(
        measured(&line(
            "--scene scenes/control_point.toml --periods 30 --transient 5",
            &[]
        )),
        (Some(5), Some(25))
    );
    let o = run(
        "capsule",
        &["simulate", "--periods", "30", "--transient", "30"],
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("horizon.transient: must be less than horizon.periods = 30"));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// Any scene text: refused with file, key and reason, or accepted and valid; never a panic.
    #[test]
    fn any_scene_text_is_refused_cleanly_or_valid(
        gamma in prop_oneof![any::<f64>().prop_map(|v| v.to_string()), Just("nan".to_string()), Just("-inf".to_string()), "[a-z\"]{0,4}"],
        periods in prop_oneof![any::<i64>().prop_map(|v| v.to_string()), any::<f64>().prop_map(|v| format!("{v:?}"))],
        state_len in 0usize..7,
        law in prop_oneof![Just("coulomb"), Just("viscous"), Just("stribeck"), Just("seven-parameter"), Just("sand")],
        junk in "[ -~\n]{0,12}",
    ) {
        let state = vec!["0.0"; state_len].join(", ");
        let text = format!(
            "[capsule]\ngamma = {gamma}\n[friction]\nlaw = \"{law}\"\n[horizon]\nperiods = {periods}\n[initial]\nstate = [{state}]\n{junk}"
        );
        match capsule_plant::scene::Scene::from_toml_str(&text, "p.toml") {
            Ok(s) => prop_assert!(s.validate().is_ok()),
            Err(e) => {
                prop_assert_eq!(&e.file, "p.toml");
                prop_assert!(!e.key.is_empty());
                prop_assert!(e.to_string().starts_with("p.toml: "));
            }
        }
    }

    /// Any flag text: a value within the documented range, or a refusal; durations convert.
    #[test]
    fn any_flag_value_is_in_range_or_refused(text in prop_oneof![
        any::<f64>().prop_map(|v| v.to_string()),
        any::<u64>().prop_map(|v| v.to_string()),
        any::<i64>().prop_map(|v| v.to_string()),
        "[-+.e0-9a-z]{0,8}",
    ]) {
        use capsule_args::ranges;
        if let Ok(v) = ranges::positive(ranges::MAX_SECONDS)(&text) {
            prop_assert!(v > 0.0 && v <= ranges::MAX_SECONDS);
            prop_assert!(Duration::try_from_secs_f64(v).is_ok());
        }
        if let Ok(v) = ranges::non_negative(ranges::MAX_SECONDS)(&text) {
            prop_assert!(Duration::try_from_secs_f64(v).is_ok());
        }
        if let Ok(v) = ranges::finite()(&text) {
            prop_assert!(v.is_finite() && v.abs() <= ranges::MAX_MAGNITUDE);
        }
        if let Ok(v) = ranges::millis()(&text) {
            prop_assert!((1..=ranges::MAX_MILLIS).contains(&v));
        }
        if let Ok(v) = ranges::within(ranges::RATE_HZ.0, ranges::RATE_HZ.1)(&text) {
            prop_assert!(Duration::try_from_secs_f64(1.0 / v).is_ok());
        }
    }
}

#[test]
fn the_launch_scripts_check_their_arguments_and_print_usage() {
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "demo.sh",
            &["scenes/control_point.toml", "-5"],
            "PERIODS_PER_SEGMENT '-5'",
        ),
        (
            "demo.sh",
            &["scenes/control_point.toml", "abc"],
            "PERIODS_PER_SEGMENT 'abc'",
        ),
        ("demo.sh", &["no/such.toml"], "cannot read scene file"),
        ("demo.sh", &["a", "b", "c"], "at most two arguments"),
        ("demo.sh", &["--rmw", "udp"], "--rmw 'udp': dds or zenoh"),
        ("capsule_launch.sh", &["--scene"], "--scene needs a value"),
        ("capsule_launch.sh", &[], "--scene is required"),
    ];
    // the launcher with a scene and one bad flag
    let launch_flags: &[([&str; 2], &str)] = &[
        (["--rmw", "udp"], "--rmw 'udp': dds or zenoh"),
        (
            ["--rmw", "zenoh"],
            "recording is not on Zenoh yet; give --no-record",
        ),
        (["--pacing", "fast"], "realtime or lockstep"),
        (["--until-s", "-5"], "--until-s '-5'"),
    ];
    let with_scene = launch_flags.iter().map(|(flag, words)| {
        let args = ["--scene", "scenes/control_point.toml"].iter().chain(flag);
        ("capsule_launch.sh", args.copied().collect(), *words)
    });
    let cases = cases.iter().map(|(s, a, w)| (*s, a.to_vec(), *w));
    for (script, args, words) in cases.chain(with_scene) {
        let o = Command::new("bash")
            .arg(root().join("launch_scripts").join(script))
            .args(&args)
            .current_dir(root())
            .stdin(Stdio::null())
            .output()
            .unwrap_or_else(|e| panic!("{script}: {e}"));
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{script} {args:?}: {err}");
        assert!(
            err.contains(words),
            "{script} {args:?}: `{err}` lacks `{words}`"
        );
        assert!(
            err.contains("Usage") || err.contains("  launch_scripts/"),
            "{script}: no usage"
        );
        assert!(!err.contains("unbound variable") && !err.contains("error: invalid value"));
    }
}
