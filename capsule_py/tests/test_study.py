"""Parameter studies on a real Dask cluster: refusals before work starts, a worker process killed
mid-way (the study completes with every point), a killed client (the same study resumes,
skipping the batches written)."""

import json
import os
import pathlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import capsule
from capsule import parameter_study as ps

distributed = pytest.importorskip("distributed")


def wait_for(cond, timeout, what):
    t0 = time.time()
    while not cond():
        if time.time() - t0 > timeout:
            pytest.fail(f"{what}: not within {timeout} s")
        time.sleep(0.05)


def parts(store):
    return sorted((pathlib.Path(store) / "parts").glob("batch-*.parquet"))


@pytest.mark.parametrize("kw,message", [
    (dict(grid={"zeta": [1, 2]}), "unknown parameter `zeta`"),
    (dict(grid={"alpha": [1], "kp": [0], "omega": [1], "gamma": [1], "beta": [1]}),
     "5 parameters (alpha, kp, omega, gamma, beta): a study varies at most 4"),
    (dict(grid={}), "grid: empty"),
    (dict(grid={"alpha": []}), "grid['alpha']: no values"),
    (dict(grid={"alpha": np.zeros(1000), "kp": np.zeros(1000)}),
     "grid: 1000 x 1000 = 1000000 points, more than max_points 100000"),
    (dict(points=[]), "points: empty"),
    (dict(grid={"alpha": [1.0, float("nan")]}), "alpha = nan (point 1): not a finite number"),
    (dict(grid={"gamma": [1.0, -1.0]}),
     "point 1 (gamma = -1.0): defaults with keyword arguments: capsule.gamma: must be > 0"),
    (dict(grid={"alpha": [1.0]}, kind="bifurcate"), "kind `bifurcate`: not one of"),
    (dict(grid={"alpha": [1.0]}, kind="sweep"), "`sweep` needs the options ['param', 'values']"),
    (dict(grid={"alpha": [1.0]}, kind="basins", options={"gird": (4, 4)}),
     "options ['gird']: not options of `basins`"),
    (dict(grid={"alpha": [1.0]}, workers=0), "workers 0"),
])
def test_bad_input_is_refused_before_work_naming_it(tmp_path, kw, message):
    store = tmp_path / "s"
    with pytest.raises(ps.StudyError) as e:
        ps.run(store, **kw)
    assert message in str(e.value)
    assert not store.exists(), "a refused study created its store"


def test_a_scheduler_that_does_not_answer_is_refused_quickly(tmp_path):
    t0 = time.time()
    with pytest.raises(ps.StudyError, match=r"scheduler tcp://127.0.0.1:9: does not answer"):
        ps.run(tmp_path / "s", grid={"alpha": [1.0]}, scheduler="tcp://127.0.0.1:9")
    assert time.time() - t0 < 30
    assert not (tmp_path / "s").exists()


def test_a_store_of_another_study_is_refused(tmp_path):
    store = tmp_path / "s"
    ps.run(store, grid={"alpha": [1.0, 1.5]}, periods=30, workers=1)
    with pytest.raises(ps.StudyError, match=r"store .*: written by another study \(simulate"):
        ps.run(store, grid={"alpha": [1.0, 1.6]}, periods=30, workers=1)
    with pytest.raises(ps.StudyError, match="written by another study"):
        ps.run(store, grid={"alpha": [1.0, 1.5]}, periods=31, workers=1)
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(ps.StudyError, match="not a study store"):
        ps.run(other, grid={"alpha": [1.0]}, workers=1)


