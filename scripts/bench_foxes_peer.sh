#!/usr/bin/env bash
# PEERS.md's animated-characters scene (Bevy: N foxes running, each at its own time, one sun, no
# shadows) with a release sandbox, for docs/experiments/notebook.md:
#   scripts/bench_foxes_peer.sh SANDBOX CHARACTER [COUNTS...]
# Forward pipeline (or $PIPELINE: forward, forward_plus, deferred, visbuffer), no shadows, no
# decals, the Fox's Run clip, 1920×1080. The wall time of a frame
# is measured as the difference of a 160-frame and a 60-frame run over their 100 extra frames (so
# loading and the first builds cancel); the GPU and CPU frame, and the CPU frame's parts
# (`cpu_ms`: animate, propagate, skin, extract, record), are medians of frames 60–159.
set -euo pipefail
bin="$1"
character="$2"
shift 2
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1 100 1000 10000)
out=$(mktemp -d)
echo "| foxes | GPU frame | CPU frame | animate | propagate | skin | extract | record | wall time a frame |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for n in "${counts[@]}"; do
  run() {
    "$bin" --headless --frames "$1" --size 1920x1080 --bench-scene foxes --character "$character" --character-clip Run \
      --instances "$n" --pipeline "${PIPELINE:-forward}" --decal-method off --no-shadows --stats "$out/peer_$1.jsonl" >/dev/null 2>&1
  }
  t0=$(date +%s.%N); run 60; t1=$(date +%s.%N); run 160; t2=$(date +%s.%N)
  python3 - "$out/peer_160.jsonl" "$n" "$t0" "$t1" "$t2" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if r["frame"] >= 60]
n, t0, t1, t2 = int(sys.argv[2]), *map(float, sys.argv[3:6])
wall = ((t2 - t1) - (t1 - t0)) / 100 * 1e3
gpu = statistics.median(r["gpu_ms"]["total"] for r in rows)
cpu = statistics.median(r["cpu_ms"]["frame"] for r in rows)
parts = " | ".join(f"{statistics.median(r['cpu_ms'].get(p, 0.0) for r in rows):.2f}" for p in ("animate", "propagate", "skin", "extract", "record"))
# Below a few milliseconds a frame the start-up's variation swamps the difference.
shown = f"{wall:.1f} ms" if wall > 1.0 else "below start-up noise"
print(f"| {n:,} | {gpu:.2f} ms | {cpu:.2f} ms | {parts} | {shown} |")
PY
done
rm -rf "$out"
