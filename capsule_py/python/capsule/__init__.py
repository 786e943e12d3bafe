"""capsule: the vibro-impact capsule toolkit (Liu, Pavlovskaia, Wiercigroch, Peng 2014) from Python.

The physics and analysis are the Rust libraries the ``capsule`` command runs; every call releases
the GIL while Rust works and stops at Ctrl-C (raising :class:`Interrupted`, whose ``partial``
holds what finished). Results are dicts with the fields of the command's JSON, and NumPy arrays
for the time history, the Poincaré points and the basin labels::

    import capsule
    r = capsule.simulate(alpha=1.6, omega=1.1, gamma=0.235, beta=3.05, xi=0.05, kp=0.1)
    r["avg_progression"], r["period"], r["poincare"].shape

Scenes come from a scene file, scene text or the defaults (the paper's section-3 set), with
keyword arguments named as the command's flags (``alpha``, ``omega``, ``gamma``, ``beta``,
``delta``, ``xi``, ``kp``, ``friction``, ``mu_v``, ``v_s``, ``tau_d``, ``k_s``, ``x0``,
``periods``, ``transient``, ``method``, ``tol``, ``step``, ``name``); they are checked by the one
scene reader, and refused with its message (:class:`SceneError`).
"""

from __future__ import annotations

import json
import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _capsule
from ._capsule import Interrupted, SceneError, SimulationError

__all__ = [
    "Scene",
    "SceneError",
    "SimulationError",
    "Interrupted",
    "simulate",
    "sweep",
    "basins",
    "continue_branch",
    "floquet",
    "lyapunov",
    "identify",
    "PARAMS",
    "SCENE_KEYWORDS",
    "HISTORY_COLUMNS",
    "study",
]

__version__ = _capsule.__version__

#: Scene parameters a sweep, a basin sweep, a continuation or a study can vary.
PARAMS: Tuple[str, ...] = tuple(_capsule.params())
#: Scene keyword arguments and the scene-file key each one sets.
SCENE_KEYWORDS: Dict[str, str] = dict(_capsule.scene_keywords())
#: Columns of :func:`simulate`'s ``history`` (as ``capsule simulate --csv`` writes them).
HISTORY_COLUMNS: Tuple[str, ...] = (
    "tau", "x1", "y1", "x2", "y2", "stuck", "contact",
    "friction_force", "contact_force", "actuator_force",
)

SceneLike = Union["Scene", str, "os.PathLike[str]", None]


class Scene:
    """A validated scene: a scene file, scene text or the defaults, with keyword overrides.

    ``Scene("scenes/control_point.toml", kp=-0.1)``, ``Scene(alpha=1.5)``,
    ``Scene(text="[drive]\\nalpha = 1.5\\n")``. A bad value raises :class:`SceneError` naming
    the source, the key and the reason, e.g.
    ``defaults with keyword arguments: capsule.gamma: must be > 0 (got -1)``.
    """

    __slots__ = ("_toml", "_source")

    def __init__(self, path: Union[str, "os.PathLike[str]", None] = None, *,
                 text: Optional[str] = None, **overrides: Any) -> None:
        p = os.fspath(path) if path is not None else None
        self._toml: str = _capsule.resolve_scene(p, text, overrides)
        # what errors of later overrides name: the file, the text or the defaults
        self._source: str = p if p is not None else ("<text>" if text is not None else "defaults")

    @classmethod
    def _of(cls, toml_text: str, source: str = "defaults") -> "Scene":
        s = cls.__new__(cls)
        s._toml = toml_text
        s._source = source
        return s

    def replace(self, **overrides: Any) -> "Scene":
        """This scene with keyword overrides applied (the same rules as the constructor)."""
        return Scene._of(_capsule.resolve_scene(None, self._toml, overrides, self._source),
                         self._source)

    def to_toml(self) -> str:
        """The complete scene file (every default written out); reading it back gives this scene."""
        return self._toml

    def to_dict(self) -> Dict[str, Any]:
        """The scene as ``capsule simulate --json`` prints it under ``scene``."""
        return json.loads(_capsule.scene_json(self._toml))

    def __getitem__(self, keyword: str) -> Any:
        """A scene value by keyword (``scene["alpha"]``)."""
        key = SCENE_KEYWORDS.get(keyword)
        if key is None:
            raise KeyError(keyword)
        d = _toml_table(self._toml)
        for part in key.split("."):
            d = d[part]
        return d

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Scene) and other._toml == self._toml

    def __hash__(self) -> int:
        return hash(self._toml)

    def __repr__(self) -> str:
        d = self.to_dict()
        return (f"Scene(name={d['name']!r}, friction={d['model']['friction']!r}, "
                f"alpha={d['drive']['alpha']}, omega={d['drive']['omega']}, kp={d['control']['kp']})")

    def __reduce__(self):  # pickled as its text (Dask ships scenes to workers)
        return (Scene._of, (self._toml, self._source))


