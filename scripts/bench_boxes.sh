#!/usr/bin/env bash
# The GPU-driven-scene issue's first table again, before and after: a glTF of N boxes (one mesh,
# N nodes on a grid, written by scripts/boxes_gltf.py; the sandbox frames it and adds a camera
# and lights) at 1920×1080 in the deferred, forward and visibility-buffer pipelines, 40 frames,
# with each sandbox given (a build with GPU culling runs every culling mode, --compare-culling):
#   scripts/bench_boxes.sh OUT_DIR LABEL=SANDBOX [LABEL=SANDBOX...] [-- N...]
# then the table (scripts/culling_table.py OUT_DIR/*.jsonl).
set -euo pipefail
source "$(dirname "$0")/builds.sh"
counts=("${rest[@]}")
[ ${#counts[@]} -gt 0 ] || counts=(1000 10000 50000 100000)
for n in "${counts[@]}"; do
  python3 "$(dirname "$0")/boxes_gltf.py" "$n" "$out/boxes_$n.gltf"
  for entry in "${bins[@]}"; do
    label="${entry%%=*}"
    bin="${entry#*=}"
    compare=()
    if "$bin" --help | grep -q -- --compare-culling; then compare=(--compare-culling); fi
    for pipeline in deferred forward visbuffer; do
      "$bin" --headless --frames 40 --size 1920x1080 --scene "$out/boxes_$n.gltf" --pipeline "$pipeline" --decal-method off \
        "${compare[@]}" --stats "$out/${label}_${pipeline}_${n}.jsonl" --screenshot "$out/${label}_${pipeline}_${n}.png" >/dev/null
    done
  done
  rm "$out/boxes_$n.gltf"
done
python3 "$(dirname "$0")/culling_table.py" "$out"/*.jsonl | tee "$out/boxes.md"
