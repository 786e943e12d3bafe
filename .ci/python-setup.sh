#!/usr/bin/env bash
# The Python package and what its tests use, installed where missing (idempotent), each checked
# by what the tests import or run:
#   - python3 (3.9 or newer) with pip, and cargo (maturin compiles the extension);
#   - capsule_py/tests: numpy, dask.distributed, pyarrow, pandas (parameter studies), pytest;
#     tomllib or, before Python 3.11, tomli (the package reads scene text with it);
#   - capsule_py/tests/test_notebook.py: matplotlib, nbclient, nbformat and the `python3`
#     Jupyter kernel (ipykernel);
#   - maturin (the build backend, used without build isolation);
# then `pip install ./capsule_py`, which builds the extension with maturin in the workspace's
# target/, and checks that the package imports. The cargo profile is maturin's (release) unless
# CAPSULE_PY_PROFILE names another: CI passes `dev`, whose crates `cargo build --workspace` has
# just compiled (the numerical ones optimised), instead of compiling them all again for release.
# Run after `cargo build --workspace` (the tests compare against target/debug/capsule).
set -euo pipefail
cd "$(dirname "$0")/.."
export PIP_ROOT_USER_ACTION=ignore

need=()
command -v python3 >/dev/null 2>&1 || need+=(python3)
python3 -m pip --version >/dev/null 2>&1 || need+=(python3-pip)
if [ "${#need[@]}" -gt 0 ]; then
  echo "python-setup: apt-get install ${need[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  hash -r
fi
python3 -c 'import sys; sys.exit(sys.version_info < (3, 9))' \
  || { echo "python-setup: Python 3.9 or newer needed (have $(python3 --version 2>&1))" >&2; exit 1; }
command -v cargo >/dev/null 2>&1 \
  || { echo "python-setup: cargo needed to build the extension (https://rustup.rs)" >&2; exit 1; }

pip_install() {
  python3 -m pip install --quiet --disable-pip-version-check "$@" \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "$@"
}

# module to import | the requirement that provides it
requirements=(
  "maturin|maturin>=1.9,<2"
  "numpy|numpy>=1.22"
  "dask.distributed|dask[distributed]>=2023.1"
  "pyarrow|pyarrow>=12"
  "pandas|pandas>=1.5"
  "pytest|pytest>=7"
  "matplotlib|matplotlib>=3.5"
  "nbclient|nbclient>=0.7"
  "nbformat|nbformat>=5"
  "ipykernel|ipykernel>=6"
)
python3 -c 'import sys; sys.exit(sys.version_info < (3, 11))' || requirements+=("tomli|tomli>=1.1")
missing() {
  local r
  for r in "${requirements[@]}"; do
    python3 -c "import ${r%%|*}" >/dev/null 2>&1 || echo "${r#*|}"
  done
  # the notebook test starts the kernel named python3
  python3 -c 'from jupyter_client.kernelspec import KernelSpecManager as K; K().get_kernel_spec("python3")' \
    >/dev/null 2>&1 || echo "ipykernel>=6"
}
mapfile -t pkgs < <(missing | sort -u)
if [ "${#pkgs[@]}" -gt 0 ]; then
  echo "python-setup: pip install ${pkgs[*]}"
  pip_install "${pkgs[@]}"
  mapfile -t still < <(missing | sort -u)
  if [ "${#still[@]}" -gt 0 ]; then
    echo "python-setup: still missing after pip install: ${still[*]}" >&2
    exit 1
  fi
fi

t0=$(date +%s)
# --no-build-isolation: maturin from above, no second download; the build is incremental
if [ -n "${CAPSULE_PY_PROFILE:-}" ]; then
  export MATURIN_PEP517_ARGS="--profile $CAPSULE_PY_PROFILE"
fi
pip_install --no-build-isolation --force-reinstall --no-deps ./capsule_py
echo "python-setup: ok (capsule $(python3 -c 'import capsule; print(capsule.__version__)') built (${CAPSULE_PY_PROFILE:-release} profile) and installed in $(( $(date +%s) - t0 )) s; $(python3 -c 'import importlib.metadata as m; print(", ".join(f"{p} {m.version(p)}" for p in ("numpy", "dask", "distributed", "pyarrow", "pytest", "nbclient")))'))"