def _toml_table(text: str) -> Dict[str, Any]:
    try:
        import tomllib  # Python >= 3.11
    except ModuleNotFoundError:  # pragma: no cover
        import tomli as tomllib  # type: ignore
    return tomllib.loads(text)


def _scene(scene: SceneLike, overrides: Dict[str, Any]) -> str:
    if isinstance(scene, Scene):
        return scene.replace(**overrides).to_toml() if overrides else scene.to_toml()
    p = os.fspath(scene) if scene is not None else None
    return _capsule.resolve_scene(p, None, overrides)


def _poincare(points: Any) -> np.ndarray:
    return np.asarray(points, dtype=float).reshape(-1, 3)


def _exponents(values: Sequence[Optional[float]]) -> np.ndarray:
    # JSON null is -inf here: a direction that sticking removes (capsule_analysis::lyapunov)
    return np.array([-np.inf if v is None else v for v in values], dtype=float)


def _spectrum(ly: Optional[Dict[str, Any]]) -> Optional[Dict[str, Any]]:
    if ly is not None:
        ly["exponents"] = _exponents(ly["exponents"])
        ly["per_period"] = _exponents(ly["per_period"])
    return ly


def simulate(scene: SceneLike = None, *, samples_per_period: int = 0,
             pulse_kp: Optional[float] = None, pulse_at: Optional[int] = None,
             pulse_periods: int = 1, kp_after: Optional[float] = None,
             stability: bool = False, **overrides: Any) -> Dict[str, Any]:
    """One run of the scene: the fields of ``capsule simulate --json``.

    ``avg_progression``, ``period`` (or None), ``impacts_per_period``,
    ``backward_slips_per_period``, ``efficiency``, ``poincare`` (an ``(n, 3)`` array of
    ``[x1 - x2, y1 - y2, y1]`` at drive phase 0), ``final_state``, ``work``, ``scene``,
    ``schedule``, ``wall_time_s``; with ``stability=True`` (``--stability``) also ``floquet``
    and ``lyapunov`` (None when not computable; ``stability_note`` says why). With ``samples_per_period > 0``
    also ``history``: a dict of arrays, one per :data:`HISTORY_COLUMNS`. A gain pulse
    (``pulse_kp`` for ``pulse_periods`` periods from period ``pulse_at``, then ``kp_after``) as
    ``capsule simulate --pulse-kp``.
    """
    toml_text = _scene(scene, overrides)
    if (pulse_kp is None) != (pulse_at is None):
        raise ValueError("pulse_kp and pulse_at go together")
    pulse = None if pulse_kp is None else (float(pulse_kp), int(pulse_at), int(pulse_periods))
    text, history = _capsule.simulate(toml_text, int(samples_per_period), pulse, kp_after, stability)
    out = json.loads(text)
    out["poincare"] = _poincare(out["poincare"])
    _spectrum(out.get("lyapunov"))
    if history is not None:
        rows = np.frombuffer(history, dtype="<f8").reshape(-1, len(HISTORY_COLUMNS))
        out["history"] = {c: rows[:, i].copy() for i, c in enumerate(HISTORY_COLUMNS)}
    return out


