//! What the examples of capsule_analysis share: their first argument and their scene.

use capsule_plant::scene::Scene;

/// The first command-line argument as a number, or `default` without one.
pub fn first_arg_or(default: f64) -> Result<f64, std::num::ParseFloatError> {
    std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()
        .map(|v| v.unwrap_or(default))
}

/// The section-5 control point, scenes/control_point.toml.
pub fn control_point() -> Result<Scene, Box<dyn std::error::Error>> {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/control_point.toml"),
    )?;
    Ok(Scene::from_toml_str(&text, "control_point.toml")?)
}
