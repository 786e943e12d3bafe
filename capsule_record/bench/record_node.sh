#!/usr/bin/env bash
# Recording benchmark (prints figures; not a timed test): plant + controller at RATE Hz for
# SECONDS of real time, three times: without recording (the baseline), with the recorder node
# (capsule_recorder, a separate DDS subscriber), and with the plant recording in-process
# (capsule_plant --record-output). Prints each process's CPU over the steady state and, for the
# recordings, whether the file holds every state the plant published.
# Each case runs inside a loopback-only network namespace (tests/peers/netns_run.sh). Needs root.
#
#   capsule_record/bench/record_node.sh [RATE_HZ=10000] [SECONDS=60] [BIN_DIR=target/release]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
rate="${1:-10000}" secs="${2:-60}" bin="${3:-$here/target/release}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for b in capsule_plant capsule_controller capsule_recorder capsule; do
  [ -x "$bin/$b" ] || { echo "$bin/$b missing (cargo build --release --workspace)" >&2; exit 2; }
done
export B="$bin" SCENE="$here/scenes/control_point.toml" O="$out" RATE="$rate" SECS="$secs"

run_case() { # name: none | node | in-plant
  CASE="$1" bash "$here/tests/peers/netns_run.sh" $((secs + 90)) bash -c '
    cpu() { awk "{print \$14 + \$15}" /proc/$1/stat; }   # utime + stime [clock ticks]
    rm -f $O/run.mcap
    $B/capsule_controller --scene "$SCENE" --mode forward 2>$O/ctl.log &
    C=$!
    R=""; plant_rec=(); subs=1
    case $CASE in
      node) $B/capsule_recorder --scene "$SCENE" --output "$O/run.mcap" 2>$O/rec.log &
            R=$!; subs=2 ;;
      in-plant) plant_rec=(--record-output "$O/run.mcap") ;;
    esac
    $B/capsule_plant --scene "$SCENE" --rate-hz $RATE --until-s $SECS --wait-subscribers $subs \
        --summary-json "$O/plant.json" "${plant_rec[@]}" 2>$O/plant.log &
    P=$!
    sleep 3; c0=$(cpu $C); p0=$(cpu $P); r0=$([ -n "$R" ] && cpu $R || echo 0); t0=$(date +%s.%N)
    sleep $((SECS - 6)); c1=$(cpu $C); p1=$(cpu $P); r1=$([ -n "$R" ] && cpu $R || echo 0); t1=$(date +%s.%N)
    wait $P
    if [ -n "$R" ]; then sleep 1; kill -INT $R; wait $R; fi
    kill -TERM $C; wait $C || true
    awk -v r=$((r1-r0)) -v c=$((c1-c0)) -v p=$((p1-p0)) -v a=$t0 -v b=$t1 -v hz=$(getconf CLK_TCK) -v n=$CASE \
      "BEGIN { w=b-a; printf \"%-9s steady state over %.1f s: plant %5.1f %%, controller %5.1f %%, recorder %5.1f %% of a core\n\", n, w, 100*p/hz/w, 100*c/hz/w, 100*r/hz/w }"
  '
  if [ "$1" != none ]; then
    local samples states
    samples=$(sed 's/.*"samples":\([0-9]*\).*/\1/' "$out/plant.json")
    states=$("$bin/capsule" record info "$out/run.mcap" | awk '/\/capsule\/state/ { for (i=1;i<=NF;i++) if ($i=="count") print $(i+1) }')
    echo "          states published: $samples, recorded: $states"
  fi
}

echo "record_node: plant + controller at $rate Hz for $secs s, $(nproc) cores"
run_case none
run_case node
run_case in-plant
