#!/usr/bin/env bash
# The tile depth mask on and off (docs/lights-and-shadows.md, "Light lists"), on a GPU machine with
# a release sandbox:
#   scripts/bench_depth_mask.sh SANDBOX OUT_DIR; python3 scripts/bench_summary.py OUT_DIR/*.jsonl
# The many-lights scene (28,587 lights, 5 cm radius) in the visibility buffer with every default,
# --compare-direct-light each way, then the peer scene's 28 lights with a ray per light.
set -uo pipefail
bin="$1"; out="$2"; mkdir -p "$out"
for mask in on off; do
  extra=""; [ "$mask" = off ] && extra="--no-light-depth-mask"
  timeout 200 "$bin" --headless --frames 40 --size 1920x1080 --bench-scene many-lights --pipeline visbuffer --light-radius 0.05 \
    --compare-direct-light $extra --stats "$out/many_lights_mask_$mask.jsonl" > "$out/log_$mask.txt" 2>&1 || echo "run $mask failed: $?"
done
for mask in on off; do
  extra=""; [ "$mask" = off ] && extra="--no-light-depth-mask"
  timeout 100 "$bin" --headless --frames 60 --size 1920x1080 --bench-scene decals-and-lights --pipeline visbuffer \
    --direct-light exhaustive $extra --stats "$out/lights28_mask_$mask.jsonl" > /dev/null 2>&1 || echo "28 $mask failed"
done
