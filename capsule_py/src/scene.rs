//! Scenes from Python: a scene file or scene text, and keyword arguments named as the `capsule`
//! command's flags (`alpha`, `kp`, `friction`, `periods`, ...). The keywords are written into the
//! scene's TOML at their keys and the result is read back by the one scene reader
//! ([`Scene::from_toml_str`]), so a keyword is checked exactly as the same key in a scene file is
//! and refused with the same message, naming the source (`defaults with keyword arguments`), the
//! key and the reason.

use crate::exceptions::SceneError;
use capsule_args::scene_file::SceneFile;
use capsule_plant::model::FRICTION_CONSTANTS;
use capsule_plant::scene::Scene;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};

/// Keyword -> scene key, besides the friction constants (keyword = key in `[friction]`).
const KEYWORDS: [(&str, &str); 15] = [
    ("name", "name"),
    ("friction", "friction.law"),
    ("alpha", "drive.alpha"),
    ("omega", "drive.omega"),
    ("gamma", "capsule.gamma"),
    ("beta", "capsule.beta"),
    ("delta", "capsule.delta"),
    ("xi", "capsule.xi"),
    ("kp", "control.kp"),
    ("x0", "initial.state"),
    ("periods", "horizon.periods"),
    ("transient", "horizon.transient"),
    ("method", "solver.method"),
    ("tol", "solver.tol"),
    ("step", "solver.step"),
];

/// Every scene keyword with its scene key, the friction constants included.
fn keywords() -> Vec<(String, String)> {
    KEYWORDS
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .chain(
            FRICTION_CONSTANTS
                .iter()
                .map(|c| (c.key.to_string(), format!("friction.{}", c.key))),
        )
        .collect()
}

/// The scene keywords and the scene key each sets, in order.
#[pyfunction]
pub fn scene_keywords() -> Vec<(String, String)> {
    keywords()
}

/// A scene refused, as the Python exception.
pub fn refused(e: capsule_plant::scene::SceneError) -> PyErr {
    SceneError::new_err(e.to_string())
}

/// Reads a scene file's bytes as every binary does (`capsule_args::scene_file`): the scene,
/// then its `[node]` table, so a bad file is refused with the same message.
fn read(bytes: &[u8], file: &str) -> PyResult<Scene> {
    SceneFile::from_bytes(bytes, file, String::new())
        .map(|f| f.scene)
        .map_err(refused)
}

/// Parses a complete scene (as [`resolve_scene`] returns it).
pub fn parse(toml_text: &str) -> PyResult<Scene> {
    Scene::from_toml_str(toml_text, "scene").map_err(refused)
}

