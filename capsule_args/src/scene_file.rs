//! Reading a scene file, once, the same way in every binary: the validated [`Scene`] and the
//! text as read (which a recording attaches).

use std::path::Path;

use capsule_plant::scene::{Fault, Scene, SceneError};
use capsule_record::SceneRecord;

use crate::node_table::NodeTable;

/// A scene file as read: the scene, the nodes' settings and the text they came from.
#[derive(Debug, Clone)]
pub struct SceneFile {
    /// The validated scene.
    pub scene: Scene,
    /// The `[node]` table, validated.
    pub node: NodeTable,
    /// The file's text, as read.
    pub text: String,
    /// The file's stem (`control_point` for `scenes/control_point.toml`): recording names.
    pub stem: String,
}

impl SceneFile {
    /// Reads and validates `path`; any problem (unreadable, not text, not TOML, a bad key) is a
    /// [`SceneError`] naming the file, the key and the reason.
    pub fn read(path: &Path) -> Result<SceneFile, SceneError> {
        let file = path.display().to_string();
        let bytes = std::fs::read(path).map_err(|e| SceneError {
            file: file.clone(),
            key: "(file)".into(),
            reason: Fault::Unreadable(e.to_string()),
        })?;
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scene".into());
        SceneFile::from_bytes(&bytes, &file, stem)
    }

    /// Reads and validates a scene's bytes (the scene, then its `[node]` table); `file` names
    /// the source in errors, `stem` the recordings.
    pub fn from_bytes(bytes: &[u8], file: &str, stem: String) -> Result<SceneFile, SceneError> {
        let scene = Scene::from_toml_bytes(bytes, file)?;
        // from_toml_bytes checked the bytes are UTF-8
        let text = String::from_utf8_lossy(bytes).into_owned();
        let node = NodeTable::from_toml_str(&text, file)?;
        Ok(SceneFile {
            scene,
            node,
            text,
            stem,
        })
    }

    /// The scene as a recording attaches it: named for the file, with the file's text.
    pub fn record(&self) -> SceneRecord {
        SceneRecord {
            name: self.stem.clone(),
            toml: self.text.clone(),
        }
    }
}
