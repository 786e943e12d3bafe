//! The custom plant example (`capsule_nodes/examples/custom_plant.rs`): a toy capsule behind
//! the plant node's hardware interface runs a lock-step loop with the controller node as the
//! simulator does: every sample published, answered and written to the toy.

use super::harness::{json_number, json_raw, netns};
use crate::examples::example;

#[test]
fn a_toy_capsule_behind_the_hardware_interface_runs_the_plant_node() {
    let plant = example("custom_plant");
    let script = format!(
        r#"
        start_controller --mode forward
        '{plant}' --scene "$SCENE" --pacing lockstep --until-s 1 --wait-subscribers 1 || exit 1
        stop $C"#,
        plant = plant.display()
    );
    let run = netns(180, &script);
    run.assert_ok();
    let summary = run.json_with("unanswered");
    println!("{summary}\n{}", run.line("toy capsule: "));
    // 1 s at the scene's 1 kHz: samples 0..=1000, each answered by the controller
    assert_eq!(json_number(summary, "samples"), Some(1001.0), "{summary}");
    assert_eq!(json_number(summary, "unanswered"), Some(0.0), "{summary}");
    assert_eq!(
        json_raw(summary, "command_stale"),
        Some("false"),
        "{summary}"
    );
    let force = json_number(summary, "actuator_force").unwrap_or(f64::NAN);
    assert!(force.is_finite() && force != 0.0, "{summary}");
    // the node read the toy once per sample and wrote it at least once per answered sample
    let counts = run.after("toy capsule: ");
    let n: Vec<u64> = counts
        .split(|c: char| !c.is_ascii_digit())
        .filter_map(|w| w.parse().ok())
        .collect();
    assert_eq!(n.first(), Some(&1001), "{counts}");
    assert!(n.get(1).is_some_and(|w| *w >= 1000), "{counts}");
}
