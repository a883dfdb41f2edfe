#!/usr/bin/env bash
# Stochastic direct lighting against a ray per light (issue 52; render/src/lights/sampling), run on
# a GPU machine with a release sandbox:
#   scripts/bench_direct_light.sh SANDBOX OUT_DIR
# 1. seed 000 §5.2.5's 28,587 point lights (`--bench-scene many-lights`) with a 5 cm radius, in the
#    visibility buffer with every default on: exhaustive, stochastic, auto, then exhaustive again
#    (--compare-direct-light, one process, 40 frames each);
# 2. the peer scene's 28 lights (`--bench-scene decals-and-lights`) the same way, 60 frames each;
# 3. pictures of the many-lights scene with sampled shadows, and exhaustive ones.
# Then the medians per run (scripts/bench_summary.py) go to OUT_DIR/summary.txt.
set -euo pipefail
bin="$1"
out="$2"
mkdir -p "$out"
"$bin" --headless --frames 40 --size 1920x1080 --bench-scene many-lights --pipeline visbuffer --light-radius 0.05 \
  --compare-direct-light --stats "$out/many_lights.jsonl"
"$bin" --headless --frames 60 --size 1920x1080 --bench-scene decals-and-lights --pipeline visbuffer \
  --compare-direct-light --stats "$out/lights28.jsonl"
for d in stochastic exhaustive; do
  "$bin" --headless --frames 40 --size 1920x1080 --bench-scene many-lights --pipeline visbuffer --light-radius 0.05 \
    --direct-light "$d" --screenshot "$out/many_lights_$d.png"
done
python3 "$(dirname "$0")/bench_summary.py" "$out"/*.jsonl | tee "$out/summary.txt"
