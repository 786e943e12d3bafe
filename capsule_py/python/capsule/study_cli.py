"""``capsule-study``: a parameter study on Dask from the command line (see
:mod:`capsule.parameter_study`).

A Python entry point, not a ``capsule study`` subcommand of the Rust binary: the study runs on
Dask, a Python library, so the Rust binary would have to embed an interpreter or shell out to
one; installed with the package (``pip install ./capsule_py[study]``) it sits beside
``dask-scheduler`` and ``dask-worker``, where a Dask user looks for it.

    capsule-study STORE --kind basins --grid alpha=1.0:2.0:11 --grid kp=0,0.05,0.1 \\
        --set omega=0.95 --option grid=40,40 [--scheduler tcp://HOST:8786 | --workers 2]

Exit status: 0 done, 2 refused input (nothing started), 1 a failure while working, 130 Ctrl-C
(the finished batches are in the store: run the same command again to resume).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any, Dict, List

import numpy as np


def _values(text: str, what: str) -> List[float]:
    """``a:b:n`` (n values from a to b) or ``v1,v2,...``."""
    try:
        if ":" in text:
            a, b, n = text.split(":")
            n = int(n)
            if n < 1:
                raise ValueError
            return [float(v) for v in np.linspace(float(a), float(b), n)]
        return [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise SystemExit(_refuse(f"{what} `{text}`: expected A:B:N or V1,V2,..."))


def _refuse(msg: str) -> int:
    print(f"capsule-study: {msg}", file=sys.stderr)
    return 2


def _option(text: str) -> tuple:
    k, _, v = text.partition("=")
    if not _:
        raise SystemExit(_refuse(f"--option `{text}`: expected NAME=VALUE"))
    v = v.strip()
    if v.lower() in ("true", "false"):
        return k, v.lower() == "true"
    if "," in v or ":" in v:
        return k, _values(v, f"--option {k}") if k in ("values",) else \
            [float(x) for x in v.split(",")]
    try:
        return k, int(v)
    except ValueError:
        try:
            return k, float(v)
        except ValueError:
            return k, v


def main(argv: List[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        prog="capsule-study",
        description="A parameter study of the capsule model on Dask: every point of a grid over "
                    "up to four scene parameters runs simulate, sweep, basins or continue; the "
                    "results go to a Parquet store that the same command resumes.")
    ap.add_argument("store", help="the study's directory (created; resumed if it holds this study)")
    ap.add_argument("--kind", default="simulate", choices=["simulate", "sweep", "basins", "continue"],
                    help="what each point runs [default: simulate]")
    ap.add_argument("--grid", action="append", default=[], metavar="PARAM=A:B:N|V1,V2,...",
                    help="a parameter and its values (repeat for up to four)")
    ap.add_argument("--scene", help="scene file (TOML) the points start from [default: the "
                                    "paper's section-3 set]")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a scene keyword for every point (alpha, kp, friction, periods, ...)")
    ap.add_argument("--option", action="append", default=[], metavar="NAME=VALUE",
                    help="an option of the kind's call, e.g. grid=40,40 (basins), param=alpha "
                         "and values=0.9:2:50 (sweep), param=alpha and to=1 (continue)")
    ap.add_argument("--scheduler", metavar="ADDR",
                    help="a running Dask scheduler (tcp://host:8786) [default: a LocalCluster "
                         "on this machine, loopback only]")
    ap.add_argument("--workers", type=int, default=2,
                    help="LocalCluster worker processes [default: 2]")
    ap.add_argument("--batch", type=int, help="points per task [default: automatic]")
    ap.add_argument("--max-points", type=int, default=100_000,
                    help="refuse larger studies [default: 100000]")
    args = ap.parse_args(argv)

    import capsule
    from capsule import parameter_study as ps

    grid: Dict[str, List[float]] = {}
    for g in args.grid:
        k, sep, v = g.partition("=")
        if not sep:
            return _refuse(f"--grid `{g}`: expected PARAM=A:B:N or PARAM=V1,V2,...")
        grid[k.strip()] = _values(v, f"--grid {k}")
    overrides: Dict[str, Any] = {}
    for s in args.set:
        k, v = _option(s)
        overrides[k] = v
    options = dict(_option(o) for o in args.option)
    t0 = time.time()
    last = [0.0]

    def progress(done: int, total: int) -> None:
        now = time.time()
        if done == total or now - last[0] > 2.0:
            last[0] = now
            print(f"capsule-study: {done}/{total} points, {now - t0:.1f} s", file=sys.stderr,
                  flush=True)

    try:
        df = ps.run(args.store, kind=args.kind, grid=grid or None, scene=args.scene,
                    options=options, scheduler=args.scheduler, workers=args.workers,
                    batch=args.batch, max_points=args.max_points, progress=progress,
                    **overrides)
    except (ps.StudyError, capsule.SceneError) as e:
        return _refuse(str(e))
    except TypeError as e:  # an unknown scene keyword in --set
        return _refuse(str(e))
    except KeyboardInterrupt:
        print(f"capsule-study: interrupted; the finished batches are in {args.store} (run the "
              "same command to resume)", file=sys.stderr)
        return 130
    failed = int((df["error"] != "").sum()) if len(df) else 0
    print(json.dumps({"store": args.store, "points": len(df), "failed": failed,
                      "wall_s": round(time.time() - t0, 2)}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
