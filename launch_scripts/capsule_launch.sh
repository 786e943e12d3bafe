#!/usr/bin/env bash
# Start the capsule graph for a scene: any extra processes (--with), then plant and controller
# composed in one process (capsule_container: in-process state and force, DDS copies for the
# rest of the graph); with --separate, controller, recorder, extras, then the plant, each a
# process. Forwards Ctrl-C / SIGTERM to every process, waits for a clean shutdown, and exits
# non-zero if any process failed. A failed process stops the graph, except the recorder: control
# goes on without it (said loudly; `capsule record recover` completes its file). When the plant
# ends by itself (--until-s), the extras get --extra-wait-s to finish, then the rest is stopped.
#
#   launch_scripts/capsule_launch.sh --scene scenes/control_point.toml --pacing lockstep \
#       --until-s 30 --mode forward [--with "CMD ..."]... [--plant-arg ARG]... [--controller-arg ARG]...
#       [--record-dir DIR | --no-record] [--separate [--record-in-plant] [--recorder-arg ARG]...]
#       [--cpu-affinity LIST] [--foxglove-port PORT] [--secure KEYSTORE] [--managed]
#       [--rmw dds|zenoh]
#
# Every run is recorded to DIR/capsule_<scene>_<UTC time>.mcap, DIR default ./runs: composed, by
# the plant in-process (every sample); with --separate by capsule_recorder, or with
# --record-in-plant by the plant itself (at 10 kHz 1-2 % of a core instead of half a core,
# docs/recording.md). --secure runs the nodes separate (each its own enclave).
# --cpu-affinity LIST (e.g. 0): every node's threads on these CPUs; plant and controller on one
# CPU wake each other without inter-processor interrupts (less CPU, lower latency: docs/ros.md).
# --foxglove-port PORT: also serve the graph live to Foxglove (capsule_foxglove's bridge, 127.0.0.1
# only; 0 picks a free port and prints it; docs/foxglove/README.md): composed, inside the container
# (a port it cannot serve on stops the launch before the loop starts); with --separate, a process
# of its own whose failure, like the recorder's, does not stop control.
# --secure KEYSTORE: run secured with SROS2 enclaves (ROS_SECURITY_KEYSTORE=KEYSTORE,
# ROS_SECURITY_ENABLE=true, ROS_SECURITY_STRATEGY=Enforce unless set; a keystore from
# launch_scripts/capsule_keystore.sh create KEYSTORE). Also when those variables are set already.
# Each node gets its enclave /capsule/{plant,controller,recorder,foxglove}, the --with commands
# /capsule/operator (ROS_SECURITY_ENCLAVE_OVERRIDE, unless set). docs/ros.md, Security.
#
# --rmw zenoh: the nodes on Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp; binaries built with
# `cargo build -p capsule_nodes --features zenoh`), plant and controller as separate processes;
# a router (capsule_zenohd on 127.0.0.1:7447) is started first unless one answers there or
# ZENOH_SESSION_CONFIG_URI / ZENOH_CONFIG_OVERRIDE name the user's own. Not on Zenoh yet:
# recording (give --no-record), the container, Foxglove, --secure (refused). --managed works
# on Zenoh too (the plant serves its lifecycle there; `ros2 lifecycle set` over rmw_zenoh_cpp).
# Also when RMW_IMPLEMENTATION=rmw_zenoh* is set already. docs/ros.md, Zenoh.
#
# --managed: the plant starts unconfigured and waits for its lifecycle (`ros2 lifecycle set
# /capsule_plant configure`, then `activate`; or `capsule_ros lifecycle-set`), as a managed node.
#
# DDS stays on loopback unless the caller says otherwise: ROS_AUTOMATIC_DISCOVERY_RANGE defaults to
# LOCALHOST here. Binaries come from $CAPSULE_BIN (default: target/debug next to this script).
set -u

