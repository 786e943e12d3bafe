"""The bindings against the `capsule` command: the same scene gives the same numbers (bit for bit:
one library, one serializer), the same refusals with the same messages, arrays of the right shape,
the GIL released and Ctrl-C honoured."""

import json
import math
import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import capsule

CONTROL = "scenes/control_point.toml"


def default_sigint():
    """In the child: SIGINT back to its default. A shell starts background jobs with SIGINT
    ignored, and Python then installs no KeyboardInterrupt handler: the Ctrl-C tests would
    depend on how the test command was launched."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def interrupt(script, after_s):
    """Runs SCRIPT in a child Python, sends it SIGINT after AFTER_S seconds; returns its exit
    status, stdout, stderr and how long it took to stop. The child never outlives the test."""
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=default_sigint)
    try:
        time.sleep(after_s)
        t_sig = time.time()
        p.send_signal(signal.SIGINT)
        out, err = p.communicate(timeout=60)
        return p.returncode, out, err, time.time() - t_sig
    finally:
        if p.poll() is None:
            p.kill()
            p.wait()


def same(a, b, path="$"):
    """Deep equality of the command's JSON and the bindings' output (arrays as lists; the
    command's null for -inf exponents)."""
    if isinstance(b, np.ndarray):
        b = [None if (isinstance(v, float) and math.isinf(v)) else v for v in b.tolist()] \
            if b.ndim == 1 else b.tolist()
    if isinstance(a, dict):
        assert isinstance(b, dict), path
        assert set(a) <= set(b), f"{path}: missing {set(a) - set(b)}"
        for k in a:
            same(a[k], b[k], f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), f"{path}: {a!r} vs {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{path}[{i}]")
    else:
        assert a == b, f"{path}: command {a!r}, bindings {b!r}"


@pytest.mark.parametrize("args,kw", [
    ((CONTROL, "--kp", "-0.1"), dict(scene=CONTROL, kp=-0.1)),
    ((CONTROL, "--kp", "0.1", "--stability"), dict(scene=CONTROL, kp=0.1, stability=True)),
    (("--alpha", "1.5", "--x0", "-1.5,0,0,0"), dict(alpha=1.5, x0=[-1.5, 0, 0, 0])),
    (("--friction", "stribeck", "--alpha", "1.3", "--kp", "1", "--periods", "60"),
     dict(friction="stribeck", alpha=1.3, kp=1, periods=60)),
])
def test_simulate_gives_the_commands_json(cli_json, args, kw):
    if args[0].endswith(".toml"):
        args = ("--scene",) + args
    want = cli_json("simulate", *args, "--json")
    scene = kw.pop("scene", None)
    got = capsule.simulate(scene, **kw)
    want.pop("wall_time_s")
    got.pop("wall_time_s")
    same(want, got)
    # the same fields both ways: the stability analysis runs in both or in neither
    assert set(want) == set(got)
    assert ("floquet" in got) == ("--stability" in args)
    assert got["poincare"].shape == (want["measured_periods"], 3)


def test_a_gain_pulse_is_the_commands(cli_json):
    want = cli_json("simulate", "--alpha", "1.5", "--x0", "-1.5,0,0,0", "--pulse-kp", "0.3",
                    "--pulse-at", "300", "--kp-after", "0", "--periods", "600", "--json")
    got = capsule.simulate(alpha=1.5, x0=[-1.5, 0, 0, 0], pulse_kp=0.3, pulse_at=300, kp_after=0,
                           periods=600)
    for k in ("wall_time_s",):
        want.pop(k), got.pop(k)
    same(want, got)


def test_the_time_history_is_the_commands_csv(cli, tmp_path):
    csv = tmp_path / "run.csv"
    cli("simulate", "--scene", CONTROL, "--periods", "20", "--csv", csv)
    want = np.loadtxt(csv, delimiter=",", skiprows=1)
    h = capsule.simulate(CONTROL, periods=20, samples_per_period=100)["history"]
    got = np.column_stack([h[c] for c in capsule.HISTORY_COLUMNS])
    assert got.shape == want.shape == (20 * 100 + 1, 10)
    # the CSV prints shortest round-trip decimals: equal bit for bit
    assert np.array_equal(got, want)


