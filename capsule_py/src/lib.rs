//! `capsule._capsule`: the Python extension module of the capsule toolkit. A thin layer over
//! `capsule_plant` (scenes) and `capsule_analysis` (runs, sweeps, basins, continuation, Floquet,
//! Lyapunov): scenes cross as complete scene files (TOML), results as the JSON the `capsule`
//! command prints (one serializer, so the same fields and numbers) and large arrays as raw
//! little-endian bytes; the Python package (`capsule_py/python/capsule`) turns them into dicts
//! and NumPy arrays. Every call releases the GIL while Rust works and honours Ctrl-C.

mod calls;
mod exceptions;
mod interrupt;
mod scene;

use exceptions::{Interrupted, SceneError, SimulationError};
use pyo3::prelude::*;

/// The extension module.
#[pymodule]
fn _capsule(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<SceneError>())?;
    m.add("SimulationError", py.get_type::<SimulationError>())?;
    m.add("Interrupted", py.get_type::<Interrupted>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(scene::resolve_scene, m)?)?;
    m.add_function(wrap_pyfunction!(scene::scene_json, m)?)?;
    m.add_function(wrap_pyfunction!(scene::scene_keywords, m)?)?;
    m.add_function(wrap_pyfunction!(calls::simulate, m)?)?;
    m.add_function(wrap_pyfunction!(calls::sweep, m)?)?;
    m.add_function(wrap_pyfunction!(calls::basins, m)?)?;
    m.add_function(wrap_pyfunction!(calls::continue_branch, m)?)?;
    m.add_function(wrap_pyfunction!(calls::floquet, m)?)?;
    m.add_function(wrap_pyfunction!(calls::lyapunov, m)?)?;
    m.add_function(wrap_pyfunction!(calls::identify, m)?)?;
    m.add_function(wrap_pyfunction!(calls::params, m)?)?;
    Ok(())
}
