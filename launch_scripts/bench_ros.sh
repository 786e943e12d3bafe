#!/usr/bin/env bash
# ROS 2 layer benchmarks (figures, not pass/fail): each case runs in its own loopback-only
# network namespace (tests/peers/netns_run.sh) and prints one line of figures.
#
#   launch_scripts/bench_ros.sh [SCENE]      (default scenes/control_point.toml)
#
# Use release binaries: cargo build --release -p capsule_nodes; CAPSULE_BIN defaults to
# target/release. Cases:
#   rt1k   real time 1 kHz, plant + controller, 60 s ($RT1K_S): loop latency p50/p99/max
#          (state published -> its command received by the plant), lateness p99/max (a sample
#          out after its due time start + k / rate), unanswered samples,
#          datagrams the kernel dropped, CPU per node (steady state: user + system time from
#          2 s in to 0.5 s before the end, % of one core) and the host's steal time
#   rt10k  the same at 10 kHz for 5 s ($RT10K_S)
#   lock   lock-step closed loop: steps per second of wall time
#   lock-rec  the same, every sample recorded (the plant's in-process recording)
#   *-cpu1 the same with both nodes pinned to one CPU (--cpu-affinity), the last one allowed
#   c-*    the same cases with plant and controller composed in one process (capsule_container,
#          in-process state and force; pinned with taskset -c for -cpu1); CPU is the process's
#   c-rt10k-fox[-cpu1]  c-rt10k with the container's Foxglove bridge (--foxglove-port 0) serving
#          a Foxglove client (tests/peers/foxglove_ws_client.py) all four channels for the run
# BENCH_CASES="lock lock-cpu1" runs only the cases named (default: all, in the order above).
# BENCH_RT="chrt -f 50" runs every node with that prefix (real-time scheduling: a host busy with
# other work then delays the loop by microseconds, not milliseconds; docs/perf/composition.md).
# BENCH_RMW=zenoh runs the separate-process cases over Zenoh (RMW_IMPLEMENTATION=rmw_zenoh_cpp, a
# capsule_zenohd router on 127.0.0.1:7447 in each case's namespace; binaries built with
# --features zenoh; docs/perf/zenoh.md); the composed cases are refused there (no container on Zenoh).
# BENCH_SECURE=KEYSTORE runs every case secured (SROS2, Enforce; plant and controller with their
# enclaves of launch_scripts/capsule_keystore.sh create KEYSTORE): docs/perf/security.md.
set -u
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$here/.."
scene="${1:-$root/scenes/control_point.toml}"
export CAPSULE_BIN="${CAPSULE_BIN:-$root/target/release}"
export SCENE="$scene" BENCH_RT="${BENCH_RT:-}"

case_script='
set -u
B=$CAPSULE_BIN
cpu() { awk "{print \$14 + \$15}" /proc/$1/stat 2>/dev/null || echo -1; }
steal() { awk "/^cpu / {print \$9}" /proc/stat; }  # ticks the hypervisor gave to others
if [ -n "${BENCH_SECURE:-}" ]; then
  export ROS_SECURITY_KEYSTORE="$BENCH_SECURE" ROS_SECURITY_ENABLE=true ROS_SECURITY_STRATEGY=Enforce
fi
rm -f /tmp/bench_rec.mcap
Z=
if [ "${BENCH_RMW:-}" = zenoh ]; then
  export RMW_IMPLEMENTATION=rmw_zenoh_cpp
  $B/capsule_zenohd 2>/dev/null & Z=$!
  for i in $(seq 50); do (echo > /dev/tcp/127.0.0.1/7447) 2>/dev/null && break; sleep 0.1; done