def test_keywords_resolve_as_the_commands_flags(cli):
    flags = ["--friction", "stribeck", "--alpha", "1.3", "--kp", "1", "--periods", "30",
             "--tol", "1e-9", "--x0", "0.1,0,0,0"]
    want = cli("simulate", *flags, "--print-scene").stdout
    got = capsule.Scene(friction="stribeck", alpha=1.3, kp=1, periods=30, tol=1e-9,
                        x0=(0.1, 0, 0, 0))
    assert capsule._toml_table(got.to_toml()) == capsule._toml_table(want)
    assert got["transient"] == 20 and got["method"] == "adaptive"
    # with a scene file: the file, then the keywords, as --scene FILE --flags
    want = cli("simulate", "--scene", CONTROL, "--kp", "-0.1", "--periods", "90",
               "--print-scene").stdout
    got = capsule.Scene(CONTROL, kp=-0.1, periods=90)
    assert capsule._toml_table(got.to_toml()) == capsule._toml_table(want)


def bad_scenes(root):
    return sorted((root / "tests" / "fixtures" / "scenes_bad").glob("*.toml"))


def test_every_bad_scene_is_refused_with_the_commands_message(root, cli):
    files = bad_scenes(root)
    assert len(files) > 20
    for f in files:
        rel = f.relative_to(root)
        p = cli("simulate", "--scene", rel, check=False)
        assert p.returncode == 2, rel
        with pytest.raises(capsule.SceneError) as e:
            capsule.Scene(rel)
        assert str(e.value) in p.stderr, f"{rel}: {e.value} vs {p.stderr}"


@pytest.mark.parametrize("kw,message", [
    (dict(gamma=-1), "defaults with keyword arguments: capsule.gamma: must be > 0 (got -1)"),
    (dict(alpha=float("nan")), "drive.alpha: must be a finite number (got NaN)"),
    (dict(friction="teflon"), "friction.law: unknown law `teflon`"),
    (dict(mu_v=0.2), "friction.mu_v: not used by law `coulomb`"),
    (dict(periods=10, transient=10), "horizon.transient: must be less than horizon.periods = 10"),
    (dict(periods=2.5), "horizon.periods: must be a whole number"),
    (dict(method="exact", friction="stribeck"), "solver.method: exact needs a piecewise-linear"),
    (dict(alpha="fast"), "drive.alpha: invalid type"),
    (dict(x0=[1, 2, 3]), "initial.state: must hold exactly 4 numbers"),
])
def test_bad_keywords_are_refused_before_work_with_the_scene_readers_message(kw, message):
    with pytest.raises(capsule.SceneError) as e:
        capsule.simulate(**kw)
    assert message in str(e.value)


def test_unknown_keywords_and_bad_arguments_are_refused():
    with pytest.raises(TypeError, match="unknown scene keyword `alhpa`"):
        capsule.Scene(alhpa=1.5)
    with pytest.raises(ValueError, match="param `zeta`: not a scene parameter"):
        capsule.sweep("zeta", [1.0])
    with pytest.raises(ValueError, match="values: empty"):
        capsule.sweep("alpha", [])
    with pytest.raises(ValueError, match="grid"):
        capsule.basins(grid=(0, 10))
    with pytest.raises(ValueError, match="x_range"):
        capsule.basins(grid=(4, 4), x_range=(float("nan"), 1))
    with pytest.raises(ValueError, match="plane"):
        capsule.basins(grid=(4, 4), plane="x3,y1")
    with pytest.raises(ValueError, match="pulse_at"):
        capsule.simulate(periods=10, pulse_kp=0.3, pulse_at=20)
    with pytest.raises(capsule.SimulationError, match="not periodic"):
        capsule.continue_branch("alpha", 0.7, alpha=0.6)


def test_sweep_gives_the_commands_rows(cli, tmp_path):
    out = tmp_path / "s"
    cli("sweep", "--param", "alpha", "--from", "0.9", "--to", "1.5", "--steps", "7",
        "--lyapunov", "--periods", "150", "--out", out)
    want = json.loads((tmp_path / "s.json").read_text())
    got = capsule.sweep("alpha", np.linspace(0.9, 1.5, 7), lyapunov=True, periods=150)
    assert got["points"] == want
    assert got["values"].shape == (7,) and got["lyapunov"].shape == (7, 3)
    ok = [w["result"]["Ok"] for w in want]
    assert np.array_equal(got["avg_progression"], [o["avg_progression"] for o in ok])
    assert [None if np.isnan(p) else int(p) for p in got["period"]] == [o["period"] for o in ok]


