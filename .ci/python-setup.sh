#!/usr/bin/env bash
# The Python package and what its tests need, installed if missing (idempotent): NumPy, Dask
# (distributed) and pyarrow for parameter studies, pytest, and matplotlib + nbclient + ipykernel
# for the notebook; then `pip install ./capsule_py`, which builds the extension with maturin in the
# workspace's target/ (release profile: the physics compiled once, without the ROS crates).
# Run after `cargo build --workspace` (the tests compare against target/debug/capsule).
set -euo pipefail
cd "$(dirname "$0")/.."
export PIP_ROOT_USER_ACTION=ignore

pip_install() {
  python3 -m pip install --quiet --disable-pip-version-check "$@" \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "$@"
}

pkgs=("maturin>=1.9,<2" "numpy>=1.22" "dask[distributed]>=2023.1" "pyarrow>=12" "pandas>=1.5"
      "pytest>=7" "matplotlib>=3.5" "nbclient>=0.7" "nbformat>=5" "ipykernel>=6")
if ! python3 -c "import maturin, numpy, dask.distributed, pyarrow, pandas, pytest, matplotlib, nbclient, nbformat, ipykernel" >/dev/null 2>&1; then
  echo "python-setup: pip install ${pkgs[*]}"
  pip_install "${pkgs[@]}"
fi
t0=$(date +%s)
# --no-build-isolation: maturin from above, no second download; the build is incremental
pip_install --no-build-isolation --force-reinstall --no-deps ./capsule_py
echo "python-setup: ok (capsule $(python3 -c 'import capsule; print(capsule.__version__)') built and installed in $(( $(date +%s) - t0 )) s; $(python3 -c 'import importlib.metadata as m; print(", ".join(f"{p} {m.version(p)}" for p in ("numpy", "dask", "distributed", "pyarrow", "pytest", "nbclient")))'))"