fi
${BENCH_RT:-} $B/capsule_controller --scene "$SCENE" --mode forward $NODE_ARGS --enclave /capsule/controller 2>/dev/null &
C=$!
sleep 0.5
${BENCH_RT:-} $B/capsule_plant --scene "$SCENE" $PLANT_ARGS $NODE_ARGS --enclave /capsule/plant --summary-json /tmp/bench_$$.json 2>/dev/null &
P=$!
# CPU over the steady state: from 2 s in (discovery done) to 0.5 s before the end
sleep 2
t0=$(date +%s.%N); c0=$(cpu $C); p0=$(cpu $P); s0=$(steal)
sleep $(awk "BEGIN{print $SECS - 2.5}")
p1=$(cpu $P); c1=$(cpu $C); t1=$(date +%s.%N); s1=$(steal)
wait $P
kill -TERM $C; wait $C
[ -z "$Z" ] || { kill -TERM $Z; wait $Z; }
hz=$(getconf CLK_TCK)
echo "SUMMARY $(cat /tmp/bench_$$.json)"
# datagrams the kernel dropped in this namespace (full receive buffers, errors)
awk "/^Udp:/ { if (!h) { for (i = 1; i <= NF; i++) f[\$i] = i; h = 1 } else print \"UDP dropped \" \$f[\"RcvbufErrors\"] + \$f[\"InErrors\"] }" /proc/net/snmp
[ "$p1" -lt 0 ] || awk -v p0=$p0 -v p1=$p1 -v c0=$c0 -v c1=$c1 -v s0=$s0 -v s1=$s1 -v t0=$t0 -v t1=$t1 -v hz=$hz -v n=$(nproc) "BEGIN{printf \"CPU plant %.1f%% controller %.1f%% of one core (host steal %.1f%% of the CPUs)\\n\", 100*(p1-p0)/hz/(t1-t0), 100*(c1-c0)/hz/(t1-t0), 100*(s1-s0)/hz/(t1-t0)/n}"
rm -f /tmp/bench_$$.json /tmp/bench_rec.mcap
'
# the same, composed: one process ($PIN: taskset -c CPU, or nothing)
composed_script='
set -u
B=$CAPSULE_BIN
cpu() { awk "{print \$14 + \$15}" /proc/$1/stat 2>/dev/null || echo -1; }
steal() { awk "/^cpu / {print \$9}" /proc/stat; }
rm -f /tmp/bench_rec.mcap
${BENCH_RT:-} $PIN $B/capsule_container --scene "$SCENE" --mode forward $PLANT_ARGS --summary-json /tmp/bench_$$.json 2>/dev/null >/tmp/bench_out_$$ &
P=$!
if [ -n "$FOX_CLIENT" ]; then
  for i in $(seq 100); do grep -q serving /tmp/bench_out_$$ && break; sleep 0.05; done
  URL=$(sed -n "s/^capsule_foxglove: serving //p" /tmp/bench_out_$$)
  python3 "$FOX_CLIENT" "$URL" --topics /capsule/state /capsule_controller/status /capsule/frame /capsule/actuator_force \
    --seconds $(awk "BEGIN{print $SECS - 3}") --min 1 --timeout $(( ${SECS%.*} + 30 )) >/tmp/bench_fox_$$ &
  F=$!