def test_basins_give_the_commands_table_and_labels(cli, tmp_path):
    out = tmp_path / "b"
    p = cli("basins", "--alpha", "1.5", "--grid", "12,10", "--json", "--out", out, "--threads", "2")
    want = json.loads(p.stdout)
    full = json.loads((tmp_path / "b.json").read_text())[0]
    got = capsule.basins(alpha=1.5, grid=(12, 10))
    assert got["labels"].shape == (10, 12) and got["labels"].dtype == np.int32
    assert [a["label"] for a in want["attractors"]] == got["names"]
    for a, b in zip(want["attractors"], got["attractors"]):
        assert a["fraction"] == b["fraction"] and a["period"] == b["period"]
        assert np.allclose(a["poincare"], b["poincare"], atol=1e-4)
    # the same label in every cell (the command's labels are names, rows from low y)
    names = np.array(got["names"], dtype=object)[got["labels"]]
    assert names.tolist() == full["labels"]
    assert (got["labels"] >= 0).all()


def test_basins_method_keyword_is_the_commands_flag(cli):
    for method, flag in [("per-state", ["--basin-method", "per-state"]), ("known-cells", [])]:
        want = json.loads(cli("basins", "--alpha", "1.5", "--grid", "14,12", "--json",
                              *flag).stdout)
        got = capsule.basins(alpha=1.5, grid=(14, 12), basin_method=method)
        assert got["basin_method"]["name"] == method == want["basin_method"]["name"]
        assert got["names"] == [a["label"] for a in want["attractors"]]
        assert [a["fraction"] for a in got["attractors"]] == \
            [a["fraction"] for a in want["attractors"]]
        assert got["work"]["periods_per_state"] > 0
    # a grid large enough that later runs meet the cells the first batch (64 runs) labelled
    cells = capsule.basins(alpha=1.5, grid=(40, 40), basin_method="known-cells", cell=0.05)
    assert cells["basin_method"]["size"] == 0.05 and cells["work"]["known_cell"] > 800
    assert cells["work"]["periods_per_state"] < 20
    assert "check" in cells and cells["check"]["sampled"] > 0
    with pytest.raises(ValueError, match="cell: 0.5 is coarser than the grid's spacing"):
        capsule.basins(alpha=1.5, grid=(14, 12), cell=0.5)
    with pytest.raises(ValueError, match="only the known-cells method has cells"):
        capsule.basins(alpha=1.5, grid=(14, 12), basin_method="per-state", cell=0.1)
    with pytest.raises(ValueError, match="basin_method \"fast\""):
        capsule.basins(alpha=1.5, grid=(14, 12), basin_method="fast")


def test_continuation_gives_the_commands_branch(cli, tmp_path):
    out = tmp_path / "c"
    cli("continue", "--alpha", "2.0", "--param", "alpha", "--to", "1.2", "--out", out)
    want = json.loads((tmp_path / "c.json").read_text())
    got = capsule.continue_branch("alpha", 1.2, alpha=2.0)
    same(want, got)
    assert got["x"].shape == (len(want["points"]), 3)
    assert len(got["special"]) >= 1


def test_floquet_and_lyapunov_are_those_simulate_reports():
    r = capsule.simulate(CONTROL, kp=0.1, stability=True)
    f = capsule.floquet(CONTROL, kp=0.1)
    assert np.array_equal(f["multipliers"], np.asarray(r["floquet"]["multipliers"]))
    assert f["largest_modulus"] < 1.0
    ly = capsule.lyapunov(CONTROL, kp=0.1)
    assert np.array_equal(ly["exponents"], r["lyapunov"]["exponents"])
    # a stuck direction is -inf (the command's JSON null), and the stable orbit's exponents < 0
    assert (ly["exponents"] < 0).all()


def test_the_gil_is_released_while_rust_works():
    # a long run on a thread while this thread keeps counting: a held GIL would stop the count
    done = threading.Event()
    result = {}

    def work():
        result["r"] = capsule.simulate(alpha=1.5, periods=30000)
        done.set()

    t = threading.Thread(target=work)
    t0 = time.perf_counter()
    t.start()
    ticks = 0
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    t.join()
    wall = time.perf_counter() - t0
    assert result["r"]["period"] is not None
    assert wall > 0.05, f"the run took only {wall:.3f} s: too short to tell"
    # at least a third of the sleeps that fit in the run happened during it
    assert ticks > wall / 0.001 / 3, f"{ticks} ticks in {wall:.3f} s"


