#!/usr/bin/env bash
# The passes compact vertices change (the G-buffer, the visibility buffer, skinning), two
# builds in one call, for docs/experiments/content-compact-vertices.md:
#   scripts/bench_vertex_passes.sh BEFORE AFTER CHARACTER [FOXES]
# `--bench-scene foxes` (10,000 by default) at 1920×1080, no shadows or decals, deferred then
# visibility buffer; medians of frames 30–89 of a 90-frame run, each build twice, alternating.
set -euo pipefail
before="$1"
after="$2"
character="$3"
foxes="${4:-10000}"
out=$(mktemp -d)
echo "| build | pipeline | run | gbuffer or visibility | skinning | scene_blas_refit | GPU frame |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for run in 1 2; do
  for pipeline in deferred visbuffer; do
    for build in before after; do
      bin=$before
      [ "$build" = after ] && bin=$after
      "$bin" --headless --frames 90 --size 1920x1080 --bench-scene foxes --character "$character" --character-clip Run \
        --instances "$foxes" --pipeline "$pipeline" --decal-method off --no-shadows --stats "$out/s.jsonl" >/dev/null 2>&1
      python3 - "$out/s.jsonl" "$build" "$pipeline" "$run" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if r["frame"] >= 30]
med = lambda k: statistics.median(r["gpu_ms"].get(k, 0.0) for r in rows)
raster = "gbuffer" if sys.argv[3] == "deferred" else "visibility"
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {med(raster):.2f} ms | {med('skinning'):.2f} ms | {med('scene_blas_refit'):.2f} ms | {med('total'):.2f} ms |")
PY
    done
  done
done
rm -rf "$out"
