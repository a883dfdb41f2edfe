#!/usr/bin/env bash
# PEERS.md's animated-characters scene (Bevy: N foxes running, each at its own time, one sun, no
# shadows) with a release sandbox, for docs/experiments/ records (skinning-peer-foxes.md and the crowds-* ones):
#   scripts/bench_foxes_peer.sh SANDBOX CHARACTER [COUNTS...]
# Forward pipeline (or $PIPELINE: forward, forward_plus, deferred, visbuffer), no shadows, no
# decals, the Fox's Run clip, 1920×1080; $EXTRA: more sandbox arguments (`--pipelined`, `--animation-budget`). The wall time of a frame
# (`wall_ms`: from one frame's submission to the next, waits for the GPU included), the GPU and
# CPU frame, and the CPU frame's parts (`cpu_ms`: animate, propagate, skin, extract, record) are
# medians of frames 60–159 of a 160-frame run.
set -euo pipefail
bin="$1"
character="$2"
shift 2
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1 100 1000 10000)
out=$(mktemp -d)
echo "| foxes | GPU frame | CPU frame | animate | propagate | skin | extract | record (prepare, submit) | wall time a frame | foxes animated a frame |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"
for n in "${counts[@]}"; do
  "$bin" --headless --frames 160 --size 1920x1080 --bench-scene foxes --character "$character" --character-clip Run \
    --instances "$n" --pipeline "${PIPELINE:-forward}" --decal-method off --no-shadows ${EXTRA:-} --stats "$out/peer.jsonl" >/dev/null 2>&1
  python3 - "$out/peer.jsonl" "$n" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if r["frame"] >= 60]
n = int(sys.argv[2])
med = lambda f: statistics.median(f(r) for r in rows)
gpu, cpu, wall = med(lambda r: r["gpu_ms"]["total"]), med(lambda r: r["cpu_ms"]["frame"]), med(lambda r: r["wall_ms"])
part = lambda p: f"{med(lambda r: r['cpu_ms'].get(p, 0.0)):.2f}"
parts = " | ".join(part(p) for p in ("animate", "propagate", "skin", "extract"))
parts += f" | {part('record')} ({part('prepare')}, {part('submit')})"
# Fewer than all of them with the animation budget (`--animation-budget`).
sampled = med(lambda r: r.get("animation", {}).get("sampled", n))
print(f"| {n:,} | {gpu:.2f} ms | {cpu:.2f} ms | {parts} | {wall:.2f} ms | {sampled:,.0f} |")
PY
done
rm -rf "$out"
