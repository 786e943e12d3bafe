#!/usr/bin/env bash
# The capsule demo: the paper's section-5 control point (Coulomb friction, alpha 1.6, omega 1.1,
# delta 0.02, xi 0.05, beta 3.05, gamma 0.235) closed-loop through ROS 2 in lock-step, DDS on
# loopback only. The controller starts FORWARD (k_p = +0.2), switches to BACKWARD (k_p = -0.2)
# and then OFF (drive only) through /capsule_controller/set_mode, each switch scheduled at a sim
# time so the run is reproducible; each segment's mean progression per drive period is printed.
#
#   launch_scripts/demo.sh [--rmw dds|zenoh] [--separate] [--secure KEYSTORE] [SCENE]
#                          [PERIODS_PER_SEGMENT]   (defaults: dds scenes/control_point.toml 60)
#
# Plant and controller run composed in one process (capsule_container, in-process state and
# force); --separate runs each as its own process, as before (capsule_launch.sh --separate).
# --secure KEYSTORE: every node secured with its SROS2 enclave (capsule_launch.sh --secure; make
# the keystore with launch_scripts/capsule_keystore.sh create KEYSTORE).
# --rmw zenoh: the same run over Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp, a router on
# 127.0.0.1:7447 started by capsule_launch.sh unless one answers), plant and controller as
# separate processes, not recorded (recording is not on Zenoh yet); the binaries must be built
# with `cargo build -p capsule_nodes --features zenoh`. docs/ros.md, Zenoh.
# The run is recorded to runs/demo-<UTC time>/capsule_<scene>_<time>.mcap and summarised with
# `capsule record info` at the end.
#
# Build first: cargo build --workspace (or set CAPSULE_BIN to a directory with the binaries).
set -u
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$here/.."
usage() { sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; }
case "${1:-}" in -h|--help) usage; exit 0 ;; esac
secure=() separate=() rmw=dds
if [ "${1:-}" = --rmw ]; then
  case "${2:-}" in dds|zenoh) rmw="$2"; shift 2 ;;
    *) echo "demo: --rmw '${2:-}': dds or zenoh" >&2; usage >&2; exit 2 ;; esac
fi
if [ "${1:-}" = --separate ]; then separate=(--separate); shift; fi
if [ "${1:-}" = --secure ]; then
  [ $# -ge 2 ] || { echo "demo: --secure needs a KEYSTORE" >&2; usage >&2; exit 2; }
  secure=(--secure "$2"); shift 2
fi
if [ $# -gt 2 ]; then echo "demo: at most two arguments" >&2; usage >&2; exit 2; fi
scene="${1:-$root/scenes/control_point.toml}"
periods="${2:-60}"
[ -r "$scene" ] && [ -f "$scene" ] || { echo "demo: cannot read scene file '$scene'" >&2; usage >&2; exit 2; }
# PERIODS_PER_SEGMENT: a whole number from 3 (a third is left to settle) to 100000
if ! [[ "$periods" =~ ^[0-9]{1,6}$ ]] || [ "$periods" -lt 3 ] || [ "$periods" -gt 100000 ]; then
  echo "demo: PERIODS_PER_SEGMENT '$periods': must be a whole number from 3 to 100000" >&2
  usage >&2
  exit 2
fi
periods=$(( 10#$periods ))
settle=$(( periods / 3 ))
bin="${CAPSULE_BIN:-$root/target/debug}"
export CAPSULE_BIN="$bin"
# loopback only unless the caller decided otherwise
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"
export ROS_LOCALHOST_ONLY="${ROS_LOCALHOST_ONLY:-1}"

[ -x "$bin/capsule_ros" ] || { echo "demo: $bin/capsule_ros not built (cargo build --workspace)" >&2; exit 2; }
rmw_args=()
if [ "$rmw" = zenoh ]; then
  [ ${#secure[@]} -eq 0 ] || { echo "demo: --rmw zenoh --secure: SROS2 secures DDS only; refusing to run unsecured" >&2; exit 2; }
  [ -x "$bin/capsule_zenohd" ] || { echo "demo: --rmw zenoh: $bin/capsule_zenohd not built: the nodes need Zenoh: cargo build -p capsule_nodes --features zenoh" >&2; exit 2; }
  export RMW_IMPLEMENTATION=rmw_zenoh_cpp
  separate=(--separate) rmw_args=(--rmw zenoh --no-record)
fi
# sim end time = 3 segments of the drive period, read from the scene by the tool itself
until_s=$("$bin/capsule_ros" period --scene "$scene" --periods $(( 3 * periods ))) || exit 2

record_dir="${CAPSULE_RECORD_DIR:-runs}/demo-$(date -u +%Y%m%dT%H%M%SZ)"
record=(--record-dir "$record_dir")
[ "$rmw" = zenoh ] && record=()
echo "demo: $scene$([ "$rmw" = zenoh ] && echo ', on Zenoh'), lock-step$([ ${#separate[@]} -gt 0 ] && echo ', separate processes' || echo ', composed'), ${periods} drive periods per segment (first ${settle} not measured), until t = ${until_s} s"
"$here/capsule_launch.sh" --scene "$scene" --pacing lockstep --until-s "$until_s" --mode forward \
  ${record[@]+"${record[@]}"} ${rmw_args[@]+"${rmw_args[@]}"} \
  ${secure[@]+"${secure[@]}"} ${separate[@]+"${separate[@]}"} \
  --with "'$bin/capsule_ros' demo --scene '$scene' --segments forward:$periods,backward:$periods,off:$periods --settle-periods $settle"
rc=$?
if [ "$rmw" = zenoh ]; then
  echo
  echo "not recorded: recording is not on Zenoh yet"
  exit $rc
fi
recording=$(ls "$record_dir"/*.mcap 2>/dev/null | head -n 1)
if [ -n "$recording" ]; then
  echo
  echo "recorded: $recording"
  "$bin/capsule" record info "$recording" || rc=1
else
  echo "demo: no recording found in $record_dir" >&2
  rc=1
fi
exit $rc
