#!/usr/bin/env bash
# The decal benchmarks of docs/experiments/ records (decals-ray-pipeline-pass.md, decals-count-exact-blas.md,
# decals-clustered.md), run on a GPU machine with a release sandbox:
#   scripts/bench_decals.sh SANDBOX OUT_DIR
# 1. seed 000's three scenarios at 1920×1080, every pipeline and decal method the device runs in
#    one process (--compare, 60 frames each), with a screenshot of the last combination;
# 2. N = 10,000 / 100,000 / 1,000,000 decals scattered over the courtyard with 1 % moving every
#    frame, deferred pipeline, ray-tracing-pipeline decals (acceleration-structure work and the
#    decal pass), then clustered decals at 100,000 and 1,000,000.
# Then the medians per pass (scripts/bench_summary.py) go to OUT_DIR/summary.txt.
set -euo pipefail
bin="$1"
out="$2"
mkdir -p "$out"
for scene in few-blended-decals decals-and-lights many-decals; do
  "$bin" --headless --frames 60 --size 1920x1080 --bench-scene "$scene" --compare --stats "$out/cmp_$scene.jsonl" \
    --screenshot "$out/$scene.png"
done
for n in 10000 100000 1000000; do
  "$bin" --headless --frames 60 --size 1920x1080 --decals "$n" --move-decals 1 --pipeline deferred --decal-method ray_pipeline \
    --stats "$out/decals_$n.jsonl"
done
for n in 100000 1000000; do
  "$bin" --headless --frames 60 --size 1920x1080 --decals "$n" --move-decals 1 --pipeline deferred --decal-method clustered \
    --stats "$out/clustered_$n.jsonl"
done
python3 "$(dirname "$0")/bench_summary.py" "$out"/*.jsonl | tee "$out/summary.txt"
