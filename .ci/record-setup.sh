#!/usr/bin/env bash
# What the recording tests need besides Rust, installed if missing (idempotent, quiet when
# present): python3 and the reference ROS 2 MCAP readers from PyPI that the tests decode our
# files with, through their own ROS 2 decoders:
#   - mcap + mcap-ros2-support (Foxglove's reader and its ROS 2 CDR decoder)
#   - rosbags (pure-Python rosbag2 reader: AnyReader)
# and Foxglove's own TypeScript readers (what the Foxglove app decodes with), pinned in
# tests/peers/foxglove/package-lock.json and installed there with `npm ci`:
#   - @mcap/core, @mcap/support (zstd/lz4 chunks), @foxglove/rosmsg,
#     @foxglove/rosmsg2-serialization
# Run before `cargo test --workspace`, after `cargo build --workspace`.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v python3 >/dev/null 2>&1; then
  echo "record-setup: apt-get install python3 python3-pip"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3 python3-pip >/dev/null
fi

pkgs=("mcap>=1.2,<2" "mcap-ros2-support>=0.5,<1" "rosbags>=0.10,<1")
if ! python3 -c "import mcap, mcap_ros2.decoder, rosbags.highlevel" >/dev/null 2>&1; then
  echo "record-setup: pip install ${pkgs[*]}"
  python3 -m pip install --quiet --disable-pip-version-check "${pkgs[@]}" \
    || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages "${pkgs[@]}"
fi
echo "record-setup: ok ($(python3 -c 'import importlib.metadata as m; print(", ".join(f"{p} {m.version(p)}" for p in ("mcap", "mcap-ros2-support", "rosbags")))'))"

if ! command -v node >/dev/null 2>&1 || ! command -v npm >/dev/null 2>&1; then
  echo "record-setup: apt-get install nodejs npm"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq nodejs npm >/dev/null
fi
fox=tests/peers/foxglove
if ! npm ls --prefix "$fox" --silent >/dev/null 2>&1; then
  echo "record-setup: npm ci in $fox"
  npm ci --prefix "$fox" --silent --no-audit --no-fund >/dev/null
fi
echo "record-setup: ok (node $(node --version); $(cd "$fox" && npm ls --depth 0 2>/dev/null | tail -n +2 | sed 's/^[^@]*//' | tr '\n' ' '))"
