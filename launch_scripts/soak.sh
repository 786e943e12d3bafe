#!/usr/bin/env bash
# Soak: plant + controller + recorder at 1 kHz real time for a long run (default one hour) in a
# loopback-only network namespace (tests/peers/netns_run.sh). Not a test: it prints figures.
#
#   launch_scripts/soak.sh [--duration-s S] [--every-s S] [--out DIR] [--scene FILE]
#
# Use release binaries (cargo build --release -p capsule_nodes -p capsule_cli); CAPSULE_BIN
# defaults to target/release. Writes to DIR (default runs/soak-<UTC time>):
#   rss.csv       resident memory [kB] of each process every --every-s (default 10 s)
#   plant.json    the plant's loop summary (samples, lost, latency p50/p99/max, refused, ...)
#   soak.mcap     the recording; *.log the nodes' logs
# and at the end a summary: lost samples, latency percentiles, memory of each process after
# the warm-up (first 10 % of the run, at most 5 min) and its growth (least-squares slope over
# the rest, and first -> last), and whether the recording holds every state seq the plant
# published. A progress line with the memory goes out every 5 min. Ctrl-C ends the run early:
# the nodes finish (the plant writes its summary, the recorder its file) and the summary covers
# what ran.
set -u
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$here/.."
duration=3600
every=10
scene="$root/scenes/control_point.toml"
out=""
while [ $# -gt 0 ]; do
  case "$1" in
    --duration-s) duration="$2"; shift 2 ;;
    --every-s) every="$2"; shift 2 ;;
    --out) out="$2"; shift 2 ;;
    --scene) scene="$2"; shift 2 ;;
    -h|--help) sed -n '2,18p' "$0"; exit 0 ;;
    *) echo "soak.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
for v in "$duration" "$every"; do
  [[ "$v" =~ ^[0-9]+$ ]] && [ "$v" -gt 0 ] || { echo "soak.sh: $v: expected a whole number of seconds > 0" >&2; exit 2; }
done
[ -f "$scene" ] || { echo "soak.sh: scene $scene: no such file" >&2; exit 2; }
export CAPSULE_BIN="${CAPSULE_BIN:-$root/target/release}"
for b in capsule_plant capsule_controller capsule_recorder capsule; do
  [ -x "$CAPSULE_BIN/$b" ] || { echo "soak.sh: $CAPSULE_BIN/$b missing: cargo build --release -p capsule_nodes -p capsule_cli" >&2; exit 2; }
done
out="${out:-$root/runs/soak-$(date -u +%Y%m%dT%H%M%SZ)}"
mkdir -p "$out" || exit 2
out="$(cd "$out" && pwd)"
echo "soak: $duration s at 1 kHz real time, scene $scene, binaries $CAPSULE_BIN, out $out, $(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"

export SCENE="$scene" OUT="$out" DURATION="$duration" EVERY="$every"
inner='
set -u
B=$CAPSULE_BIN
rss() { awk "/^VmRSS/ {print \$2}" /proc/$1/status 2>/dev/null || echo ""; }
$B/capsule_recorder --scene "$SCENE" --output "$OUT/soak.mcap" 2> "$OUT/recorder.log" &
R=$!
$B/capsule_controller --scene "$SCENE" --mode forward 2> "$OUT/controller.log" &
C=$!
$B/capsule_plant --scene "$SCENE" --until-s "$DURATION" --wait-subscribers 2 \
  --summary-json "$OUT/plant.json" 2> "$OUT/plant.log" &
P=$!
trap "kill -INT $P 2>/dev/null" INT TERM
echo "t_s,plant_kb,controller_kb,recorder_kb" > "$OUT/rss.csv"
t0=$(date +%s)
next_progress=300
while kill -0 $P 2>/dev/null; do
  t=$(( $(date +%s) - t0 ))
  line="$t,$(rss $P),$(rss $C),$(rss $R)"
  echo "$line" >> "$OUT/rss.csv"
  if [ $t -ge $next_progress ]; then
    echo "soak: t = $t s, RSS kB plant,controller,recorder = ${line#*,}"
    next_progress=$(( next_progress + 300 ))
  fi
  sleep "$EVERY" & wait $!