def test_a_study_gives_the_bindings_numbers_for_every_kind(tmp_path):
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster:
        addr = cluster.scheduler_address
        df = ps.run(tmp_path / "sim", grid={"alpha": [1.2, 1.5], "kp": [0.0, 0.1]},
                    scheduler=addr, periods=90)
        assert list(df["point"]) == [0, 1, 2, 3]
        for _, row in df.iterrows():
            want = capsule.simulate(alpha=row["alpha"], kp=row["kp"], periods=90)
            assert row["avg_progression"] == want["avg_progression"]
            got = json.loads(row["result"])
            assert np.array_equal(np.asarray(got["poincare"]), want["poincare"])
        b = ps.run(tmp_path / "bas", kind="basins", grid={"kp": [0.0, 0.1]}, alpha=1.5,
                   options={"grid": (6, 6), "basin_method": "per-state"}, scheduler=addr)
        want = capsule.basins(alpha=1.5, kp=0.1, grid=(6, 6), basin_method="per-state")
        assert json.loads(b.loc[1, "result"])["basin_method"]["name"] == "per-state"
        got = json.loads(b.loc[1, "result"])
        assert np.array_equal(np.asarray(got["labels"]), want["labels"])
        assert b.loc[1, "period1_share"] == sum(a["fraction"] for a in want["attractors"]
                                                if a["period"] == 1)
        s = ps.run(tmp_path / "sw", kind="sweep", grid={"kp": [0.0]}, scheduler=addr,
                   options={"param": "alpha", "values": [1.4, 1.8]}, periods=60)
        assert s.loc[0, "values"] == 2 and s.loc[0, "failed"] == 0
        c = ps.run(tmp_path / "co", kind="continue", grid={"kp": [0.0]}, alpha=2.0,
                   scheduler=addr, options={"param": "alpha", "to": 1.5})
        assert c.loc[0, "branch_points"] > 3 and c.loc[0, "error"] == ""


def test_a_worker_killed_mid_way_loses_no_point(tmp_path):
    store = tmp_path / "s"
    n = 48
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address="127.0.0.1:0") as cluster, \
            distributed.Client(cluster) as client:
        result = {}

        def study():
            try:
                result["df"] = ps.run(store, grid={"alpha": np.linspace(1.0, 2.0, n)},
                                      periods=3000, scheduler=cluster.scheduler_address,
                                      batch=2, options={"stability": False})
            except BaseException as e:  # reported below
                result["error"] = e

        t = threading.Thread(target=study)
        t.start()
        wait_for(lambda: len(parts(store)) >= 2, 120, "the first batches")
        pids = client.run(os.getpid)
        victim = sorted(pids.values())[0]
        os.kill(victim, signal.SIGKILL)
        written_at_kill = len(parts(store))
        t.join(timeout=300)
        assert not t.is_alive(), "the study did not finish"
        assert "error" not in result, result.get("error")
    assert written_at_kill < n // 2, "the worker was killed after the study had finished"
    df = result["df"]
    assert list(df["point"]) == list(range(n)), "a point is missing or twice"
    assert (df["error"] == "").all()
    assert len(parts(store)) == n // 2


STUDY = [sys.executable, "-m", "capsule.study_cli", "--grid", "alpha=1.0:2.0:40",
         "--set", "periods=3000", "--option", "stability=false", "--workers", "2",
         "--batch", "2"]


def test_a_killed_client_resumes_skipping_what_was_written(tmp_path):
    store = tmp_path / "s"
    p = subprocess.Popen(STUDY[:3] + [str(store)] + STUDY[3:], start_new_session=True,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wait_for(lambda: len(parts(store)) >= 3, 120, "the first batches")
    finally:
        # the client and its LocalCluster (its own process group): a crash of the whole run
        os.killpg(p.pid, signal.SIGKILL)
        p.wait(timeout=30)
    time.sleep(0.5)
    before = {f.name: f.stat().st_mtime_ns for f in parts(store)}
    assert 3 <= len(before) < 20, before
    r = subprocess.run(STUDY[:3] + [str(store)] + STUDY[3:], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["points"] == 40
    first = [line for line in r.stderr.splitlines() if "points" in line][0]
    assert first.startswith(f"capsule-study: {2 * len(before)}/40 points"), first
    after = {f.name: f.stat().st_mtime_ns for f in parts(store)}
    assert len(after) == 20
    for name, t in before.items():
        assert after[name] == t, f"{name} was computed again"
    df = ps.load(store)
    assert list(df["point"]) == list(range(40))


def test_the_command_line_refuses_bad_input_with_status_2(tmp_path):
    r = subprocess.run([sys.executable, "-m", "capsule.study_cli", str(tmp_path / "s"),
                        "--grid", "zeta=1,2"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "unknown parameter `zeta`" in r.stderr
    r = subprocess.run([sys.executable, "-m", "capsule.study_cli", str(tmp_path / "s"),
                        "--grid", "alpha=1,2", "--set", "gamma=-1"], capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 2 and "capsule.gamma: must be > 0" in r.stderr
