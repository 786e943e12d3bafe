#!/usr/bin/env python3
"""`capsule simulate --json` against the compiled CVODE reference (bench/cvode_reference.c), timed
as whole processes in alternating pairs, and checked for agreement first.

    cc -O2 -o target/cvode_reference bench/cvode_reference.c \\
       -lsundials_cvode -lsundials_nvecserial -lm
    cargo build --release -p capsule_cli
    python3 bench/cvode_pairs.py                      # section-5 scene, 41 pairs
    python3 bench/cvode_pairs.py --kp 0.1 --pairs 101 --cpu 1
    python3 bench/cvode_pairs.py --also /bin/true --also "target/release/capsule --version"

Each pair runs the reference, then capsule (the order alternates from pair to pair), each
started with posix_spawn and waited for, its stdout going to /dev/null; the time of a run is the
wall time from spawn to exit, and its CPU time the user + system time the kernel accounts to it
(wait4; steadier than the wall time on a loaded host). Prints one JSON object: the agreement of
the two results (the progression per period, efficiency, final state, Poincare points), the
median and best times, and the ratios of the medians. Standard library only.
"""
import argparse
import json
import os
import statistics
import subprocess
import time

SCENE = "scenes/control_point.toml"


def spawn_time(argv, cpu):
    """Wall and CPU time of one run of argv (stdout and stderr to /dev/null), in seconds."""
    if cpu is not None:
        argv = ["taskset", "-c", str(cpu)] + argv
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        actions = [(os.POSIX_SPAWN_DUP2, devnull, 1), (os.POSIX_SPAWN_DUP2, devnull, 2)]
        t0 = time.perf_counter()
        pid = os.posix_spawnp(argv[0], argv, os.environ, file_actions=actions)
        _, status, usage = os.wait4(pid, 0)
        wall = time.perf_counter() - t0
    finally:
        os.close(devnull)
    if status != 0:
        raise SystemExit(f"{argv} failed (status {status})")
    return wall, usage.ru_utime + usage.ru_stime


def largest_difference(a, b):
    """Largest absolute difference of two equally shaped nested lists of numbers."""
    if isinstance(a, list):
        if len(a) != len(b):
            return float("inf")
        return max((largest_difference(x, y) for x, y in zip(a, b)), default=0.0)
    return abs(a - b)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--capsule", default="target/release/capsule")
    ap.add_argument("--reference", default="target/cvode_reference")
    ap.add_argument("--kp", type=float, default=0.0, help="gain (the scene's is 0)")
    ap.add_argument("--rtol", type=float, default=1e-13, help="CVODE's relative tolerance")
    ap.add_argument("--method", default="adams", choices=["adams", "bdf"])
    ap.add_argument("--pairs", type=int, default=41)
    ap.add_argument("--cpu", type=int, help="pin both to this CPU (taskset)")
    ap.add_argument("--capsule-flag", action="append", default=[],
                    help="an extra flag for capsule (repeatable), e.g. --capsule-flag=--stability")
    ap.add_argument("--also", action="append", default=[], metavar="COMMAND",
                    help="also time this command line (split on spaces; repeatable) once per "
                         "pair, right after a run of the reference as capsule is in every other "
                         "pair: what a process costs before any work (the floor)")
    a = ap.parse_args()
    capsule = [a.capsule, "simulate", "--json", "--scene", SCENE, "--kp", repr(a.kp)]
    capsule += a.capsule_flag
    reference = [a.reference, "--kp", repr(a.kp), "--rtol", repr(a.rtol), "--method", a.method]

    got = json.loads(subprocess.run(capsule, check=True, capture_output=True, text=True).stdout)
    ref = json.loads(subprocess.run(reference, check=True, capture_output=True, text=True).stdout)
    fs = ["x1", "y1", "x2", "y2"]
    agreement = {
        "progression_capsule": got["avg_progression"],
        "progression_cvode": ref["avg_progression"],
        "progression": abs(got["avg_progression"] - ref["avg_progression"]),
        "efficiency": abs(got["efficiency"] - ref["efficiency"]),
        "final_state": largest_difference([got["final_state"][k] for k in fs],
                                          [ref["final_state"][k] for k in fs]),
        "poincare": largest_difference(got["poincare"], ref["poincare"]),
        "same_period": got["period"] == ref["period"],
        "same_impacts_per_period": got["impacts_per_period"] == ref["impacts_per_period"],
        "same_backward_slips_per_period":
            got["backward_slips_per_period"] == ref["backward_slips_per_period"],
    }

    times = {"cvode": [], "capsule": []}
    cpu = {"cvode": [], "capsule": []}
    also = {c: ([], []) for c in a.also}
    for i in range(a.pairs):
        order = [("cvode", reference), ("capsule", capsule)]
        for name, argv in order if i % 2 == 0 else reversed(order):
            wall, used = spawn_time(argv, a.cpu)
            times[name].append(wall)
            cpu[name].append(used)
        for c, (walls, used) in also.items():
            # each right after a run of the reference, as capsule is in every other pair
            spawn_time(reference, a.cpu)
            wall, u = spawn_time(c.split(), a.cpu)
            walls.append(wall)
            used.append(u)
    med = {k: statistics.median(v) for k, v in times.items()}
    cpu_med = {k: statistics.median(v) for k, v in cpu.items()}
    ratios = [r / c for r, c in zip(times["cvode"], times["capsule"])]
    print(json.dumps({
        "scene": SCENE, "kp": a.kp, "reference": ref["impl"], "rtol": a.rtol,
        "capsule_flags": a.capsule_flag, "pairs": a.pairs, "cpu": a.cpu,
        "agreement": agreement,
        "median_s": med, "best_s": {k: min(v) for k, v in times.items()},
        "ratio_of_medians": med["cvode"] / med["capsule"],
        "median_pair_ratio": statistics.median(ratios),
        "cpu_median_s": cpu_med,
        "cpu_ratio_of_medians": cpu_med["cvode"] / cpu_med["capsule"],
        "also_median_s": {c: {"wall": statistics.median(w), "cpu": statistics.median(u)}
                          for c, (w, u) in also.items()},
        "reference_work": ref["work"], "capsule_work": got["work"],
    }, indent=2))


if __name__ == "__main__":
    main()