done
wait $P; echo "plant exit $?"
sleep 1
kill -TERM $C $R 2>/dev/null
wait $C; echo "controller exit $?"
wait $R; echo "recorder exit $?"
'
"$root/tests/peers/netns_run.sh" $(( duration + 600 )) bash -c "$inner"
echo "soak: run ended (status $?); analysing"

python3 - "$out" "$duration" <<'PY'
import csv, json, os, struct, sys
out, duration = sys.argv[1], float(sys.argv[2])

def fit(ts, ys):
    n = len(ts)
    if n < 2:
        return float("nan")
    mt, my = sum(ts) / n, sum(ys) / n
    den = sum((t - mt) ** 2 for t in ts)
    return sum((t - mt) * (y - my) for t, y in zip(ts, ys)) / den if den else float("nan")

try:
    j = json.load(open(os.path.join(out, "plant.json")))
    ms = lambda v: "n/a" if v is None else f"{1e3 * v:.3f} ms"
    print(f"loop: {j['samples']} samples in {j['wall_s']:.0f} s ({j['before_first_answer']} before the first "
          f"answer), lost {j['unanswered']}, answered late {j['late_answers']}, latency p50 "
          f"{ms(j['latency_p50_s'])} p99 {ms(j['latency_p99_s'])} max {ms(j['latency_max_s'])}, "
          f"refused {j['rejected_commands']}, saturated {j.get('saturated_commands')}, "
          f"graph conflicts {j.get('graph_conflicts')}")
except (OSError, ValueError, KeyError) as e:
    j = None
    print(f"loop: no plant summary ({e})")

rows = list(csv.DictReader(open(os.path.join(out, "rss.csv"))))
warm = min(300.0, 0.1 * duration)
for name in ("plant", "controller", "recorder"):
    pts = [(float(r["t_s"]), float(r[name + "_kb"])) for r in rows if r[name + "_kb"]]
    after = [(t, y) for t, y in pts if t >= warm]
    if len(after) < 2:
        print(f"memory {name}: too few samples after the {warm:.0f} s warm-up")
        continue
    ts, ys = zip(*after)
    slope = fit(ts, ys)
    print(f"memory {name}: {pts[0][1]:.0f} kB at {pts[0][0]:.0f} s, {after[0][1]:.0f} kB after the warm-up "
          f"({after[0][0]:.0f} s), {ys[-1]:.0f} kB at {ts[-1]:.0f} s (max {max(ys):.0f}); growth after the warm-up "
          f"{slope * 60:.1f} kB/min ({slope:.3f} kB/s), first -> last {ys[-1] - after[0][1]:+.0f} kB")

# every state seq the plant published, in the recording? (seq read straight from the CDR)
path = os.path.join(out, "soak.mcap")
try:
    from mcap.reader import make_reader
    n = 0
    seen = set()
    with open(path, "rb") as f:
        for schema, channel, msg in make_reader(f).iter_messages(topics=["/capsule/state"]):
            d = msg.data
            slen = struct.unpack_from("<I", d, 4 + 8)[0]
            off = 8 + 4 + slen  # CDR body offset of the end of frame_id
            off = (off + 7) // 8 * 8
            seq = struct.unpack_from("<Q", d, 4 + off)[0]
            seen.add(seq)
            n += 1
    if seen:
        lo, hi = min(seen), max(seen)
        missing = (hi - lo + 1) - len(seen)
        published = j["samples"] if j else None
        print(f"recording: {n} state messages, seqs {lo}..{hi}, {len(seen)} distinct, {missing} missing in that range"
              + (f"; the plant published {published} (seqs 0..{published - 1}): "
                 f"{'all recorded' if lo == 0 and hi == published - 1 and missing == 0 else 'NOT all recorded'}"
                 if published else ""))
    else:
        print("recording: no state messages")
except Exception as e:  # a damaged file is a finding, not a crash of the report
    print(f"recording: cannot read {path}: {e} (try capsule record recover)")
PY
