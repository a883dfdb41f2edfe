#!/usr/bin/env bash
# The crowd scene (`--bench-scene crowd`: 10,000 foxes, every default on) in place and pipelined,
# for each sandbox named on the command line, on a GPU machine:
#   scripts/bench_crowd.sh Fox.glb NAME=SANDBOX [NAME=SANDBOX...]
# 60 frames at 1920×1080 a run; prints medians of frames 15–49: the GPU frame, the wall time a
# frame, every CPU part (`cpu_ms`), the refit counters and how many of those frames submitted their
# recorded commands again. A sandbox named `old` runs in place
# only (builds before `--pipelined`). $EXTRA: more sandbox arguments (`--animation-budget`).
set -uo pipefail
fox="$1"
shift
out=$(mktemp -d)
for spec in "$@"; do
  name="${spec%%=*}"
  bin="${spec#*=}"
  for extra in "" "--pipelined"; do
    [ "$name" = old ] && [ -n "$extra" ] && continue
    timeout 150 "$bin" --headless --frames 60 --size 1920x1080 --bench-scene crowd --character "$fox" $extra ${EXTRA:-} \
      --stats "$out/crowd.jsonl" >/dev/null 2>&1 || echo "run failed: $name $extra"
    python3 - "$out/crowd.jsonl" "$name ${extra:-in place}" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if 15 <= r["frame"] < 50]
med = lambda f: statistics.median(f(r) for r in rows)
c = lambda k: med(lambda r: r["counters"].get(k, 0))
cpu = " ".join(f"{k} {med(lambda r: r['cpu_ms'][k]):.2f}" for k in rows[0]["cpu_ms"])
print(f"crowd {sys.argv[2]}: {rows[0]['pipeline']}, GPU {med(lambda r: r['gpu_ms']['total']):.2f}, "
      f"wall {med(lambda r: r['wall_ms']):.2f}; cpu: {cpu}; refits {c('scene_blas_refits')} "
      f"deferred {c('scene_blas_refits_deferred')} skinned {c('skinned_meshes')}; "
      f"commands reused in {sum(bool(r['counters'].get('commands_reused')) for r in rows)} of {len(rows)} frames")
PY
  done
done
rm -rf "$out"