here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
bin="${CAPSULE_BIN:-$here/../target/debug}"
export ROS_AUTOMATIC_DISCOVERY_RANGE="${ROS_AUTOMATIC_DISCOVERY_RANGE:-LOCALHOST}"

scene="" pacing="realtime" until_s="" mode="" extra_wait=600
plant_args=() ctl_args=() withs=()
usage() { sed -n '2,42p' "$0" | sed 's/^# \{0,1\}//'; }
record=1 record_dir="./runs" rec_args=() in_plant=0 cpus= fox_port= fox_args=() autostart=true separate=0
rmw=dds
case "${RMW_IMPLEMENTATION:-}" in rmw_zenoh*) rmw=zenoh ;; esac
die() { echo "capsule_launch: $*" >&2; usage >&2; exit 2; }
while [ $# -gt 0 ]; do
  # every option but the flags takes a value
  case "$1" in
    --no-record|--record-in-plant|--separate|--managed|-h|--help) ;;
    *) [ $# -ge 2 ] || die "$1 needs a value" ;;
  esac
  case "$1" in
    --scene) scene="$2"; shift 2 ;;
    --pacing) pacing="$2"; shift 2 ;;
    --until-s) until_s="$2"; shift 2 ;;
    --mode) mode="$2"; shift 2 ;;
    --with) withs+=("$2"); shift 2 ;;
    --extra-wait-s) extra_wait="$2"; shift 2 ;;
    --plant-arg) plant_args+=("$2"); shift 2 ;;
    --controller-arg) ctl_args+=("$2"); shift 2 ;;
    --record-dir) record_dir="$2"; shift 2 ;;
    --no-record) record=0; shift ;;
    --record-in-plant) in_plant=1; shift ;;
    --separate) separate=1; shift ;;
    --managed) autostart=false; shift ;;
    --rmw) rmw="$2"; shift 2 ;;
    --recorder-arg) rec_args+=("$2"); shift 2 ;;
    --cpu-affinity) cpus="$2"; shift 2 ;;
    --foxglove-port) fox_port="$2"; shift 2 ;;
    --secure)
      [ -d "$2/enclaves" ] || die "--secure '$2': not a keystore (no enclaves/; make one with launch_scripts/capsule_keystore.sh create $2)"
      export ROS_SECURITY_KEYSTORE="$2" ROS_SECURITY_ENABLE=true
      export ROS_SECURITY_STRATEGY="${ROS_SECURITY_STRATEGY:-Enforce}"
      shift 2 ;;
    -h|--help) usage; exit 0 ;;
    *) die "unknown argument $1" ;;
  esac
done
[ -n "$scene" ] || die "--scene is required"
case "$rmw" in dds|zenoh) ;; *) die "--rmw '$rmw': dds or zenoh" ;; esac
if [ "$rmw" = zenoh ]; then
  [ "$record" = 0 ] || die "--rmw zenoh: recording is not on Zenoh yet; give --no-record"
  [ -z "$fox_port" ] || die "--rmw zenoh: the Foxglove bridge is not on Zenoh yet"
  [ -x "$bin/capsule_zenohd" ] || { echo "capsule_launch: --rmw zenoh: $bin/capsule_zenohd not built: the nodes need Zenoh, cargo build -p capsule_nodes --features zenoh" >&2; exit 2; }
  export RMW_IMPLEMENTATION="${RMW_IMPLEMENTATION:-rmw_zenoh_cpp}"
  case "$RMW_IMPLEMENTATION" in rmw_zenoh*) ;; *) die "--rmw zenoh with RMW_IMPLEMENTATION=$RMW_IMPLEMENTATION" ;; esac
  if [ "$separate" = 0 ]; then
    echo "capsule_launch: on Zenoh, plant and controller run as separate processes (the container is not on Zenoh yet)" >&2
    separate=1
  fi
