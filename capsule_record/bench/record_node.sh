#!/usr/bin/env bash
# Recorder benchmark (prints figures; not a timed test): plant + controller at RATE Hz for
# SECONDS of real time, the recorder writing everything; then the recorder's CPU share, the
# nodes' for reference, and whether the file holds every state the plant published.
# Runs inside a loopback-only network namespace (tests/peers/netns_run.sh). Needs root.
#
#   capsule_record/bench/record_node.sh [RATE_HZ=10000] [SECONDS=60] [BIN_DIR=target/release]
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
rate="${1:-10000}" secs="${2:-60}" bin="${3:-$here/target/release}"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
for b in capsule_plant capsule_controller capsule_recorder; do
  [ -x "$bin/$b" ] || { echo "$bin/$b missing (cargo build --release --workspace)" >&2; exit 2; }
done
[ -x "$bin/capsule" ] || { echo "$bin/capsule missing (cargo build --release --workspace)" >&2; exit 2; }
export B="$bin" SCENE="$here/scenes/control_point.toml" O="$out" RATE="$rate" SECS="$secs"
bash "$here/tests/peers/netns_run.sh" $((secs + 90)) bash -c '
  cpu() { awk "{print \$14 + \$15}" /proc/$1/stat; }   # utime + stime [clock ticks]
  $B/capsule_controller --scene "$SCENE" --mode forward 2>$O/ctl.log &
  C=$!
  $B/capsule_recorder --scene "$SCENE" --output "$O/run.mcap" 2>$O/rec.log &
  R=$!
  $B/capsule_plant --scene "$SCENE" --rate-hz $RATE --until-s $SECS --wait-subscribers 2 \
      --summary-json "$O/plant.json" 2>$O/plant.log &
  P=$!
  sleep 3; r0=$(cpu $R); c0=$(cpu $C); p0=$(cpu $P); t0=$(date +%s.%N)
  sleep $((SECS - 6)); r1=$(cpu $R); c1=$(cpu $C); p1=$(cpu $P); t1=$(date +%s.%N)
  wait $P
  sleep 1; kill -INT $R; wait $R; kill -TERM $C; wait $C || true
  hz=$(getconf CLK_TCK)
  awk -v r=$((r1-r0)) -v c=$((c1-c0)) -v p=$((p1-p0)) -v a=$t0 -v b=$t1 -v hz=$hz \
    "BEGIN { w=b-a; printf \"steady state over %.1f s: recorder %.1f %% of a core, controller %.1f %%, plant %.1f %%\n\", w, 100*r/hz/w, 100*c/hz/w, 100*p/hz/w }"
'
echo "plant: $(cat "$out/plant.json" | head -c 200)"
"$bin/capsule" record info "$out/run.mcap" | sed -n '1,20p'
samples=$(sed 's/.*"samples":\([0-9]*\).*/\1/' "$out/plant.json")
states=$("$bin/capsule" record info "$out/run.mcap" | awk '/\/capsule\/state/ { for (i=1;i<=NF;i++) if ($i=="count") print $(i+1) }')
echo "states published: $samples, recorded: $states"
