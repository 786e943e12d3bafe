//! Workspace integration tests: one binary, one module per area.

mod architecture_doc;
mod attractors;
mod bad_input;
mod basin_cells;
mod cli;
mod common;
mod docs_links;
mod examples;
mod function_length;
mod hard_cases;
mod identify;
mod import_circles;
mod paper;
mod python;
mod record;
mod replay_args;
mod ros;
mod rosidl;
mod scenes;
mod solver;
mod stability;
mod type_hashes;

use capsule_plant::scene::Scene;
use std::path::PathBuf;

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// A bundled scene by file name.
pub fn scene(name: &str) -> Scene {
    let path = root().join("scenes").join(name);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    Scene::from_toml_str(&text, name).unwrap_or_else(|e| panic!("{e}"))
}