fi
sleep 2
t0=$(date +%s.%N); p0=$(cpu $P); s0=$(steal)
sleep $(awk "BEGIN{print $SECS - 2.5}")
p1=$(cpu $P); t1=$(date +%s.%N); s1=$(steal)
wait $P
# the client: messages received per channel (state, status, frame, force), or why not
[ -n "$FOX_CLIENT" ] && { wait $F; echo "FOXGLOVE client (rc $?) received: $(grep -o "\"count\": [0-9]*" /tmp/bench_fox_$$ | tr "\n" " ")"; }
hz=$(getconf CLK_TCK)
echo "SUMMARY $(cat /tmp/bench_$$.json)"
awk "/^Udp:/ { if (!h) { for (i = 1; i <= NF; i++) f[\$i] = i; h = 1 } else print \"UDP dropped \" \$f[\"RcvbufErrors\"] + \$f[\"InErrors\"] }" /proc/net/snmp
[ "$p1" -lt 0 ] || awk -v p0=$p0 -v p1=$p1 -v s0=$s0 -v s1=$s1 -v t0=$t0 -v t1=$t1 -v hz=$hz -v n=$(nproc) "BEGIN{printf \"CPU container %.1f%% of one core (host steal %.1f%% of the CPUs)\\n\", 100*(p1-p0)/hz/(t1-t0), 100*(s1-s0)/hz/(t1-t0)/n}"
rm -f /tmp/bench_$$.json /tmp/bench_rec.mcap /tmp/bench_out_$$ /tmp/bench_fox_$$
'
report() { # name, output
  local name="$1" out="$2" json
  json=$(echo "$out" | sed -n 's/^SUMMARY //p')
  python3 - "$name" "$json" "$(echo "$out" | grep '^CPU' || echo 'CPU: run shorter than the measuring window')" "$(echo "$out" | grep '^UDP dropped')" <<'PY'
import json, sys
name, raw, cpu, udp = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
try:
    j = json.loads(raw)
except Exception:
    print(f"{name}: no summary ({raw!r})"); sys.exit(0)
ms = lambda v: "n/a" if v is None else f"{1e3*v:.3f} ms"
print(f"{name}: samples {j['samples']} ({j['before_first_answer']} before the first answer), lost {j['unanswered']}, "
      f"answered late {j['late_answers']}, latency p50 {ms(j['latency_p50_s'])} "
      f"p99 {ms(j['latency_p99_s'])} max {ms(j['latency_max_s'])}, "
      + (f"lateness p99 {ms(j['lateness_p99_s'])} max {ms(j['lateness_max_s'])}, " if j.get('lateness_p99_s') is not None else "")
      + f"wall {j['wall_s']:.2f} s, "
      f"{j['samples']/j['wall_s']:.0f} steps/s"
      + (f" ({j['samples']/j['loop_s']:.0f} in the loop's {j['loop_s']:.2f} s)" if j.get('loop_s') else "")
      + f"; {cpu}; {udp} datagrams"
      + (f"; DDS copies {j['dds_copies']}" if 'dds_copies' in j else ""))
PY
}

run_case() { # name seconds plant-args [node-args]
  local out
  case " ${BENCH_CASES:-$1} " in *" $1 "*) ;; *) return 0 ;; esac
  out=$(SECS="$2" PLANT_ARGS="$3" NODE_ARGS="${4:-}" "$root/tests/peers/netns_run.sh" $(( ${2%.*} + 60 )) bash -c "$case_script")
  report "$1" "$out"
}
run_composed() { # name seconds container-args [pin]
  local out client=
  case " ${BENCH_CASES:-$1} " in *" $1 "*) ;; *) return 0 ;; esac
  [ "${BENCH_RMW:-}" = zenoh ] && { echo "$1: not on Zenoh (the container is DDS only)"; return 0; }
  case "$1" in *-fox*) client="$root/tests/peers/foxglove_ws_client.py" ;; esac
  out=$(SECS="$2" PLANT_ARGS="$3" PIN="${4:-}" FOX_CLIENT="$client" "$root/tests/peers/netns_run.sh" $(( ${2%.*} + 60 )) bash -c "$composed_script")
  report "$1" "$out"
  echo "$out" | grep "^FOXGLOVE" | sed "s/^/$1: /"
}
cpu=$(awk '/Cpus_allowed_list/ {print $2}' /proc/self/status | tr ',' '\n' | tail -1 | sed 's/.*-//')

for c in ${BENCH_CASES:-}; do
  case "$c" in rt1k|rt1k-cpu1|rt10k|rt10k-cpu1|lock|lock-cpu1|lock-rec|lock-rec-cpu1) ;;
    c-rt1k|c-rt1k-cpu1|c-rt10k|c-rt10k-cpu1|c-rt10k-fox|c-rt10k-fox-cpu1|c-lock|c-lock-cpu1|c-lock-rec|c-lock-rec-cpu1) ;;
    *) echo "bench_ros: BENCH_CASES: unknown case '$c' (rt1k rt10k lock lock-rec, each also -cpu1 and c-)" >&2; exit 2 ;;
  esac
