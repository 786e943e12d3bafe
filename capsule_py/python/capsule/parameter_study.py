"""Parameter studies on Dask: a grid (or a list) over up to four scene parameters, each point one
`simulate`, `sweep`, `basins` or `continue_branch`, in batches on a ``dask.distributed`` cluster
(a LocalCluster by default, any running cluster by its scheduler address), the results in a
directory of Parquet files that a study resumes from after a crash.

The store (one directory)::

    STORE/study.json               what the study is (kind, options, scene, points) and its fingerprint
    STORE/parts/batch-000042.parquet   one file per finished batch, written whole by the worker
                                   that computed it (temporary name, then an atomic rename)

Why Parquet and not Zarr: a point's result is a record of scalars (progression, period, shares)
and variable-length parts (a Poincaré cycle, an attractor table, a branch, a label grid), which
is a table, not an N-d array; each batch is one immutable file written by the worker that
computed it, so no two writers ever share a chunk, no lock and no region alignment is needed,
and a crash leaves only whole files (a half-written temporary is ignored). Resuming is listing
the parts. pandas, pyarrow, Dask DataFrame, DuckDB and polars read the directory as one table
(:func:`load`).

A worker killed mid-way loses only its batch in flight, which the scheduler runs again on another
worker; a killed client loses nothing written: run the same study again and it skips the
finished points.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import pathlib
import time
from typing import Any, Callable, Dict, Iterable, List, Mapping, Optional, Sequence

import numpy as np

import capsule

#: What a study point can run.
KINDS = ("simulate", "sweep", "basins", "continue")
#: Most parameters one study varies.
MAX_PARAMS = 4
#: Default most points one study may have (raise with ``max_points``).
DEFAULT_MAX_POINTS = 100_000
#: Store format version (in study.json).
FORMAT = 1
#: Seconds to wait for a scheduler given by address before refusing it.
CONNECT_TIMEOUT_S = 5.0

# the options each kind takes (the keyword arguments of the call, besides the scene)
_OPTIONS = {
    "simulate": {"pulse_kp", "pulse_at", "pulse_periods", "kp_after", "stability"},
    "sweep": {"param", "values", "follow", "lyapunov"},
    "basins": {"grid", "x_range", "y_range", "plane", "known_tol", "basin_method", "cell", "cell_hits",
               "cell_check"},
    "continue": {"param", "to", "arc_step", "max_arc_step", "max_points"},
}
_REQUIRED = {"simulate": set(), "sweep": {"param", "values"}, "basins": set(),
             "continue": {"param", "to"}}
# points per task at most: enough work per task that the scheduler's ~1 ms per task is small
_MAX_BATCH = {"simulate": 64, "sweep": 4, "basins": 1, "continue": 2}


class StudyError(ValueError):
    """A study refused before any work started: the input named, and why."""


def study_params() -> List[str]:
    """The scene parameters a study can vary: the sweepable ones and the friction constants."""
    friction = [k for k, v in capsule.SCENE_KEYWORDS.items()
                if v.startswith("friction.") and k != "friction"]
    return list(capsule.PARAMS) + friction


# ---------------------------------------------------------------------------------------------
# the points


def _points(grid: Optional[Mapping[str, Any]], points: Optional[Sequence[Mapping[str, float]]],
            max_points: int) -> tuple:
    if (grid is None) == (points is None):
        raise StudyError("give a grid (a dict of parameter -> values) or points (a list of "
                         "dicts), one of them")
    known = study_params()
    if grid is not None:
        if not isinstance(grid, Mapping) or not grid:
            raise StudyError("grid: empty (give 1 to 4 parameters with their values)")
        names = list(grid)
        axes = []
        for name in names:
            vals = np.asarray(grid[name], dtype=float).ravel() if not isinstance(grid[name], str) \
                else None
            if vals is None:
                raise StudyError(f"grid[{name!r}]: values must be numbers, not a string")
            if vals.size == 0:
                raise StudyError(f"grid[{name!r}]: no values")
            axes.append([float(v) for v in vals])
        sizes = [len(a) for a in axes]
        n = math.prod(sizes)
        _check_names(names, known)
        if n > max_points:
            raise StudyError(f"grid: {' x '.join(map(str, sizes))} = {n} points, more than "
                             f"max_points {max_points}: coarsen the grid or raise max_points")
        rows = [list(p) for p in itertools.product(*axes)]
    else:
        if not isinstance(points, Sequence) or isinstance(points, (str, bytes)) or not points:
            raise StudyError("points: empty (give a list of dicts parameter -> value)")
        names = list(points[0])
        if not names:
            raise StudyError("points[0]: no parameters")
        _check_names(names, known)
        if len(points) > max_points:
            raise StudyError(f"points: {len(points)} points, more than max_points "
                             f"{max_points}: fewer points or raise max_points")
        rows = []
        for i, p in enumerate(points):
            if set(p) != set(names):
                raise StudyError(f"points[{i}]: parameters {sorted(p)} differ from points[0]'s "
                                 f"{sorted(names)}")
            rows.append([float(p[k]) for k in names])
    for i, row in enumerate(rows):
        for k, v in zip(names, row):
            if not math.isfinite(v):
                raise StudyError(f"{k} = {v} (point {i}): not a finite number")
    return names, rows


def _check_names(names: List[str], known: List[str]) -> None:
    if len(names) > MAX_PARAMS:
        raise StudyError(f"{len(names)} parameters ({', '.join(names)}): a study varies at most "
                         f"{MAX_PARAMS}")
    for k in names:
        if k not in known:
            raise StudyError(f"unknown parameter `{k}` (a study varies: {', '.join(known)})")
    if len(set(names)) != len(names):
        raise StudyError(f"a parameter is given twice: {', '.join(names)}")


def _check_options(kind: str, options: Mapping[str, Any]) -> Dict[str, Any]:
    if kind not in KINDS:
        raise StudyError(f"kind `{kind}`: not one of {', '.join(KINDS)}")
    opts = dict(options or {})
    extra = set(opts) - _OPTIONS[kind]
    if extra:
        raise StudyError(f"options {sorted(extra)}: not options of `{kind}` "
                         f"({', '.join(sorted(_OPTIONS[kind]))})")
    missing = _REQUIRED[kind] - set(opts)
    if missing:
        raise StudyError(f"`{kind}` needs the options {sorted(missing)}")
    if "param" in opts and opts["param"] not in capsule.PARAMS:
        raise StudyError(f"options param `{opts['param']}`: not a scene parameter "
                         f"({', '.join(capsule.PARAMS)})")
    if "values" in opts:
        opts["values"] = [float(v) for v in np.asarray(opts["values"], dtype=float).ravel()]
        if not opts["values"]:
            raise StudyError("options values: empty")
    for k in ("grid", "x_range", "y_range"):
        if k in opts:
            opts[k] = [float(v) if k != "grid" else int(v) for v in opts[k]]
    return opts


# ---------------------------------------------------------------------------------------------
# one point, one batch (these run on the workers)


def _record(kind: str, out: Dict[str, Any]) -> Dict[str, Any]:
    """The scalar columns of a point's result (the full result goes along as JSON)."""
    if kind == "simulate":
        ly = out.get("lyapunov")
        return {
            "avg_progression": out["avg_progression"],
            "period": float("nan") if out["period"] is None else float(out["period"]),
            "impacts_per_period": out["impacts_per_period"],
            "backward_slips_per_period": out["backward_slips_per_period"],
            "efficiency": out["efficiency"],
            "largest_lyapunov": float(ly["exponents"][0]) if ly else float("nan"),
        }
    if kind == "sweep":
        return {"values": len(out["values"]),
                "failed": sum(e is not None for e in out["error"]),
                "max_progression": float(np.nanmax(out["avg_progression"]))
                if np.isfinite(out["avg_progression"]).any() else float("nan")}
    if kind == "basins":
        atts = out["attractors"]
        p1 = sum(a["fraction"] for a in atts if a["period"] == 1)
        best = max(atts, key=lambda a: a["fraction"]) if atts else None
        return {"attractors": len(atts), "period1_share": p1,
                "largest_basin": best["label"] if best else "",
                "largest_share": best["fraction"] if best else 0.0,
                "failed_share": float((out["labels"] == -1).mean())}
    if kind == "continue":
        return {"branch_points": len(out["points"]), "branch_period": out["period"],
                "special_points": len(out["special"]),
                "stopped": out["stopped"] or ""}
    raise ValueError(kind)


