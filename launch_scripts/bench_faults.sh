#!/usr/bin/env bash
# Figures (not pass/fail) of the graph under network faults and a stalled controller: plant and
# controller as separate processes, each case RUNS times ($RUNS, default 3) in its own
# loopback-only network namespace (tests/peers/netns_run.sh), faults injected with iptables
# (tests/peers/net_faults.sh). One line per run: wall time, samples, re-sends, unanswered and
# late answers, zero-force steps logged, and whether the last sample equals the clean run's.
#
#   launch_scripts/bench_faults.sh [SCENE]      (default scenes/control_point.toml)
#
# Cases ($FAULT_CASES, default all, in this order):
#   lock-clean    lock-step, --until-s $UNTIL_S (default 1), no fault: the reference
#   lock-lossy    10 % loss, 1 +- 1 ms delay, 5 % reordered (3 ms more), 1 % duplicated
#   lock-outage   0.5 s with nothing getting through, as the loop starts
#   lock-stop     no network fault: the controller stopped (SIGSTOP) for 150 ms, 0.3 s in
#   rt-clean      real time, 5 s
#   rt-loss5      real time, 5 % loss
#   rt-partition  real time, 5 % loss, 1 s partition 2 s in
# PLANT_ARGS="--lockstep-on-silence zero-force" adds flags to every plant (the old fallback).
# CAPSULE_BIN: the node binaries (default target/debug, what the tests run).
set -u
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(cd "$here/.." && pwd)"
scene="${1:-$root/scenes/control_point.toml}"
bin="${CAPSULE_BIN:-$root/target/debug}"
runs="${RUNS:-3}" until_s="${UNTIL_S:-1}"
cases="${FAULT_CASES:-lock-clean lock-lossy lock-outage lock-stop rt-clean rt-loss5 rt-partition}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
one() { # CASE RUN
  local c="$1" tmp="$out/$1.$2"
  mkdir -p "$tmp"
  B="$bin" ROOT="$root" SCENE="$scene" TMP="$tmp" CASE="$c" UNTIL_S="$until_s" PLANT_ARGS="${PLANT_ARGS:-}" \
    "$root/tests/peers/netns_run.sh" 120 bash -c '
    . "$ROOT/tests/peers/net_faults.sh"
    case "$CASE" in lock-*) pacing="--pacing lockstep --until-s $UNTIL_S" ;; *) pacing="--until-s 5" ;; esac
    "$B/capsule_controller" --scene "$SCENE" --mode forward 2> "$TMP/ctl.log" & C=$!
    case "$CASE" in
      lock-lossy) lossy 0.10; dupes 0.01; delayed 1 1 0.05 ;;
      rt-loss5|rt-partition) lossy 0.05 ;;
    esac
    t0=$(date +%s.%N)
    "$B/capsule_plant" --scene "$SCENE" $pacing --wait-subscribers 1 $PLANT_ARGS \
        --summary-json "$TMP/s.json" 2> "$TMP/plant.log" & P=$!
    case "$CASE" in
      lock-outage) wait_log "$TMP/plant.log" "matched: starting"; partition; sleep 0.5; heal ;;
      lock-stop) wait_log "$TMP/plant.log" "matched: starting"; sleep 0.3; kill -STOP $C; sleep 0.15; kill -CONT $C ;;
      rt-partition) wait_log "$TMP/plant.log" "matched: starting"; sleep 2; partition; sleep 1; heal ;;
    esac
    wait $P; rc=$?
    t1=$(date +%s.%N)
    kill -TERM $C; wait $C
    unfault
    zero=$(grep -c "applying zero force" "$TMP/plant.log")
    echo "rc=$rc process_s=$(awk "BEGIN { printf \"%.2f\", $t1 - $t0 }") zero_force_logs=$zero $(cat "$TMP/s.json" 2>/dev/null)"
    [ -s "$TMP/nfq.json" ] && echo "queue $(cat "$TMP/nfq.json")"
  ' 2>/dev/null
}
declare -A ref=()
for c in $cases; do
  for r in $(seq "$runs"); do
    res="$(one "$c" "$r")"
    line="$(echo "$res" | grep '^rc=')"
    last="${line#*\"last\":}"
    kind="${c%%-*}"
    [ "$c" = lock-clean ] || [ "$c" = rt-clean ] && [ -z "${ref[$kind]+x}" ] && ref[$kind]="$last"
    same="-"; [ "$kind" = lock ] && { [ "$last" = "${ref[lock]:-}" ] && same=yes || same=NO; }
    python3 - "$c" "$r" "$same" "$line" "$(echo "$res" | grep '^queue ' | cut -c7-)" <<'PY'
import json, re, sys
case, run, same, line, queue = sys.argv[1:6]
rc = re.search(r"rc=(\d+)", line).group(1)
proc = re.search(r"process_s=([\d.]+)", line).group(1)
zero = re.search(r"zero_force_logs=(\d+)", line).group(1)
j = line[line.find("{"):] if "{" in line else ""
s = json.loads(j) if j else {}
last = s.get("last", {})
q = json.loads(queue) if queue else {}
print(f"{case:13} run {run} rc {rc} process {proc} s loop {s.get('loop_s') or 0:.3f} s "
      f"samples {s.get('samples','-')} resent {s.get('resent','-')} unanswered {s.get('unanswered','-')} "
      f"late {s.get('late_answers','-')} zero-force logs {zero} seq {last.get('seq','-')} "
      f"x2 {last.get('capsule_position', float('nan')):.6f} m same-as-clean {same}"
      + (f" queue {q.get('packets')} packets {q.get('reordered')} reordered" if q else ""))
PY
  done
done
