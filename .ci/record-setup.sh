#!/usr/bin/env bash
# What the recording tests use besides Rust, installed where missing (idempotent, quiet when
# present): the reference ROS 2 MCAP readers the tests decode our files with, through their own
# ROS 2 decoders, each checked by what tests/peers uses:
#   - tests/peers/mcap_decode.py (python3 on PATH): `mcap.reader` and `mcap_ros2.decoder`
#     (PyPI mcap + mcap-ros2-support, Foxglove's reader and its ROS 2 CDR decoder) and
#     `rosbags.highlevel` (PyPI rosbags, a pure-Python rosbag2 reader)
#   - tests/peers/foxglove/decode.mjs (node): @mcap/core, @mcap/support (zstd/lz4 chunks),
#     @foxglove/rosmsg, @foxglove/rosmsg2-serialization (what the Foxglove app decodes with),
#     pinned in tests/peers/foxglove/package-lock.json, installed there with `npm ci`; Node.js
#     with ES modules and top-level await (18 or newer)
# Run before `cargo test --workspace`, after `cargo build --workspace`.
set -euo pipefail
cd "$(dirname "$0")/.."
export PIP_ROOT_USER_ACTION=ignore

apt_install() {
  echo "record-setup: apt-get install $*"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
  hash -r
}

# Python and pip
need=()
command -v python3 >/dev/null 2>&1 || need+=(python3)
python3 -m pip --version >/dev/null 2>&1 || need+=(python3-pip)
[ "${#need[@]}" -eq 0 ] || apt_install "${need[@]}"

# ROS 2 Jazzy's own rosidl (PyPI wheels): tests/peers/rosidl_type_hashes.py
py_modules="mcap.reader, mcap_ros2.decoder, rosbags.highlevel, rosidl_generator_type_description, rosidl_adapter.msg"
pkgs=("mcap>=1.2,<2" "mcap-ros2-support>=0.5,<1" "rosbags>=0.10,<1"
  "ros-rosidl-generator-type-description==4.6.6" "ros-rosidl-adapter==4.6.6"
  "ros-rosidl-parser==4.6.6" "ros-rosidl-pycommon==4.6.6")
if ! python3 -c "import $py_modules" >/dev/null 2>&1; then
  echo "record-setup: missing a module of $py_modules: pip install ${pkgs[*]}"
  python3 -m pip install --quiet --disable-pip-version-check "${pkgs[@]}" \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "${pkgs[@]}"
  python3 -c "import $py_modules" || { echo "record-setup: still cannot import $py_modules" >&2; exit 1; }
fi
echo "record-setup: ok ($(python3 -c 'import importlib.metadata as m; print(", ".join(f"{p} {m.version(p)}" for p in ("mcap", "mcap-ros2-support", "rosbags")))'))"

# Node.js 18+ and npm
node_ok() {
  command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1 \
    && [ "$(node -p 'process.versions.node.split(".")[0]')" -ge 18 ]
}
node_ok || apt_install nodejs npm
node_ok || { echo "record-setup: Node.js 18 or newer with npm needed (have $(node --version 2>&1))" >&2; exit 1; }

# the readers, as decode.mjs imports them (resolved from its folder)
fox=tests/peers/foxglove
js_modules='["@mcap/core", "@mcap/support", "@foxglove/rosmsg", "@foxglove/rosmsg2-serialization"]'
js_import_all() {
  (cd "$fox" && node --input-type=module -e "await Promise.all($js_modules.map((m) => import(m)))") \
    >/dev/null 2>&1
}
if ! js_import_all || ! npm ls --prefix "$fox" --silent >/dev/null 2>&1; then
  echo "record-setup: missing or not the locked version of $js_modules: npm ci in $fox"
  npm ci --prefix "$fox" --silent --no-audit --no-fund >/dev/null
  js_import_all || { echo "record-setup: node still cannot import $js_modules in $fox" >&2; exit 1; }
fi
echo "record-setup: ok (node $(node --version); $(cd "$fox" && npm ls --depth 0 2>/dev/null | tail -n +2 | sed 's/^[^@]*//' | tr '\n' ' '))"
