#!/usr/bin/env bash
# The CPU side of a crowd of animated foxes, for docs/experiments/crowds-deferred-refits.md:
#   scripts/bench_crowd_cpu.sh CHARACTER COUNT SANDBOX [SANDBOX...]
# Each sandbox build runs three configurations of `--bench-scene foxes` (COUNT foxes, the
# character's Run clip, 1920×1080, 60 frames): the peer scene of ../shared/PEERS.md (forward, no
# shadows, no decals), the visibility buffer with nothing ray-traced, and deferred with every
# default. It prints, per build and configuration, the medians of frames 15–49 of the GPU frame
# and of every part of `cpu_ms` (`--stats`), then the peer scene's wall time a frame (a 160-frame
# run less a 60-frame run, over 100). SCENE=crowd runs the crowd scene instead; BENCH_FLAGS are
# added to every run (for example BENCH_FLAGS="--refit-pixels 0").
set -euo pipefail
character=$1 count=$2
shift 2
out=${OUT:-$(mktemp -d)}
scene=(--headless --size 1920x1080 --bench-scene "${SCENE:-foxes}" --character "$character" --character-clip Run --instances "$count")
configs=(
  "peer:--pipeline forward --decal-method off --no-shadows"
  "nothing_traced:--pipeline visbuffer --no-shadows --ao screen_space --reflections off"
  "every_default:--pipeline deferred"
)
i=0
for bin in "$@"; do
  i=$((i + 1))
  for c in "${configs[@]}"; do
    name=${c%%:*} args=${c#*:}
    # shellcheck disable=SC2086
    timeout 180 "$bin" "${scene[@]}" --frames 60 $args ${BENCH_FLAGS:-} --stats "$out/$i-$name.jsonl" >"$out/$i-$name.log" 2>&1 || { tail -5 "$out/$i-$name.log"; exit 1; }
  done
  # shellcheck disable=SC2086
  peer() { timeout 180 "$bin" "${scene[@]}" --frames "$1" --pipeline forward --decal-method off --no-shadows ${BENCH_FLAGS:-} >/dev/null 2>&1; }
  t0=$(date +%s.%N); peer 60; t1=$(date +%s.%N); peer 160; t2=$(date +%s.%N)
  echo "$t0 $t1 $t2" >"$out/$i-wall.txt"
done
python3 - "$out" "$count" "$@" <<'PY'
import json, statistics, sys
out, count, bins = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
parts = ["frame", "animate", "propagate", "skin", "extract", "record", "prepare", "submit"]
counts = ["scene_blas_refits", "scene_blas_refits_deferred"]
print(f"{count:,} foxes, 1920×1080, medians of frames 15–49 (ms)")
print("| build | run | GPU frame | BLAS refits (GPU) | " + " | ".join(f"CPU {p}" for p in parts) + " | refits | deferred |")
print("| --- | --- | --- | --- | " + " | ".join("---" for _ in parts) + " | --- | --- |")
for i, b in enumerate(bins, 1):
    for name in ["peer", "nothing_traced", "every_default"]:
        rows = [json.loads(l) for l in open(f"{out}/{i}-{name}.jsonl")]
        rows = [r for r in rows if 15 <= r["frame"] < 50]
        med = lambda f: statistics.median(f(r) for r in rows)
        gpu = med(lambda r: r["gpu_ms"]["total"])
        refit = med(lambda r: r["gpu_ms"].get("scene_blas_refit", 0.0))
        cpu = [f"{med(lambda r: r['cpu_ms'][p]):.2f}" if p in rows[0]["cpu_ms"] else "—" for p in parts]
        n = [f"{med(lambda r: r['counters'].get(c, 0)):,.0f}" for c in counts]
        print(f"| {b} | {name} | {gpu:.2f} | {refit:.2f} | " + " | ".join(cpu) + " | " + " | ".join(n) + " |")
for i, b in enumerate(bins, 1):
    t0, t1, t2 = map(float, open(f"{out}/{i}-wall.txt").read().split())
    print(f"{b}: peer scene wall time a frame {((t2 - t1) - (t1 - t0)) / 100 * 1e3:.1f} ms")
PY
