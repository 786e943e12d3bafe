//! The scene format: defaults, round trips, refusals.

use super::file::FrictionSpec;
use super::{Fault, Horizon, Scene};
use crate::device::DeviceModel;
use crate::model::{Friction, State, FRICTION_CONSTANTS};
use crate::solver::{Method, SolverConfig};

const GOOD: &str = r#"
    [capsule]
    gamma = 0.235
    beta = 3.05
    delta = 0.02
    xi = 0.05
    [friction]
    law = "coulomb"
    [drive]
    alpha = 1.6
    omega = 1.1
"#;

#[test]
fn a_minimal_scene_gets_the_defaults() {
    let s = Scene::from_toml_str(GOOD, "good.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s.horizon,
        Horizon {
            periods: 300,
            transient: 200
        }
    );
    assert_eq!(s.solver.method, Method::Exact);
    assert_eq!(s.initial, State::default());
    assert_eq!(s.name, "good.toml");
}

#[test]
fn an_empty_scene_is_the_default_scene() {
    let s = Scene::from_toml_str("", "empty.toml").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        s,
        Scene {
            name: "empty.toml".into(),
            ..Scene::default()
        }
    );
}

#[test]
fn a_partial_table_takes_the_defaults_for_the_rest() {
    let s = Scene::from_toml_str("[capsule]\ngamma = 0.5\n[horizon]\nperiods = 30\n", "p")
        .unwrap_or_else(|e| panic!("{e}"));
    let d = Scene::default();
    assert_eq!(s.model.capsule.gamma, 0.5);
    assert_eq!(s.model.capsule.beta, d.model.capsule.beta);
    assert_eq!(
        s.horizon,
        Horizon {
            periods: 30,
            transient: 20
        }
    );
}

#[test]
fn every_law_of_the_table_reads_back_with_its_constants_and_refuses_others() {
    for c in &FRICTION_CONSTANTS {
        assert!(FrictionSpec::default().slot(c.key).is_some(), "{}", c.key);
    }
    for law in Friction::LAWS {
        assert_eq!(Friction::by_name(law.name()), Some(law));
        let mut s = Scene::default();
        s.model.friction = law;
        s.solver = SolverConfig::most_accurate_for(&s.model);
        let back = Scene::from_toml_str(&s.to_toml(), "t.toml").map_err(|e| e.to_string());
        assert_eq!(back.map(|b| b.model.friction), Ok(law));
        let used: Vec<&str> = law.constants().iter().map(|(c, _)| c.key).collect();
        for c in &FRICTION_CONSTANTS {
            let text = format!("[friction]\nlaw = \"{}\"\n{} = 0.5\n", law.name(), c.key);
            let got = Scene::from_toml_str(&text, "t.toml").map(|s| s.model.friction);
            if used.contains(&c.key) {
                let mut want = law;
                assert!(want.set_constant(c.key, 0.5));
                assert_eq!(got.map_err(|e| e.to_string()), Ok(want));
            } else {
                let e = got.err().map(|e| e.to_string()).unwrap_or_default();
                assert!(e.contains(&format!("friction.{}", c.key)), "{e}");
            }
        }
    }
    let e = Scene::from_toml_str("[friction]\nlaw = \"dry\"\n", "t.toml").err();
    let e = e.map(|e| e.to_string()).unwrap_or_default();
    assert!(
        e.contains("coulomb, viscous, stribeck, seven-parameter or gaussian-stribeck"),
        "{e}"
    );
}

#[test]
fn printed_scenes_read_back_the_same() {
    let mut s = Scene::from_toml_str(GOOD, "good.toml").unwrap_or_else(|e| panic!("{e}"));
    s.model.friction = Friction::SevenParameter(crate::friction::SevenParameter {
        mu_v: 0.2,
        v_s: 0.3,
        tau_d: 0.04,
        k_s: 1e4,
    });
    s.solver.method = Method::Adaptive;
    s.initial = State::from_array([0.1, -0.2, 0.3, 1e-7]);
    let back = Scene::from_toml_str(&s.to_toml(), "x").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, s);
}

#[test]
fn errors_name_file_key_and_reason() {
    let bad = GOOD.replace("gamma = 0.235", "gamma = -1.0");
    let e = Scene::from_toml_str(&bad, "bad.toml")
        .err()
        .map(|e| e.to_string());
    assert_eq!(
        e.as_deref(),
        Some("bad.toml: capsule.gamma: must be > 0 (got -1)")
    );
    let e = Scene::from_toml_str("[capsule]\ngamma = \"big\"\n", "t.toml").err();
    assert_eq!(e.map(|e| e.key), Some("capsule.gamma".to_string()));
    let e = Scene::from_toml_str("[drive]\nalpha = 1\nalpha = 2\n", "d.toml").err();
    assert_eq!(e.map(|e| e.key), Some("(syntax)".to_string()));
    let e = Scene::from_toml_bytes(b"\xff\xfe\x00", "g.bin").err();
    assert_eq!(e.map(|e| e.reason), Some(Fault::NotText));
}

#[test]
fn a_device_table_fills_from_the_typical_device_and_reads_back() {
    let s = Scene::from_toml_str(
        "[device]\nmeasured = [\"displacement\"]\nlag_s = 0.002\nseed = 7\n",
        "d.toml",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let d = s.device.unwrap_or_else(|| panic!("no device"));
    let typical = DeviceModel::typical(&s.physical);
    assert_eq!(d.measured.names(), ["displacement"]);
    assert_eq!((d.lag_s, d.seed), (0.002, 7));
    assert_eq!(d.noise_m, typical.noise_m);
    let back = Scene::from_toml_str(&s.to_toml(), "x").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(back, s);
    assert_eq!(Scene::default().device, None);
    let e = |text: &str| {
        Scene::from_toml_str(text, "d.toml")
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    assert_eq!(
        e("[device]\nlatency_s = -1.0\n"),
        "d.toml: device.latency_s: must be >= 0 (got -1)"
    );
    assert!(e("[device]\nmeasured = [\"speed\"]\n")
        .contains("device.measured: unknown quantity `speed`"));
    assert!(e("[device]\nseed = 1.5\n").contains("device.seed"));
    assert!(e("[device]\nmax_force_n = 0.0\n").contains("device.max_force_n: must be > 0"));
}
