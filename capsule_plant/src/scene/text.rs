//! A scene as text: read (TOML to the file's shape, its values over the defaults, validated)
//! and written back.

use super::error::{Fault, SceneError};
use super::file::RawScene;
use super::toml_reader::read_toml;
use super::types::Scene;

impl Scene {
    /// Parse and validate a scene from the bytes of a file; `file` names the source in errors.
    pub fn from_toml_bytes(bytes: &[u8], file: &str) -> Result<Self, SceneError> {
        let text = std::str::from_utf8(bytes).map_err(|_| SceneError {
            file: file.to_string(),
            key: "(file)".to_string(),
            reason: Fault::NotText,
        })?;
        Scene::from_toml_str(text, file)
    }

    /// Parse and validate a scene; `file` names the source in errors.
    pub fn from_toml_str(text: &str, file: &str) -> Result<Self, SceneError> {
        // syntax errors with their line, shape errors with their key
        let raw: RawScene = read_toml(text).map_err(|e| e.in_file(file))?;
        let scene = raw.resolve(file).map_err(|e| e.in_file(file))?;
        scene.validate().map_err(|e| e.in_file(file))?;
        Ok(scene)
    }

    /// The scene as a complete scene file (every key of its tables written out; the nodes'
    /// `[node]` table is not the scene's); reading it back gives the same scene.
    pub fn to_toml(&self) -> String {
        // every field is a plain number, string or array: serializing cannot fail
        toml::to_string(&RawScene::of(self)).unwrap_or_default()
    }
}
