#!/usr/bin/env bash
# The skinning benchmark of docs/experiments/skinning-gpu.md (issue 25), run on a GPU machine with a release
# sandbox and a skinned character (the shared Fox):
#   scripts/bench_skinning.sh SANDBOX CHARACTER OUT_DIR [COUNTS...]
# The foxes bench scene (COUNT foxes, each walking from its own time, so every pose changes
# every frame) at 1920×1080 in the deferred pipeline, ray-traced shadows, 60 frames, for each
# count (default 1 100 1000 10000), then the table (scripts/skinning_table.py: medians of
# frames 20–59 of CPU animation, extraction and frame time, the skinning pass, the BLAS refits
# and the GPU frame).
set -euo pipefail
bin="$1"
character="$2"
out="$3"
shift 3
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1 100 1000 10000)
mkdir -p "$out"
for n in "${counts[@]}"; do
  "$bin" --headless --frames 60 --size 1920x1080 --bench-scene foxes --character "$character" --instances "$n" \
    --pipeline deferred --decal-method off --stats "$out/foxes_${n}.jsonl" --screenshot "$out/foxes_${n}.png" \
    | grep -E '^device' || true
done
python3 "$(dirname "$0")/skinning_table.py" "$out"/foxes_*.jsonl | tee "$out/skinning.md"
