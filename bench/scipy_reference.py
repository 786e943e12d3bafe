#!/usr/bin/env python3
"""An independent, event-driven SciPy implementation of the capsule model (Coulomb or viscous
friction, harmonic drive, position feedback k_p |x2 - x1|), for side-by-side runs with capsule.

It is what a user would write instead: `solve_ivp` (DOP853) restarted at every located event
(contact on/off, feedback kink, break-away, slip end), with the same switching rules as the Rust
simulator. It shares no code with capsule, so agreement is a check of both.

    python3 bench/scipy_reference.py --kp 0.1 --rtol 1e-10            # section-5 scene
    python3 bench/scipy_reference.py --kp 0.1 --capsule target/release/capsule   # side by side

Prints one JSON object per run (time and average progression) and, with --capsule, the same
for capsule and the ratio of their times. Not part of the test command (needs SciPy).
"""
import argparse
import json
import math
import subprocess
import time

import numpy as np
from scipy.integrate import solve_ivp


def simulate(p, rtol, atol):
    """300 periods (200 transient) from rest; returns the average progression per measured
    period, the efficiency (eq. 4: progression over the actuator's work on the mass) and the
    number of solve_ivp calls."""
    gamma, beta, delta, xi, mu_v = p["gamma"], p["beta"], p["delta"], p["xi"], p["mu_v"]
    alpha, omega, kp = p["alpha"], p["omega"], p["kp"]
    fb = 1.0
    period = 2.0 * math.pi / omega
    state = np.zeros(5)  # x1, y1, x2, y2, actuator work
    phase = 0  # 0 = stick, +1/-1 = slip direction
    contact = False
    sigma = 1.0
    t = 0.0

    def capsule_force(s, contact_on):
        z = s[0] - s[2]
        f = z + 2.0 * xi * (s[1] - s[3])
        if contact_on:
            f += beta * (z - delta)
        return f

    def rhs(tt, s):
        z = s[0] - s[2]
        fa = alpha * math.cos(omega * tt) + kp * sigma * z
        f = capsule_force(s, contact)
        if phase == 0:
            return [s[1], fa - f, 0.0, 0.0, fa * s[1]]
        return [s[1], fa - f, s[3], (f - phase - mu_v * s[3]) / gamma, fa * s[1]]

    def events():
        evs = []
        if beta > 0.0:
            def ev_contact(tt, s):
                return (s[0] - s[2]) - delta
            ev_contact.terminal = True
            ev_contact.direction = -1.0 if contact else 1.0
            evs.append(("contact", ev_contact))
        if kp != 0.0:
            def ev_kink(tt, s):
                return s[0] - s[2]
            ev_kink.terminal = True
            ev_kink.direction = -sigma
            evs.append(("kink", ev_kink))
        if phase == 0:
            def ev_up(tt, s):
                return capsule_force(s, contact) - fb
            ev_up.terminal = True
            ev_up.direction = 1.0
            def ev_down(tt, s):
                return -capsule_force(s, contact) - fb
            ev_down.terminal = True
            ev_down.direction = 1.0
            evs += [("break+", ev_up), ("break-", ev_down)]
        else:
            def ev_slip_end(tt, s):
                return s[3]
            ev_slip_end.terminal = True
            ev_slip_end.direction = -float(phase)
            evs.append(("slip_end", ev_slip_end))
        return evs

    x2_start = 0.0
    w_start = 0.0
    calls = 0
    for n in range(300):
        if n == 200:
            x2_start = state[2]
            w_start = state[4]
        t_end = (n + 1) * period
        while t < t_end - 1e-12:
            evs = events()
            sol = solve_ivp(rhs, (t, t_end), state, method="DOP853", rtol=rtol, atol=atol,
                            events=[e for _, e in evs])
            calls += 1
            hit = None
            for (name, _), te, ye in zip(evs, sol.t_events, sol.y_events):
                if len(te) and te[0] > t + 1e-13 and (hit is None or te[0] < hit[1]):
                    hit = (name, te[0], ye[0])
            if hit is None:
                t, state = t_end, sol.y[:, -1].copy()
                break
            name, t, state = hit[0], hit[1], hit[2].copy()
            if name == "contact":
                contact = not contact
            elif name == "kink":
                sigma = -sigma
            elif name in ("break+", "break-"):
                phase = 1 if name == "break+" else -1
            elif name == "slip_end":
                state[3] = 0.0
                f = capsule_force(state, contact)
                phase = 0 if abs(f) <= fb else (1 if f > 0 else -1)
    progression = state[2] - x2_start
    return progression / 100.0, progression / (state[4] - w_start), calls


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for name, default in [("gamma", 0.235), ("beta", 3.05), ("delta", 0.02), ("xi", 0.05),
                          ("mu_v", 0.0), ("alpha", 1.6), ("omega", 1.1), ("kp", 0.1)]:
        ap.add_argument("--" + name.replace("_", "-"), type=float, default=default)
    ap.add_argument("--rtol", type=float, default=1e-10)
    ap.add_argument("--atol", type=float, default=1e-12)
    ap.add_argument("--capsule", help="path of the capsule binary, to run the same scene")
    a = ap.parse_args()
    p = {k: getattr(a, k) for k in ["gamma", "beta", "delta", "xi", "mu_v", "alpha", "omega", "kp"]}
    t0 = time.perf_counter()
    prog, eff, calls = simulate(p, a.rtol, a.atol)
    wall = time.perf_counter() - t0
    out = {"impl": "scipy DOP853", "rtol": a.rtol, "avg_progression": prog, "efficiency": eff,
           "wall_s": wall, "solve_ivp_calls": calls, "params": p}
    print(json.dumps(out))
    if a.capsule:
        law = ["--friction", "viscous", "--mu-v", str(a.mu_v)] if a.mu_v > 0 else ["--friction", "coulomb"]
        cmd = [a.capsule, "simulate", "--json", "--gamma", str(a.gamma), "--beta", str(a.beta),
               "--delta", str(a.delta), "--xi", str(a.xi), "--alpha", str(a.alpha),
               "--omega", str(a.omega), "--kp", str(a.kp)] + law
        best = math.inf
        for _ in range(10):
            r = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            best = min(best, r["wall_time_s"])
        exact = r["avg_progression"]
        print(json.dumps({"impl": "capsule exact", "avg_progression": exact,
                          "efficiency": r["efficiency"], "wall_s": best,
                          "difference": abs(exact - prog),
                          "efficiency_difference": abs(r["efficiency"] - eff),
                          "speedup": wall / best}))
        # equal error: the loosest adaptive tolerance whose error (against capsule's exact
        # result) is no larger than SciPy's
        scipy_err = abs(prog - exact)
        for tol in [1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12]:
            cmd_a = cmd + ["--method", "adaptive", "--tol", str(tol)]
            best_a = math.inf
            for _ in range(3):
                ra = json.loads(subprocess.run(cmd_a, check=True, capture_output=True, text=True).stdout)
                best_a = min(best_a, ra["wall_time_s"])
            err = abs(ra["avg_progression"] - exact)
            if err <= scipy_err:
                print(json.dumps({"impl": "capsule adaptive at equal error", "tol": tol,
                                  "error": err, "scipy_error": scipy_err, "wall_s": best_a,
                                  "speedup": wall / best_a}))
                break


if __name__ == "__main__":
    main()