def _sweep_columns(param: str, rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    n = len(rows)
    out: Dict[str, Any] = {"param": param, "points": list(rows)}
    out["values"] = np.array([r["value"] for r in rows], dtype=float)
    ok = [r["result"].get("Ok") for r in rows]
    out["error"] = [r["result"].get("Err") for r in rows]
    for f in ("avg_progression", "impacts_per_period", "backward_slips_per_period", "efficiency"):
        out[f] = np.array([o[f] if o else np.nan for o in ok], dtype=float)
    out["period"] = np.array([o["period"] if o and o["period"] is not None else np.nan
                              for o in ok], dtype=float)
    out["poincare"] = [_poincare(o["poincare"]) if o else np.empty((0, 3)) for o in ok]
    if n and "lyapunov" in rows[0]:
        out["lyapunov"] = np.array([_exponents(r["lyapunov"]["Ok"]["exponents"])
                                    if "Ok" in r["lyapunov"] else [np.nan] * 3 for r in rows],
                                   dtype=float).reshape(-1, 3)
    return out


def sweep(param: str, values: Sequence[float], scene: SceneLike = None, *,
          follow: bool = False, lyapunov: bool = False, **overrides: Any) -> Dict[str, Any]:
    """One parameter over ``values`` (``capsule sweep``): every value from the scene's initial
    state in parallel, or with ``follow`` each from the previous value's final state.

    Returns ``points`` (the rows of ``capsule sweep``'s JSON: ``value`` and ``result`` with
    ``Ok`` or ``Err``) and columns over the values: ``values``, ``period`` (NaN when none),
    ``avg_progression``, ``impacts_per_period``, ``backward_slips_per_period``, ``efficiency``
    (NaN where the run failed), ``error`` (None or the reason), ``poincare`` (a list of
    ``(n, 3)`` arrays) and with ``lyapunov`` an ``(n, 3)`` array of spectra. Ctrl-C raises
    :class:`Interrupted` whose ``partial`` holds the values that finished, in this form.
    """
    toml_text = _scene(scene, overrides)
    vals = [float(v) for v in np.asarray(values, dtype=float).ravel()]
    if not vals:
        raise ValueError("values: empty (give at least one value)")
    try:
        text = _capsule.sweep(toml_text, param, vals, follow, lyapunov)
    except Interrupted as e:
        if e.partial is not None:
            e.partial = _sweep_columns(param, json.loads(e.partial))
        raise
    return _sweep_columns(param, json.loads(text))


def _basins_out(text: str, labels: Optional[bytes]) -> Dict[str, Any]:
    out = json.loads(text)
    for a in out["attractors"]:
        a["poincare"] = _poincare(a["poincare"])
    g = out["grid"]
    if labels is not None:
        out["labels"] = np.frombuffer(labels, dtype="<i4").reshape(g["ny"], g["nx"]).copy()
    out["names"] = [a["label"] for a in out["attractors"]]
    return out


def basins(scene: SceneLike = None, *, grid: Tuple[int, int] = (100, 100),
           x_range: Tuple[float, float] = (-2.0, 2.0), y_range: Tuple[float, float] = (-2.0, 2.0),
           plane: str = "x1-x2,y1-y2", known_tol: float = 1e-4,
           basin_method: str = "known-cells",
           cell: Optional[float] = None, cell_hits: int = 2, cell_check: int = 200,
           **overrides: Any) -> Dict[str, Any]:
    """Basins of attraction on a grid of initial states (``capsule basins``).

    ``basin_method="known-cells"`` stops a run once it enters cells of the Poincaré section (edge
    ``cell``, default half the grid's spacing) labelled by earlier runs, ``cell_hits`` points in
    a row, and reruns ``cell_check`` of those states per state as a check (``work``, ``check``,
    ``warning``); ``basin_method="per-state"`` runs each state until it settles on its own.

    Returns ``labels``: an ``(ny, nx)`` int32 array (row 0 at the low end of ``y_range``) of
    indices into ``attractors`` (-1: the run failed, -2: not computed), ``attractors``: the
    table in legend order (``label``, ``period``, ``impacts_per_period``, ``avg_progression``,
    ``poincare`` array, ``fraction`` of the grid), ``names`` (the labels), ``grid`` and
    ``work`` as ``capsule basins --json`` prints them. The rest of the state comes from the
    scene's initial state. Ctrl-C raises :class:`Interrupted` with the summary so far.
    """
    toml_text = _scene(scene, overrides)
    nx, ny = (int(v) for v in grid)
    try:
        text, labels = _capsule.basins(toml_text, nx, ny, tuple(map(float, x_range)),
                                       tuple(map(float, y_range)), plane, float(known_tol),
                                       str(basin_method), None if cell is None else float(cell),
                                       int(cell_hits), int(cell_check))
    except Interrupted as e:
        if e.partial is not None:
            e.partial = _basins_out(e.partial, None)
        raise
    return _basins_out(text, labels)


def continue_branch(param: str, to: float, scene: SceneLike = None, *, arc_step: float = 0.01,
                    max_arc_step: float = 0.02, max_points: int = 5000,
                    **overrides: Any) -> Dict[str, Any]:
    """Continue the periodic orbit the scene settles on in ``param`` towards ``to``
    (``capsule continue``): pseudo-arclength, Newton shooting on the exact Jacobian.

    Returns the branch as ``capsule continue`` writes its JSON (``param``, ``period``,
    ``points``, ``special`` bifurcations, ``stopped``, ``closed``) plus arrays over the points:
    ``values``, ``x`` (``(n, 3)``: x1 - x2, y1, y2 at drive phase 0), ``stable``,
    ``largest_modulus``. Ctrl-C ends the branch at the next point and raises
    :class:`Interrupted` whose ``partial`` is the branch so far, in this form.
    """
    toml_text = _scene(scene, overrides)
    try:
        text = _capsule.continue_branch(toml_text, param, float(to), float(arc_step),
                                        float(max_arc_step), int(max_points))
    except Interrupted as e:
        if e.partial is not None:
            e.partial = _branch_out(e.partial)
        raise
    return _branch_out(text)


def _branch_out(text: str) -> Dict[str, Any]:
    out = json.loads(text)
    pts = out["points"]
    out["values"] = np.array([p["value"] for p in pts], dtype=float)
    out["x"] = np.array([p["x"] for p in pts], dtype=float).reshape(-1, 3)
    out["stable"] = np.array([p["stable"] for p in pts], dtype=bool)
    out["largest_modulus"] = np.array(
        [max((float(np.hypot(*m)) for m in p["multipliers"]), default=np.nan) for p in pts])
    return out


def floquet(scene: SceneLike = None, *, x: Optional[Sequence[float]] = None,
            period: Optional[int] = None, **overrides: Any) -> Dict[str, Any]:
    """Floquet multipliers (saltation matrices at every event) of the period-``period`` orbit
    through ``x = (x1 - x2, y1, y2)`` at drive phase 0; without ``x``, of the orbit the scene's
    run ends on. ``multipliers`` is an ``(n, 2)`` array of (real, imaginary) parts."""
    toml_text = _scene(scene, overrides)
    xs = None if x is None else [float(v) for v in x]
    out = json.loads(_capsule.floquet(toml_text, xs, period))
    out["multipliers"] = np.asarray(out["multipliers"], dtype=float).reshape(-1, 2)
    return out


def lyapunov(scene: SceneLike = None, **overrides: Any) -> Dict[str, Any]:
    """The Lyapunov spectrum of the scene's run (Müller's method through the events):
    ``exponents`` per unit time, largest first (``-inf``: a direction sticking removes; the
    command's JSON writes it ``null``), ``per_period``, ``largest_half_run``, ``periods``."""
    toml_text = _scene(scene, overrides)
    return _spectrum(json.loads(_capsule.lyapunov(toml_text)))


def identify(recording: Union[str, "os.PathLike[str]"], free: Sequence[str],
             scene: SceneLike = None, *, segment: Optional[Tuple[float, float]] = None,
             validate: Optional[Union[str, "os.PathLike[str]"]] = None,
             patience: Optional[int] = None, **overrides: Any) -> Dict[str, Any]:
    """A twin of the recorded device: the scene keys ``free`` (``"capsule.gamma"``, ...) fitted
    so that the scene's capsule, driven by the recorded force, reproduces the recorded
    positions; ``segment=(t0, t1)`` fits only those seconds (the rest validates), ``validate``
    another recording. The same dict as ``capsule identify --json``: ``report`` (values,
    standard errors, residual RMS, what cannot be told apart) and ``validation``. Refused
    input raises ``ValueError``, a fit that does not converge or ends at a bound
    :class:`SimulationError`."""
    toml_text = _scene(scene, overrides)
    seg = None if segment is None else (float(segment[0]), float(segment[1]))
    return json.loads(_capsule.identify(os.fspath(recording), toml_text, [str(k) for k in free],
                                        seg, None if validate is None else os.fspath(validate),
                                        patience))


def study(*args: Any, **kwargs: Any):
    """A parameter study on Dask: see :func:`capsule.parameter_study.run` (needs
    ``pip install ./capsule_py[study]``)."""
    from . import parameter_study
    return parameter_study.run(*args, **kwargs)
