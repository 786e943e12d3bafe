//! The exceptions the extension raises (a module of their own: the calls and the scene
//! reader raise them, and the module's entry point registers them).

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