def _jsonable(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, dict):
        return {k: _jsonable(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_jsonable(x) for x in v]
    if isinstance(v, float) and not math.isfinite(v):
        return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def run_point(kind: str, scene_toml: str, options: Mapping[str, Any]) -> Dict[str, Any]:
    """One point: the call of ``kind`` on the scene, as a record (scalars + ``result`` JSON)."""
    scene = capsule.Scene._of(scene_toml)
    opts = dict(options)
    if kind == "simulate":
        out = capsule.simulate(scene, **opts)
    elif kind == "sweep":
        out = capsule.sweep(opts.pop("param"), opts.pop("values"), scene, **opts)
        out.pop("points")
    elif kind == "basins":
        out = capsule.basins(scene, **opts)
    else:
        out = capsule.continue_branch(opts.pop("param"), opts.pop("to"), scene, **opts)
    rec = _record(kind, out)
    out.pop("scene", None)
    rec["result"] = json.dumps(_jsonable(out))
    return rec


def run_batch(store: str, batch: int, kind: str, names: List[str], ids: List[int],
              rows: List[List[float]], scene_toml: str, options: Mapping[str, Any]) -> tuple:
    """Computes a batch of points and writes STORE/parts/batch-NNNNNN.parquet whole (a temporary
    name, then an atomic rename); returns (batch, points, seconds). A point that fails is a row
    with its error; the batch is written either way."""
    import pyarrow as pa
    import pyarrow.parquet as pq
    t0 = time.perf_counter()
    recs = []
    for pid, row in zip(ids, rows):
        values = dict(zip(names, row))
        rec: Dict[str, Any] = {"point": pid, **values}
        try:
            scene = capsule.Scene._of(scene_toml).replace(**values)
            rec.update(run_point(kind, scene.to_toml(), options))
            rec["error"] = ""
        except (capsule.SceneError, capsule.SimulationError, ValueError) as e:
            rec["error"] = f"{type(e).__name__}: {e}"
        recs.append(rec)
    # every record has the same columns: the kind's, or none of them when every point failed
    columns = list(dict.fromkeys(k for r in recs for k in r))
    table = pa.Table.from_pylist([{k: r.get(k) for k in columns} for r in recs])
    parts = pathlib.Path(store) / "parts"
    final = parts / f"batch-{batch:06d}.parquet"
    tmp = parts / f".batch-{batch:06d}.{os.getpid()}.tmp"
    pq.write_table(table, tmp)
    os.replace(tmp, final)
    return batch, len(ids), time.perf_counter() - t0


# ---------------------------------------------------------------------------------------------
# the store


def _fingerprint(spec: Mapping[str, Any]) -> str:
    text = json.dumps(spec, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _check_store(store: pathlib.Path, spec: Dict[str, Any]) -> bool:
    """Whether ``store`` holds this study already; refused when it holds another one or
    something else. Creates nothing."""
    meta = store / "study.json"
    fp = _fingerprint(spec)
    if store.exists() and not store.is_dir():
        raise StudyError(f"store {store}: exists and is not a directory")
    if meta.exists():
        try:
            old = json.loads(meta.read_text())
        except (OSError, ValueError) as e:
            raise StudyError(f"store {store}: study.json unreadable ({e}): not a study store")
        if old.get("fingerprint") != fp:
            what = f"{old.get('spec', {}).get('kind')} over {old.get('spec', {}).get('params')}"
            raise StudyError(
                f"store {store}: written by another study ({what}, fingerprint "
                f"{old.get('fingerprint')}; this one is {fp}): use another directory, or "
                f"remove it to start over")
        return True
    if store.exists() and any(store.iterdir()):
        raise StudyError(f"store {store}: a non-empty directory that is not a study store "
                         "(no study.json)")
    if not store.parent.is_dir():
        raise StudyError(f"store {store}: directory {store.parent} does not exist")
    return False


def _open_store(store: pathlib.Path, spec: Dict[str, Any]) -> None:
    """Creates the store for this study unless it holds it already (checked by _check_store);
    removes temporaries a killed worker left."""
    meta = store / "study.json"
    fp = _fingerprint(spec)
    if meta.exists():
        for tmp in (store / "parts").glob(".batch-*.tmp"):
            tmp.unlink(missing_ok=True)
        return
    (store / "parts").mkdir(parents=True, exist_ok=True)
    tmp = store / ".study.json.tmp"
    tmp.write_text(json.dumps({"format": FORMAT, "fingerprint": fp, "spec": spec}, indent=1))
    os.replace(tmp, meta)


def _done_batches(store: pathlib.Path) -> set:
    parts = store / "parts"
    done = set()
    for f in parts.glob("batch-*.parquet"):
        try:
            done.add(int(f.stem.split("-")[1]))
        except ValueError:
            continue
    return done


def load(store: "os.PathLike[str] | str"):
    """The study's results as one pandas DataFrame, a row per finished point, by point index:
    the parameters, the kind's scalar columns, ``error`` ("" when the point ran) and
    ``result`` (the call's full output as JSON text)."""
    import pandas as pd
    store = pathlib.Path(store)
    if not (store / "study.json").exists():
        raise StudyError(f"store {store}: not a study store (no study.json)")
    files = sorted((store / "parts").glob("batch-*.parquet"))
    if not files:
        return pd.DataFrame()
    df = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    return df.sort_values("point").reset_index(drop=True)


def spec_of(store: "os.PathLike[str] | str") -> Dict[str, Any]:
    """What the study in ``store`` is (kind, params, points, scene, options, batch)."""
    return json.loads((pathlib.Path(store) / "study.json").read_text())["spec"]


# ---------------------------------------------------------------------------------------------
# the run


def _connect(scheduler: Optional[str], workers: int, threads_per_worker: int):
    from distributed import Client, LocalCluster
    if scheduler is None:
        cluster = LocalCluster(n_workers=workers, threads_per_worker=threads_per_worker,
                               processes=True, host="127.0.0.1", dashboard_address="127.0.0.1:0",
                               # the Rust thread pool of a sweep or basin map: one per Dask thread
                               env={"RAYON_NUM_THREADS": str(threads_per_worker)})
        return Client(cluster), cluster
    try:
        return Client(scheduler, timeout=CONNECT_TIMEOUT_S), None
    except (OSError, TimeoutError, ValueError) as e:
        raise StudyError(f"scheduler {scheduler}: does not answer within "
                         f"{CONNECT_TIMEOUT_S:g} s ({type(e).__name__}: {e})") from None


def run(store: "os.PathLike[str] | str", *, kind: str = "simulate",
        grid: Optional[Mapping[str, Any]] = None,
        points: Optional[Sequence[Mapping[str, float]]] = None,
        scene: "capsule.Scene | str | os.PathLike[str] | None" = None,
        options: Optional[Mapping[str, Any]] = None, scheduler: Optional[str] = None,
        workers: int = 2, threads_per_worker: int = 1, batch: Optional[int] = None,
        max_points: int = DEFAULT_MAX_POINTS,
        progress: Optional[Callable[[int, int], None]] = None, **overrides: Any):
    """Run a parameter study; returns its results (:func:`load`).

    ``grid={"alpha": np.linspace(0.5, 2, 16), "kp": [0, 0.05, 0.1]}`` (every combination) or
    ``points=[{"alpha": 1.5, "kp": 0.1}, ...]``, over up to four of :func:`study_params`, on
    ``scene`` (a :class:`capsule.Scene`, a scene file or the defaults, with ``overrides``); each
    point runs ``kind`` (``simulate``, ``sweep``, ``basins``, ``continue``) with ``options``
    (that call's keyword arguments, e.g. ``{"grid": (40, 40)}`` for basins). On a LocalCluster of
    ``workers`` processes (loopback only) unless ``scheduler`` names a running one
    (``tcp://host:8786``). ``batch`` points per task (default: about four tasks per Dask thread,
    at most a kind's cap). Results go to ``store`` (a directory); run the same study again to
    resume it. Everything is checked before any work starts; a bad input raises
    :class:`StudyError` naming it.
    """
    store = pathlib.Path(store)
    if not isinstance(workers, int) or not 1 <= workers <= 1024:
        raise StudyError(f"workers {workers!r}: must be a whole number from 1 to 1024")
    if not isinstance(threads_per_worker, int) or not 1 <= threads_per_worker <= 1024:
        raise StudyError(f"threads_per_worker {threads_per_worker!r}: must be 1 to 1024")
    if not isinstance(max_points, int) or max_points < 1:
        raise StudyError(f"max_points {max_points!r}: must be a whole number >= 1")
    if batch is not None and (not isinstance(batch, int) or batch < 1):
        raise StudyError(f"batch {batch!r}: must be a whole number >= 1")
    opts = _check_options(kind, options or {})
    names, rows = _points(grid, points, max_points)
    base = scene if isinstance(scene, capsule.Scene) else capsule.Scene(scene, **overrides)
    if isinstance(scene, capsule.Scene) and overrides:
        base = base.replace(**overrides)
    # every point's scene, checked now (a refused value names the point)
    for i, row in enumerate(rows):
        try:
            base.replace(**dict(zip(names, row)))
        except capsule.SceneError as e:
            raise StudyError(f"point {i} ({', '.join(f'{k} = {v}' for k, v in zip(names, row))})"
                             f": {e}") from None
    threads = workers * threads_per_worker if scheduler is None else None
    spec = {"kind": kind, "params": names, "points": rows, "scene": base.to_toml(),
            "options": opts}
    _check_store(store, spec)
    client, cluster = _connect(scheduler, workers, threads_per_worker)
    try:
        _open_store(store, spec)
        if threads is None:
            threads = max(1, sum(client.nthreads().values()))
        size = batch or max(1, min(_MAX_BATCH[kind], len(rows) // (4 * threads)))
        batches = [list(range(i, min(i + size, len(rows)))) for i in range(0, len(rows), size)]
        # the batch size is part of what a batch file holds: a resumed study keeps its own
        meta = json.loads((store / "study.json").read_text())
        if "batch" in meta:
            size = meta["batch"]
            batches = [list(range(i, min(i + size, len(rows))))
                       for i in range(0, len(rows), size)]
        else:
            meta["batch"] = size
            tmp = store / ".study.json.tmp"
            tmp.write_text(json.dumps(meta, indent=1))
            os.replace(tmp, store / "study.json")
        done = _done_batches(store)
        todo = [b for b in range(len(batches)) if b not in done]
        finished = sum(len(batches[b]) for b in done if b < len(batches))
        if progress:
            progress(finished, len(rows))
        from distributed import as_completed
        # one submission for all batches (client.map), each under a key of its own
        n_todo = len(todo)
        futures = client.map(run_batch, [str(store.resolve())] * n_todo, todo, [kind] * n_todo,
                             [names] * n_todo, [batches[b] for b in todo],
                             [[rows[i] for i in batches[b]] for b in todo],
                             [base.to_toml()] * n_todo, [opts] * n_todo,
                             key=[f"capsule-study-{meta['fingerprint']}-{b}" for b in todo],
                             pure=False, retries=2) if todo else []
        # counted as they finish, without fetching the results (the batch files are the
        # results; a round trip per result would cost milliseconds per task)
        sizes = {f.key: len(batches[b]) for f, b in zip(futures, todo)}
        for fut in as_completed(futures):
            if fut.status != "finished":
                fut.result()  # raises the task's error
            n = sizes[fut.key]
            finished += n
            if progress:
                progress(finished, len(rows))
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    missing = [b for b in range(len(batches)) if b not in _done_batches(store)]
    if missing:
        raise RuntimeError(f"store {store}: batches {missing[:10]} not written")
    return load(store)
