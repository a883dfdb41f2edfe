#!/usr/bin/env bash
# Ray-query lights' drawn shadows on the ray-tracing-pipeline tier (issue 52; render/src/lights/sampling,
# shaders/include/ray_pipeline_lights.glsl), run on a GPU machine with two release sandboxes:
#   scripts/bench_ray_query_lights.sh SANDBOX_BEFORE SANDBOX_AFTER OUT_DIR
# Seed 000 §5.2.5's 28,587 point lights (`--bench-scene many-lights`, 5 cm radius), in the
# visibility buffer and deferred shading, two alternating rounds of: ray-query lights with the
# build before, ray-query lights with the build after, and tiled lights with `stochastic` shadows
# (the build after). Prints the medians of frames 10–39 of every GPU pass over 0.05 ms, with the
# shadows and direct-light method each run applied.
set -euo pipefail
before="$1" after="$2" out="$3"
mkdir -p "$out"
run() { # NAME SANDBOX PIPELINE ARGS...
  local name=$1 bin=$2 pipeline=$3
  shift 3
  timeout 120 "$bin" --headless --frames 40 --size 1920x1080 --bench-scene many-lights --light-radius 0.05 --pipeline "$pipeline" "$@" \
    --stats "$out/$name.jsonl" >"$out/$name.log" 2>&1
  python3 - "$out/$name.jsonl" "$name" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])][10:]
keys = sorted({k for r in rows for k in r["gpu_ms"]})
med = {k: statistics.median(r["gpu_ms"].get(k, 0) for r in rows) for k in keys}
last = rows[-1]
print(sys.argv[2], f"shadows={last.get('shadows')} direct={last.get('direct_light')}", " ".join(f"{k}={v:.3f}" for k, v in med.items() if v > 0.05))
PY
}
for round in 1 2; do
  for pipeline in visbuffer deferred; do
    run "before-ray-query-$pipeline-$round" "$before" "$pipeline" --lights ray_query
    run "after-ray-query-$pipeline-$round" "$after" "$pipeline" --lights ray_query
    run "after-tiled-stochastic-$pipeline-$round" "$after" "$pipeline" --lights tiled --direct-light stochastic
  done
done
