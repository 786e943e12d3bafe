"""Per-task overhead of a study (a benchmark that prints figures): the same 2,000 tiny points
(a 3-period simulate, about 0.1 ms of Rust work each) as 2,000 tasks of one point and as 20
tasks of 100 points, on a 2-worker LocalCluster; the difference per extra task is what one task
costs (Dask's scheduling and transfer, plus our Parquet file per batch). Dask's own share:
2,000 no-op tasks on the same cluster.

    python3 capsule_py/bench/bench_study_overhead.py STORE_DIR
"""

import pathlib
import shutil
import sys
import time
from distributed import Client, LocalCluster
from capsule import parameter_study as ps


def main():
    out = pathlib.Path(sys.argv[1])
    N = 2000
    grid = {"alpha": [0.5 + 1e-4 * i for i in range(N)]}
    with LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                      dashboard_address="127.0.0.1:0") as cluster, Client(cluster) as client:
        t0 = time.perf_counter()
        client.gather(client.map(lambda i: i, range(N), pure=False))
        noop = time.perf_counter() - t0
        walls = {}
        for batch in (1, 100):
            store = out / f"overhead_b{batch}"
            shutil.rmtree(store, ignore_errors=True)
            t0 = time.perf_counter()
            ps.run(store, grid=grid, periods=3, options={"stability": False}, batch=batch,
                   scheduler=cluster.scheduler_address)
            walls[batch] = time.perf_counter() - t0
    tasks = {1: N, 100: N // 100}
    per_task = (walls[1] - walls[100]) / (tasks[1] - tasks[100])
    print(f"{N} points as {tasks[1]} tasks: {walls[1]:.2f} s; as {tasks[100]} tasks: "
          f"{walls[100]:.2f} s")
    print(f"per-task overhead (2 workers, so about twice this per worker-second): "
          f"{1e3 * per_task:.2f} ms; Dask alone ({N} no-op tasks): {1e3 * noop / N:.2f} ms per task")


if __name__ == "__main__":  # Dask starts its workers by spawning this file anew
    main()