/// The resolved scene as a complete scene file: `path` (a file) or `text` (scene TOML, named
/// `source` in errors, `<text>` by default) or the defaults, with `overrides` (keyword -> value)
/// applied as the `capsule` command applies its flags.
#[pyfunction]
#[pyo3(signature = (path=None, text=None, overrides=None, source=None))]
pub fn resolve_scene(
    path: Option<std::path::PathBuf>,
    text: Option<String>,
    overrides: Option<&Bound<'_, PyDict>>,
    source: Option<String>,
) -> PyResult<String> {
    let (base, source) = match (&path, text) {
        (Some(_), Some(_)) => {
            return Err(PyTypeError::new_err(
                "give a scene file or scene text, not both",
            ))
        }
        (Some(p), None) => {
            let file = p.display().to_string();
            let bytes = std::fs::read(p).map_err(|e| {
                refused(capsule_plant::scene::SceneError {
                    file: file.clone(),
                    key: "(file)".into(),
                    reason: capsule_plant::scene::Fault::Unreadable(e.to_string()),
                })
            })?;
            (read(&bytes, &file)?, file)
        }
        (None, Some(t)) => {
            let source = source.unwrap_or_else(|| "<text>".to_string());
            (read(t.as_bytes(), &source)?, source)
        }
        (None, None) => (Scene::default(), "defaults".to_string()),
    };
    let Some(overrides) = overrides.filter(|d| !d.is_empty()) else {
        return Ok(base.to_toml());
    };
    let mut doc: toml::Table = base
        .to_toml()
        .parse()
        .map_err(|e| SceneError::new_err(format!("{source}: {e}")))?;
    let known = keywords();
    let mut given = Vec::new();
    for (k, v) in overrides.iter() {
        let k: String = k.extract()?;
        let Some((_, key)) = known.iter().find(|(kw, _)| *kw == k) else {
            let names: Vec<&str> = known.iter().map(|(kw, _)| kw.as_str()).collect();
            return Err(PyTypeError::new_err(format!(
                "unknown scene keyword `{k}` (known: {})",
                names.join(", ")
            )));
        };
        given.push((k, key.clone(), to_toml(&v, key)?));
    }
    let has = |kw: &str| given.iter().any(|(k, _, _)| k == kw);
    // the command line's rules: another law takes its own paper constants and (unless a method
    // is given) its most accurate method; periods alone scale the transient with them
    if has("friction") {
        if let Some(toml::Value::Table(f)) = doc.get_mut("friction") {
            f.retain(|k, _| k == "law");
        }
        if !has("method") {
            if let Some(toml::Value::Table(s)) = doc.get_mut("solver") {
                s.remove("method");
            }
        }
    }
    if has("periods") && !has("transient") {
        if let Some((_, _, toml::Value::Integer(p))) = given.iter().find(|(k, _, _)| k == "periods")
        {
            if let Ok(p) = u32::try_from(*p) {
                let t = base.horizon.with_periods(p).transient;
                given.push((
                    "transient".into(),
                    "horizon.transient".into(),
                    toml::Value::Integer(t.into()),
                ));
            }
        }
    }
    for (_, key, value) in given {
        set(&mut doc, &key, value);
    }
    let text = toml::to_string(&doc).map_err(|e| SceneError::new_err(e.to_string()))?;
    let scene = Scene::from_toml_str(&text, &format!("{source} with keyword arguments"))
        .map_err(refused)?;
    Ok(scene.to_toml())
}

/// The scene as JSON (as `capsule simulate --json` prints it under `scene`).
#[pyfunction]
pub fn scene_json(toml_text: &str) -> PyResult<String> {
    serde_json::to_string(&parse(toml_text)?).map_err(|e| SceneError::new_err(e.to_string()))
}

/// `value` at the dotted `key` of `doc`, making the table if missing.
fn set(doc: &mut toml::Table, key: &str, value: toml::Value) {
    match key.split_once('.') {
        None => {
            doc.insert(key.to_string(), value);
        }
        Some((table, rest)) => {
            let entry = doc
                .entry(table.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            if !entry.is_table() {
                *entry = toml::Value::Table(toml::Table::new());
            }
            if let toml::Value::Table(t) = entry {
                set(t, rest, value);
            }
        }
    }
}

/// A Python value as TOML (the scene reader then judges it as it would in a file): numbers,
/// booleans, strings, and sequences of them.
fn to_toml(v: &Bound<'_, PyAny>, key: &str) -> PyResult<toml::Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(toml::Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return match v.extract::<i64>() {
            Ok(i) => Ok(toml::Value::Integer(i)),
            // beyond i64: as a float, which the reader refuses or accepts by its range
            Err(_) => Ok(toml::Value::Float(v.extract()?)),
        };
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(toml::Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(toml::Value::String(v.extract()?));
    }
    // NumPy scalars and other numbers
    if let Ok(f) = v.extract::<f64>() {
        return Ok(toml::Value::Float(f));
    }
    if let Ok(items) = v.try_iter() {
        let mut out = Vec::new();
        for item in items {
            out.push(to_toml(&item?, key)?);
        }
        return Ok(toml::Value::Array(out));
    }
    Err(PyTypeError::new_err(format!(
        "{key}: cannot be a {} (a number, a string or a list of numbers)",
        v.get_type().name()?
    )))
}