SCRIPT = textwrap.dedent("""
    import sys, time, capsule
    t0 = time.time()
    try:
        capsule.sweep("alpha", [0.5 + 1e-6 * i for i in range(200000)], periods=300)
    except capsule.Interrupted as e:
        print("partial", len(e.partial["values"]), round(time.time() - t0, 2), flush=True)
        sys.exit(3)
    print("finished", flush=True)
""")


def test_ctrl_c_stops_a_long_sweep_with_what_finished():
    code, out, err, took = interrupt(SCRIPT, 3.0)
    assert code == 3, out + err
    n = int(out.split()[1])
    assert 0 < n < 200000, out
    assert took < 30, f"Ctrl-C took {took:.1f} s to stop the sweep"


def test_ctrl_c_stops_a_long_simulate():
    script = ("import capsule\ntry:\n    capsule.simulate(alpha=0.6, periods=4000000)\n"
              "except capsule.Interrupted as e:\n    print('interrupted', e)\n    raise SystemExit(3)\n")
    code, out, err, took = interrupt(script, 2.0)
    assert code == 3 and "interrupted" in out, out + err
    assert took < 5


def test_scenes_pickle_as_their_text():
    import pickle
    s = capsule.Scene(CONTROL, kp=0.05)
    t = pickle.loads(pickle.dumps(s))
    assert t == s and t["kp"] == 0.05



@pytest.mark.parametrize("call,check", [
    ("capsule.basins(alpha=1.5, kp=0.05, grid=(400, 400))",
     "e.partial['grid']['pending'] > 0 and len(e.partial['attractors']) > 0"),
    ("capsule.continue_branch('alpha', 0.95, alpha=2.0, arc_step=1e-5, max_arc_step=1e-5, "
     "max_points=1000000)",
     "len(e.partial['values']) > 1 and 'interrupt' in (e.partial['stopped'] or '')"),
])
def test_ctrl_c_stops_basins_and_continuation_with_what_finished(call, check):
    script = (f"import capsule\ntry:\n    {call}\nexcept capsule.Interrupted as e:\n"
              f"    assert {check}, e.partial\n    print('interrupted')\n    raise SystemExit(3)\n")
    code, out, err, took = interrupt(script, 3.0)
    assert code == 3 and "interrupted" in out, out + err
    assert took < 30


def test_identify_gives_the_commands_json(root, cli, tmp_path):
    """capsule.identify returns what `capsule identify --json` prints (issue 37): the fitted
    value, the report and the validation on what --segment left out; a bad key is refused
    with the command's message."""
    rec = tmp_path / "run.mcap"
    cli("simulate", "--scene", CONTROL, "--kp", "0.2", "--periods", "40", "--record", rec)
    text = (root / CONTROL).read_text()
    assert "gamma = 0.235" in text
    nominal = tmp_path / "nominal.toml"
    nominal.write_text(text.replace("gamma = 0.235", "gamma = 0.25"))
    want = json.loads(cli("identify", "--recording", rec, "--scene", nominal, "--free",
                          "capsule.gamma", "--segment", "0:2.7", "--json").stdout)
    got = capsule.identify(str(rec), ["capsule.gamma"], str(nominal), segment=(0, 2.7))
    want.pop("wall_time_s")
    got.pop("wall_time_s")
    same(want, got)
    assert set(want) == set(got)
    # the recording's own capsule, from a nominal scene 6 % off
    gamma = got["report"]["parameters"][0]["value"]
    assert abs(gamma / 0.235 - 1) < 0.01, got["report"]
    assert got["validated_on"] == "left out by --segment", got
    bad = cli("identify", "--recording", rec, "--scene", nominal, "--free", "capsule.mass",
              check=False)
    assert bad.returncode == 2, bad.stderr
    with pytest.raises(ValueError) as e:
        capsule.identify(str(rec), ["capsule.mass"], str(nominal))
    assert "`capsule.mass` is not a scene key" in str(e.value)
    assert str(e.value) in bad.stderr, (str(e.value), bad.stderr)
