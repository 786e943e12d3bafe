//! The minimal controller example (`capsule_nodes/examples/minimal_controller.rs`) closes the
//! loop with a lock-step plant as the controller node does: every sample answered, and the
//! capsule where the controller node's FORWARD 0.2 takes it.

use super::harness::{json_number, netns};
use crate::examples::example;

#[test]
fn the_minimal_controller_drives_the_plant_as_the_controller_node_does() {
    let minimal = example("minimal_controller");
    let script = format!(
        r#"
        plant() {{ $B/capsule_plant --scene "$SCENE" --pacing lockstep --until-s 1.5 --wait-subscribers 1 \
              --command-timeout-s 10 --summary-json "$TMP/$1.json"; }}
        '{minimal}' --scene "$SCENE" --kp 0.2 & M=$!
        plant minimal || exit 1
        stop $M || exit 1
        echo "MINIMAL $(cat $TMP/minimal.json)"
        start_controller --mode forward --gain 0.2
        plant node || exit 1
        stop $C
        echo "NODE $(cat $TMP/node.json)""#,
        minimal = minimal.display()
    );
    let run = netns(180, &script);
    run.assert_ok();
    let (a, b) = (run.after("MINIMAL "), run.after("NODE "));
    assert_eq!(json_number(a, "unanswered"), Some(0.0), "{a}");
    assert_eq!(json_number(a, "seq"), Some(1500.0), "{a}");
    let x_minimal = json_number(a, "capsule_position").unwrap_or(f64::NAN);
    let x_node = json_number(b, "capsule_position").unwrap_or(f64::NAN);
    println!("capsule at {x_minimal} m (minimal controller), {x_node} m (controller node)");
    // forward: about 1.5 mm per drive period of 0.09 s
    assert!(
        x_minimal > 0.01,
        "the capsule went {x_minimal} m\n{}",
        run.all()
    );
    assert!(
        (x_minimal - x_node).abs() <= 1e-6 * x_node.abs(),
        "minimal controller {x_minimal} m, controller node {x_node} m\n{}",
        run.all()
    );
    run.assert_stdout(&["answered up to seq 1500; the capsule went"]);
}
