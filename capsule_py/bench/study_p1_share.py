"""Beyond the paper: the period-1 basin share over the (alpha, k_p) plane at the section-3 set
(Coulomb friction, omega 0.95), a basin map per point, as a Dask study; and how it scaled with
one and two LocalCluster workers. Writes docs/figures/p1_share.png and prints the figures that
docs/studies.md quotes.

    python3 capsule_py/bench/study_p1_share.py STORE_DIR [GRID]   # GRID: states per side (20)
"""

import json
import pathlib
import shutil
import sys
import time
import numpy as np
import capsule
from capsule import parameter_study as ps
import matplotlib
import matplotlib.pyplot as plt


def main():
    out = pathlib.Path(sys.argv[1])
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    ALPHA = np.round(np.linspace(0.9, 2.0, 12), 3)
    KP = [-0.1, -0.05, 0.0, 0.05, 0.1, 0.15, 0.2]
    grid = {"alpha": ALPHA, "kp": KP}
    walls = {}
    for workers in (1, 2):
        store = out / f"p1_share_w{workers}"
        shutil.rmtree(store, ignore_errors=True)
        t0 = time.perf_counter()
        df = ps.run(store, kind="basins", grid=grid, options={"grid": (n, n)}, workers=workers,
                    batch=1)
        walls[workers] = time.perf_counter() - t0
        print(f"{workers} worker(s): {len(df)} maps of {n} x {n} in {walls[workers]:.1f} s")
    states = len(ALPHA) * len(KP) * n * n
    print(f"speed-up 2 vs 1 worker: {walls[1] / walls[2]:.2f}x; {states} initial states; "
          f"{1e3 * walls[1] / states:.2f} ms per state on one worker")
    work = [json.loads(r)["work"] for r in df["result"]]
    print(f"periods integrated: {sum(w['periods'] for w in work)}; Rust wall summed over maps "
          f"{sum(w['wall_s'] for w in work):.1f} s")
    share = df.pivot(index="kp", columns="alpha", values="period1_share")
    print(share.round(2).to_string())

    matplotlib.use("Agg")

    fig, ax = plt.subplots(figsize=(8, 4.2), constrained_layout=True)
    im = ax.imshow(share.values, origin="lower", aspect="auto", cmap="viridis", vmin=0, vmax=1,
                   extent=(ALPHA[0] - 0.05, ALPHA[-1] + 0.05, -0.125, 0.225))
    ax.set_yticks(KP)
    ax.set_xlabel("alpha (drive amplitude)")
    ax.set_ylabel("k_p (feedback gain)")
    for i, kp in enumerate(KP):
        for j, a in enumerate(ALPHA):
            v = share.values[i, j]
            ax.text(a, kp, f"{100 * v:.0f}", ha="center", va="center", fontsize=7,
                    color="white" if v < 0.6 else "black")
    fig.colorbar(im, ax=ax, label="share of [-2, 2]^2 ending on a period-1 orbit")
    ax.set_title(f"Period-1 basin share, Coulomb, section-3 set ({n} x {n} starts per point)")
    dest = pathlib.Path(__file__).resolve().parents[2] / "docs" / "figures" / "p1_share.png"
    fig.savefig(dest, dpi=130)
    print(f"wrote {dest}")


if __name__ == "__main__":  # Dask starts its workers by spawning this file anew
    main()