fi
[ -r "$scene" ] && [ -f "$scene" ] || die "cannot read scene file '$scene'"
case "$pacing" in realtime|lockstep) ;; *) die "--pacing '$pacing': realtime or lockstep" ;; esac
[ -z "$until_s" ] || [[ "$until_s" =~ ^[0-9]+(\.[0-9]*)?([eE][-+]?[0-9]+)?$ ]] || die "--until-s '$until_s': a positive number of seconds"
[[ "$extra_wait" =~ ^[0-9]{1,7}$ ]] || die "--extra-wait-s '$extra_wait': a whole number of seconds (0 to 9999999)"
if [ "$separate" = 0 ] && [ "${ROS_SECURITY_ENABLE:-}" = true ]; then
  echo "capsule_launch: secured: plant and controller run as separate processes, each with its own enclave" >&2
  separate=1
fi
if [ "$separate" = 0 ]; then
  [ "$in_plant" = 0 ] || die "--record-in-plant goes with --separate (composed, the plant always records in-process)"
  [ ${#rec_args[@]} -eq 0 ] || die "--recorder-arg goes with --separate (composed, no recorder process: the plant records in-process)"
fi
for b in capsule_plant capsule_controller $([ "$separate" = 0 ] && echo capsule_container); do
  [ -x "$bin/$b" ] || { echo "capsule_launch: $bin/$b not built (cargo build --workspace)" >&2; exit 2; }
done

# secured: each node its enclave (the --check runs below then check its files too)
extra_enclave=()
if [ "${ROS_SECURITY_ENABLE:-}" = true ]; then
  ctl_args+=(--enclave /capsule/controller); plant_args+=(--enclave /capsule/plant)
  rec_args+=(--enclave /capsule/recorder); fox_args+=(--enclave /capsule/foxglove)
  [ -z "${ROS_SECURITY_ENCLAVE_OVERRIDE:-}" ] && extra_enclave=(env ROS_SECURITY_ENCLAVE_OVERRIDE=/capsule/operator)
  echo "capsule_launch: SECURED (SROS2): keystore ${ROS_SECURITY_KEYSTORE:-(unset)}, strategy ${ROS_SECURITY_STRATEGY:-(permissive)}, enclaves /capsule/{controller,plant,recorder,foxglove}, --with commands ${ROS_SECURITY_ENCLAVE_OVERRIDE:-/capsule/operator}" >&2
else
  echo "capsule_launch: unsecured (no DDS Security; --secure KEYSTORE to run with SROS2 enclaves)" >&2
fi

# refuse bad scenes and flags before anything starts (no half-started graph)
if [ "$separate" = 0 ]; then
  co=(--scene "$scene" --pacing "$pacing")
  [ -n "$until_s" ] && co+=(--until-s "$until_s")
  [ -n "$mode" ] && co+=(--mode "$mode")
  [ -n "$cpus" ] && co+=(--cpu-affinity "$cpus")
  # the live view: the bridge inside the container, not a process of its own
  [ -n "$fox_port" ] && co+=(--foxglove-port "$fox_port")
  for a in --autostart "$autostart" ${plant_args[@]+"${plant_args[@]}"}; do co+=(--plant-arg "$a"); done
  for a in ${ctl_args[@]+"${ctl_args[@]}"}; do co+=(--controller-arg "$a"); done
  # lock-step: the extras' DDS readers matched before the first sample (the controller is in-process)
  [ "$pacing" = lockstep ] && [ ${#withs[@]} -gt 0 ] && co+=(--plant-arg --wait-subscribers --plant-arg "${#withs[@]}")
  if [ "$record" = 1 ]; then
    mkdir -p "$record_dir" || die "cannot create --record-dir '$record_dir'"
    out=$("$bin/capsule_container" "${co[@]}" --record-dir "$record_dir" --check) || exit 2
    out="${out#*would record to }"
    co+=(--record-output "${out%%; controller *}")
  else
    "$bin/capsule_container" "${co[@]}" --check >/dev/null || exit 2
  fi
fi
[ -n "$mode" ] && ctl_args+=(--mode "$mode")
if [ -n "$cpus" ]; then ctl_args+=(--cpu-affinity "$cpus"); plant_args+=(--cpu-affinity "$cpus"); rec_args+=(--cpu-affinity "$cpus"); fi
[ "$separate" = 1 ] && { "$bin/capsule_controller" --scene "$scene" ${ctl_args[@]+"${ctl_args[@]}"} --check || exit 2; }
pl=(--scene "$scene" --pacing "$pacing" --autostart "$autostart")
[ -n "$until_s" ] && pl+=(--until-s "$until_s")
# recording: the plant also waits for the recorder (so it records sample 0)
# the file name the check prints is the one the run writes (fixed here, not re-timed at start)
if [ "$record" = 1 ]; then mkdir -p "$record_dir" || die "cannot create --record-dir '$record_dir'"; fi
if [ "$separate" = 0 ]; then
  :
elif [ "$record" = 1 ] && [ "$in_plant" = 1 ]; then
  [ "$pacing" = lockstep ] && pl+=(--wait-subscribers "$(( 1 + ${#withs[@]} ))")
  out=$("$bin/capsule_plant" "${pl[@]}" --record-dir "$record_dir" ${plant_args[@]+"${plant_args[@]}"} --check) || exit 2
  pl+=(--record-output "${out##*would record to }")
elif [ "$record" = 1 ]; then
  [ -x "$bin/capsule_recorder" ] || { echo "capsule_launch: $bin/capsule_recorder not built (cargo build --workspace)" >&2; exit 2; }
  rec=("$bin/capsule_recorder" --scene "$scene" --record-dir "$record_dir" ${rec_args[@]+"${rec_args[@]}"})
  out=$("${rec[@]}" --check) || exit 2
  echo "$out"
  rec=("$bin/capsule_recorder" --scene "$scene" --output "${out##*would write }" ${rec_args[@]+"${rec_args[@]}"})
  # lock-step waits for the extras as before; real time only for controller + recorder
  if [ "$pacing" = lockstep ]; then pl+=(--wait-subscribers "$(( 2 + ${#withs[@]} ))"); else pl+=(--wait-subscribers 2); fi
else
  [ "$pacing" = lockstep ] && pl+=(--wait-subscribers "$(( 1 + ${#withs[@]} ))")
fi
[ "$separate" = 1 ] && { "$bin/capsule_plant" "${pl[@]}" ${plant_args[@]+"${plant_args[@]}"} --check || exit 2; }
if [ -n "$fox_port" ] && [ "$separate" = 1 ]; then
  [ -x "$bin/capsule_foxglove" ] || { echo "capsule_launch: $bin/capsule_foxglove not built (cargo build --workspace)" >&2; exit 2; }
  fox=("$bin/capsule_foxglove" --port "$fox_port" ${fox_args[@]+"${fox_args[@]}"})
  [ -n "$cpus" ] && fox+=(--cpu-affinity "$cpus")
  "${fox[@]}" --check >/dev/null || exit 2
fi

pids=() names=()
stop_all() {
  for p in "${pids[@]}"; do kill -TERM "$p" 2>/dev/null; done
}
on_signal() {
  echo "capsule_launch: $1: stopping the graph" >&2
  stopping=1
  stop_all
}
stopping=0
trap 'on_signal SIGINT' INT
trap 'on_signal SIGTERM' TERM

start() { # name cmd...
  local name="$1"; shift
  "$@" &
  pids+=("$!"); names+=("$name")
}

# Zenoh: a router on 127.0.0.1:7447 unless one answers there or the user configured the session
if [ "$rmw" = zenoh ] && [ -z "${ZENOH_SESSION_CONFIG_URI:-}${ZENOH_CONFIG_OVERRIDE:-}" ] \
  && ! (echo > /dev/tcp/127.0.0.1/7447) 2>/dev/null; then
  start router "$bin/capsule_zenohd"
  for _ in $(seq 100); do (echo > /dev/tcp/127.0.0.1/7447) 2>/dev/null && break; sleep 0.05; done
  (echo > /dev/tcp/127.0.0.1/7447) 2>/dev/null || { echo "capsule_launch: the Zenoh router did not answer on 127.0.0.1:7447 within 5 s" >&2; stop_all; exit 1; }
fi
[ "$separate" = 1 ] && start controller "$bin/capsule_controller" --scene "$scene" ${ctl_args[@]+"${ctl_args[@]}"}
[ "$separate" = 1 ] && [ "$record" = 1 ] && [ "$in_plant" = 0 ] && start recorder "${rec[@]}"
[ -n "$fox_port" ] && [ "$separate" = 1 ] && start foxglove "${fox[@]}"
for w in ${withs[@]+"${withs[@]}"}; do start "extra: $w" ${extra_enclave[@]+"${extra_enclave[@]}"} bash -c "$w"; done
if [ "$separate" = 1 ]; then
  start plant "$bin/capsule_plant" "${pl[@]}" ${plant_args[@]+"${plant_args[@]}"}
else
  start "container (plant + controller)" "$bin/capsule_container" "${co[@]}"
fi

declare -A status=() said=()
wait_pid() { # index -> sets status
  local i="$1" rc
  while :; do
    wait "${pids[$i]}"; rc=$?
    # wait returns >128 when interrupted by a trapped signal while the child still runs
    if kill -0 "${pids[$i]}" 2>/dev/null; then continue; fi
    status[$i]=$rc; return
  done
}

plant_i=$(( ${#pids[@]} - 1 ))
# wait for whichever ends first; a failure anywhere stops everything
while :; do
  alive=0 failed=0
  for i in "${!pids[@]}"; do
    if [ -z "${status[$i]+x}" ]; then
      if kill -0 "${pids[$i]}" 2>/dev/null; then alive=1; else wait_pid "$i"; fi
    fi
    if [ -n "${status[$i]+x}" ] && [ "${status[$i]}" != 0 ] && [ "$stopping" = 0 ]; then
      if [ "${names[$i]}" = recorder ]; then
        # losing the recording must not lose control of the capsule
        if [ -z "${said[$i]+x}" ]; then
          said[$i]=1
          echo "capsule_launch: RECORDER DIED (status ${status[$i]}): control goes on, NOT RECORDED from now on; complete its file with: capsule record recover FILE (in $record_dir)" >&2
        fi
      elif [ "${names[$i]}" = foxglove ]; then
        if [ -z "${said[$i]+x}" ]; then
          said[$i]=1
          echo "capsule_launch: the Foxglove live view failed (status ${status[$i]}): control goes on without it" >&2
        fi
      else
        echo "capsule_launch: ${names[$i]} failed (status ${status[$i]}): stopping the graph" >&2
        failed=1
      fi
    fi
  done
  if [ "$failed" = 1 ] && [ "$stopping" = 0 ]; then stopping=1; stop_all; fi
  [ "$alive" = 0 ] && break
  if [ -n "${status[$plant_i]+x}" ] && [ "$stopping" = 0 ]; then
    # plant done: let the extras finish, then stop the controller
    for i in "${!pids[@]}"; do
      case "${names[$i]}" in extra:*)
        t0=$SECONDS
        while kill -0 "${pids[$i]}" 2>/dev/null && [ $((SECONDS - t0)) -lt "$extra_wait" ] && [ "$stopping" = 0 ]; do sleep 0.2; done
        ;; esac
    done
    stopping=1; stop_all
  fi
  sleep 0.1
done

rc=0
for i in "${!pids[@]}"; do
  s="${status[$i]:-0}"
  # a process we stopped with SIGTERM and that died of it counts as a clean stop
  if [ "$s" != 0 ] && ! { [ "$stopping" = 1 ] && [ "$s" = 143 ]; }; then
    echo "capsule_launch: ${names[$i]} exited with status $s" >&2
    rc=1
  fi
done
exit "$rc"
