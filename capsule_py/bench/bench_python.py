"""What the Python layer costs on top of the Rust work (a benchmark that prints figures, not a
test): a 300-period simulate of the section-5 scene at k_p 0.1 (exact method) through
`capsule.simulate`, against the time the Rust side measures for the same work (`wall_time_s`:
the run and its stability analysis). The difference is scene resolution, JSON both ways, the
NumPy arrays, the GIL hand-over and the worker thread. Best and median of N calls.

    python3 capsule_py/bench/bench_python.py [N]
"""

import statistics
import sys
import time

import capsule

N = int(sys.argv[1]) if len(sys.argv) > 1 else 200
scene = capsule.Scene("scenes/control_point.toml", kp=0.1)


def measure(**kw):
    total, rust = [], []
    for _ in range(N):
        t0 = time.perf_counter()
        r = capsule.simulate(scene, **kw)
        total.append(time.perf_counter() - t0)
        rust.append(r["wall_time_s"])
    over = [t - w for t, w in zip(total, rust)]
    return min(total), statistics.median(total), statistics.median(rust), statistics.median(over)


for label, kw in [("simulate, 300 periods + Floquet + Lyapunov", {}),
                  ("simulate, 300 periods, no stability", {"stability": False})]:
    best, med, rust, over = measure(**kw)
    print(f"{label}: Python call best {1e3 * best:.2f} ms, median {1e3 * med:.2f} ms; "
          f"Rust work median {1e3 * rust:.2f} ms; Python layer median {1e3 * over:.3f} ms "
          f"= {100 * over / med:.1f} % of the call")
