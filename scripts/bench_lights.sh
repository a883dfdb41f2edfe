#!/usr/bin/env bash
# The light-culling and shadow benchmarks of docs/experiments/lights-*.md, run on a GPU machine with a
# release sandbox:
#   scripts/bench_lights.sh SANDBOX OUT_DIR
# 1. seed 001 Tables 5.1 and 5.2: the ten-point-lights scene at 1920×1080 with a fixed camera, each
#    optimisation row and tile size in one process (--compare-lights, 120 frames each);
# 2. the 28-light decals-and-lights scene (100 puddle decals) in every pipeline: every light and
#    tiled culling without shadows (what the lighting passes cost before and after culling), then
#    tiled with shadows, and for deferred and visibility buffer the same with their lighting as
#    full-screen fragment passes instead of compute, and with ray-query lights (60 frames each);
# 3. seed 000 §5.2.5's 28,587 small point lights in every pipeline, no shadows (the seed's
#    scenario has none): every light against tiled, and in deferred and visibility buffer also
#    ray-query lights, each pipeline's methods in one process (--compare-light-methods), 14
#    frames each (every-light shading is slow; the summary skips 10 frames of warm-up).
# Then the medians per run (scripts/bench_summary.py) go to OUT_DIR/summary.txt.
set -euo pipefail
bin="$1"
out="$2"
mkdir -p "$out"
"$bin" --headless --frames 120 --size 1920x1080 --bench-scene ten-point-lights --decal-method off --compare-lights \
  --stats "$out/table5.jsonl" --screenshot "$out/ten-point-lights.png"
"$bin" --headless --frames 3 --size 1920x1080 --bench-scene ten-point-lights --decal-method off --tile-size 8 \
  --debug-view light-heatmap --screenshot "$out/ten-point-lights-heatmap.png"
"$bin" --headless --frames 3 --size 1920x1080 --bench-scene ten-point-lights --decal-method off \
  --debug-view shadow-rays --screenshot "$out/ten-point-lights-rays.png"
for pipeline in forward deferred visbuffer forward_plus; do
  for run in "all --no-shadows" "tiled --no-shadows" "tiled" "tiled --fragment-shading" "ray_query --no-shadows"; do
    [ "$pipeline" = forward_plus ] && [ "$run" != tiled ] && continue
    case "$pipeline/$run" in forward/*fragment* | forward/ray_query*) continue ;; esac
    name="lights28_${pipeline}_${run// /}"
    # shellcheck disable=SC2086
    "$bin" --headless --frames 60 --size 1920x1080 --bench-scene decals-and-lights --decal-method ray_pipeline --pipeline "$pipeline" \
      --lights $run --stats "$out/$name.jsonl"
  done
done
"$bin" --headless --frames 14 --size 1920x1080 --bench-scene many-lights --decal-method off --no-shadows --pipeline forward \
  --lights all --stats "$out/many_forward_all.jsonl"
"$bin" --headless --frames 14 --size 1920x1080 --bench-scene many-lights --decal-method off --no-shadows --pipeline forward \
  --lights tiled --stats "$out/many_forward_tiled.jsonl"
for pipeline in deferred visbuffer; do
  "$bin" --headless --frames 14 --size 1920x1080 --bench-scene many-lights --decal-method off --no-shadows --pipeline "$pipeline" \
    --compare-light-methods --stats "$out/many_${pipeline}_methods.jsonl"
  "$bin" --headless --frames 14 --size 1920x1080 --bench-scene many-lights --decal-method off --no-shadows --pipeline "$pipeline" \
    --lights tiled --fragment-shading --stats "$out/many_${pipeline}_tiled--fragment-shading.jsonl"
done
python3 "$(dirname "$0")/bench_summary.py" "$out"/*.jsonl | tee "$out/summary.txt"
