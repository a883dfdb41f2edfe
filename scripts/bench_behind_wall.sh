#!/usr/bin/env bash
# PEERS.md's "many instances behind a wall" rebuilt in our sandbox (--bench-scene behind-wall):
# N boxes behind a wall, 20 in front, a floor and the sun, no shadows (as Bevy was measured), at
# 1920×1080 in the deferred, visibility-buffer and Forward+ pipelines, every culling mode in one
# process (--compare-culling, 40 frames each):
#   scripts/bench_behind_wall.sh SANDBOX OUT_DIR [N...]
# then the table (scripts/culling_table.py).
set -euo pipefail
bin="$1"
out="$2"
shift 2
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1600 16000 160000)
mkdir -p "$out"
for n in "${counts[@]}"; do
  for pipeline in deferred visbuffer forward_plus; do
    "$bin" --headless --frames 40 --size 1920x1080 --bench-scene behind-wall --instances "$n" --pipeline "$pipeline" \
      --decal-method off --no-shadows --compare-culling --stats "$out/wall_${pipeline}_${n}.jsonl" >/dev/null
  done
done
python3 "$(dirname "$0")/culling_table.py" "$out"/wall_*.jsonl | tee "$out/wall.md"