done
case "${BENCH_RMW:-dds}" in dds|zenoh) ;; *) echo "bench_ros: BENCH_RMW: '$BENCH_RMW' is neither dds nor zenoh" >&2; exit 2 ;; esac
if [ "${BENCH_RMW:-}" = zenoh ]; then
  [ -x "$CAPSULE_BIN/capsule_zenohd" ] || { echo "bench_ros: BENCH_RMW=zenoh: $CAPSULE_BIN/capsule_zenohd missing (cargo build -p capsule_nodes --features zenoh)" >&2; exit 2; }
  [ -z "${BENCH_SECURE:-}" ] || { echo "bench_ros: BENCH_SECURE with BENCH_RMW=zenoh: SROS2 secures DDS only" >&2; exit 2; }
fi
if [ -n "${BENCH_SECURE:-}" ]; then
  [ -d "$BENCH_SECURE/enclaves" ] || { echo "bench_ros: BENCH_SECURE '$BENCH_SECURE': not a keystore (launch_scripts/capsule_keystore.sh create DIR)" >&2; exit 2; }
  BENCH_SECURE="$(cd "$BENCH_SECURE" && pwd)"; export BENCH_SECURE
fi
echo "bench_ros: scene $scene, binaries $CAPSULE_BIN, ${BENCH_RMW:-dds}, $(nproc) cores, $([ -n "${BENCH_SECURE:-}" ] && echo "SECURED with $BENCH_SECURE" || echo unsecured)${BENCH_RT:+, nodes run with $BENCH_RT}, load average $(cut -d' ' -f1-3 /proc/loadavg)"
run_case rt1k ${RT1K_S:-60} "--pacing realtime --until-s ${RT1K_S:-60}"
run_case rt1k-cpu1 ${RT1K_S:-60} "--pacing realtime --until-s ${RT1K_S:-60}" "--cpu-affinity $cpu"
run_case rt10k ${RT10K_S:-5} "--pacing realtime --rate-hz 10000 --until-s ${RT10K_S:-5}"
run_case rt10k-cpu1 ${RT10K_S:-5} "--pacing realtime --rate-hz 10000 --until-s ${RT10K_S:-5}" "--cpu-affinity $cpu"
run_case lock 8 "--pacing lockstep --until-s 10 --wait-subscribers 1"
run_case lock-cpu1 8 "--pacing lockstep --until-s 10 --wait-subscribers 1" "--cpu-affinity $cpu"
rec="--record-output /tmp/bench_rec.mcap"
run_case lock-rec 8 "--pacing lockstep --until-s 10 --wait-subscribers 1 $rec"
run_case lock-rec-cpu1 8 "--pacing lockstep --until-s 10 --wait-subscribers 1 $rec" "--cpu-affinity $cpu"
# composed: the lock-step runs 300 s of sim time (at tens of thousands of steps/s, 10 s would end
# before the CPU window opens)
run_composed c-rt1k ${RT1K_S:-60} "--pacing realtime --until-s ${RT1K_S:-60}"
run_composed c-rt1k-cpu1 ${RT1K_S:-60} "--pacing realtime --until-s ${RT1K_S:-60}" "taskset -c $cpu"
run_composed c-rt10k ${RT10K_S:-5} "--pacing realtime --plant-arg --rate-hz --plant-arg 10000 --until-s ${RT10K_S:-5}"
run_composed c-rt10k-cpu1 ${RT10K_S:-5} "--pacing realtime --plant-arg --rate-hz --plant-arg 10000 --until-s ${RT10K_S:-5}" "taskset -c $cpu"
fox="--foxglove-port 0"
run_composed c-rt10k-fox ${RT10K_S:-5} "--pacing realtime --plant-arg --rate-hz --plant-arg 10000 --until-s ${RT10K_S:-5} $fox"
run_composed c-rt10k-fox-cpu1 ${RT10K_S:-5} "--pacing realtime --plant-arg --rate-hz --plant-arg 10000 --until-s ${RT10K_S:-5} $fox" "taskset -c $cpu"
run_composed c-lock 8 "--pacing lockstep --until-s 300"
run_composed c-lock-cpu1 8 "--pacing lockstep --until-s 300" "taskset -c $cpu"
run_composed c-lock-rec 8 "--pacing lockstep --until-s 300 $rec"
run_composed c-lock-rec-cpu1 8 "--pacing lockstep --until-s 300 $rec" "taskset -c $cpu"
