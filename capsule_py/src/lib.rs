//! `capsule._capsule`: the Python extension module of the capsule toolkit. A thin layer over
//! `capsule_plant` (scenes) and `capsule_analysis` (runs, sweeps, basins, continuation, Floquet,
//! Lyapunov): scenes cross as complete scene files (TOML), results as the JSON the `capsule`
//! command prints (one serializer, so the same fields and numbers) and large arrays as raw
//! little-endian bytes; the Python package (`capsule_py/python/capsule`) turns them into dicts
//! and NumPy arrays. Every call releases the GIL while Rust works and honours Ctrl-C.

mod calls;
mod interrupt;
mod scene;

use pyo3::prelude::*;

pyo3::create_exception!(
    _capsule,
    SceneError,
    pyo3::exceptions::PyValueError,
    "A scene refused: the source (file or keyword arguments), the key and the reason, as the \
     `capsule` command says it."
);
pyo3::create_exception!(
    _capsule,
    SimulationError,
    pyo3::exceptions::PyRuntimeError,
    "A run that failed while working (diverged, Zeno, no periodic start, ...)."
);
pyo3::create_exception!(
    _capsule,
    Interrupted,
    pyo3::exceptions::PyKeyboardInterrupt,
    "Ctrl-C stopped the work; `partial` holds what finished (JSON text, or None)."
);

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
