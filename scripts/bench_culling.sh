#!/usr/bin/env bash
# The GPU-driven scene's benchmark of docs/experiments/culling-indirect-draws.md and
# docs/experiments/culling-command-reuse.md (issue 24), run on a GPU machine with a release sandbox:
#   scripts/bench_culling.sh SANDBOX OUT_DIR [INSTANCES...]
# The many-instances bench scene (a city of props walled in by buildings, the camera in a
# street) at 1920×1080 for each instance count (default 1,000 10,000 100,000 1,000,000), in the
# deferred, forward and visibility-buffer pipelines, every culling mode in one process
# (--compare-culling, 40 frames each), then the table (scripts/culling_table.py: medians of
# frames 10–39 of CPU record time, GPU frame time, the culling passes and what was drawn).
set -euo pipefail
bin="$1"
out="$2"
shift 2
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(1000 10000 100000 1000000)
mkdir -p "$out"
for n in "${counts[@]}"; do
  for pipeline in deferred forward visbuffer; do
    "$bin" --headless --frames 40 --size 1920x1080 --bench-scene many-instances --instances "$n" --pipeline "$pipeline" \
      --decal-method off --compare-culling --stats "$out/culling_${pipeline}_${n}.jsonl" --screenshot "$out/culling_${pipeline}_${n}.png" \
      | grep -E '^device' || true
  done
done
python3 "$(dirname "$0")/culling_table.py" "$out"/culling_*.jsonl | tee "$out/culling.md"
