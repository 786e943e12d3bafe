//! From a prototype to its twin through the ROS graph (issue 37): the plant records the
//! emulated device (`capsule emulate-device`, the typical device, a capsule off the nominal
//! scene) in lock-step under the controller's FORWARD, and the twin identified from that
//! recording (`capsule_record::series`, `capsule_analysis::identify`, as `capsule identify`
//! runs them) has the emulated capsule's numbers.

use super::harness::netns;
use crate::common::TempDir;
use capsule_analysis::identify::{identify, Settings};
use capsule_analysis::twin::Recorded;
use capsule_plant::device::DeviceModel;

#[test]
fn a_twin_is_identified_from_the_plant_s_recording_of_the_emulator() {
    let dir = TempDir::new("twin_ros");
    let nominal_text = std::fs::read_to_string(crate::root().join("scenes/control_point.toml"))
        .unwrap_or_else(|e| panic!("{e}"));
    // the device's capsule: gamma +20 %, xi +20 % (the emulator's scene); the typical device
    let device_text = nominal_text
        .replace("gamma = 0.235", "gamma = 0.282")
        .replace("xi = 0.05", "xi = 0.06");
    assert_ne!(device_text, nominal_text);
    let device_scene = dir.arg("device.toml");
    std::fs::write(&device_scene, &device_text).unwrap_or_else(|e| panic!("{e}"));
    let rec = dir.arg("run.mcap");
    let script = format!(
        r#"
        "$B/capsule" emulate-device --scene "{device_scene}" --link "$TMP/dev" --pacing lockstep > "$TMP/emu.out" 2> "$TMP/emu.err" &
        E=$!
        start_controller --mode forward
        $B/capsule_plant --scene "$SCENE" --source "serial:$TMP/dev" --pacing lockstep --until-s 12 \
            --wait-subscribers 1 --command-timeout-s 10 --record-output "{rec}" || exit 1
        stop $C || exit 1
        kill -INT $E; wait $E
        cat "$TMP/emu.err""#
    );
    let run = netns(240, &script);
    run.assert_ok();
    let s = capsule_record::series::series(std::path::Path::new(&rec))
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(s.forces, capsule_record::series::ForceSource::Commands);
    let samples = s.x2_m.len();
    assert!(
        samples > 11_000,
        "{samples} samples, {} repeated",
        s.repeated
    );
    let recorded = Recorded::new(s.h_s, s.rel_m, s.x2_m, s.command_n);
    let mut nominal = crate::scene("control_point.toml");
    nominal.device = Some(DeviceModel::typical(&nominal.physical));
    let keys = vec!["capsule.gamma".to_string(), "capsule.xi".to_string()];
    let fit = identify(&nominal, &recorded, &keys, &Settings::default())
        .unwrap_or_else(|e| panic!("{e}"));
    for (e, truth) in fit.report.parameters.iter().zip([0.282, 0.06]) {
        let v = e.value.unwrap_or(f64::NAN);
        let sd = e.std_error.unwrap_or(f64::NAN);
        let line = format!(
            "{} true {truth} fitted {v} +- {sd}; {} repeated samples dropped",
            e.key, s.repeated
        );
        assert!((v / truth - 1.0).abs() < 0.05, "{line}");
        assert!((v - truth).abs() <= 3.0 * sd, "{line}");
        println!("{line}");
    }
}
