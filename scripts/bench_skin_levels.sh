#!/usr/bin/env bash
# Skinning a far character's level of detail only (render/src/skinning) against skinning every
# vertex (--full-skinning), in one call, on the `foxes` and `crowd` scenes: GPU frame, the
# skinning pass, the vertices skinned, medians of frames 15-49 of 60 at 1920x1080.
# Usage: scripts/bench_skin_levels.sh SANDBOX CHARACTER [COUNT]
set -euo pipefail
bin=$1 character=$2 count=${3:-10000}
out=$(mktemp -d)
configs=(
  "peer:--pipeline forward --decal-method off --no-shadows"
  "nothing_traced:--pipeline visbuffer --no-shadows --ao screen_space --reflections off"
  "every_default:--pipeline deferred"
)
for scene in foxes crowd; do
  for c in "${configs[@]}"; do
    name=${c%%:*} args=${c#*:}
    for mode in levels full; do
      flag=""; [ "$mode" = full ] && flag="--full-skinning"
      # shellcheck disable=SC2086
      timeout 180 "$bin" --headless --size 1920x1080 --bench-scene "$scene" --character "$character" --character-clip Run \
        --instances "$count" --frames 60 $args $flag --stats "$out/$scene-$name-$mode.jsonl" >"$out/log" 2>&1 || { tail -5 "$out/log"; exit 1; }
    done
  done
done
python3 - "$out" "$count" <<'PY'
import json, statistics, sys
out, count = sys.argv[1], int(sys.argv[2])
print(f"{count:,} foxes, 1920x1080, medians of frames 15-49")
print("| scene | run | skinning | GPU frame | skinning pass (GPU ms) | vertices skinned | CPU frame |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for scene in ["foxes", "crowd"]:
    for name in ["peer", "nothing_traced", "every_default"]:
        for mode in ["full", "levels"]:
            rows = [json.loads(l) for l in open(f"{out}/{scene}-{name}-{mode}.jsonl")]
            rows = [r for r in rows if 15 <= r["frame"] < 50]
            med = lambda f: statistics.median(f(r) for r in rows)
            print(f"| {scene} | {name} | {mode} | {med(lambda r: r['gpu_ms']['total']):.2f} | {med(lambda r: r['gpu_ms'].get('skinning', 0.0)):.2f} "
                  f"| {med(lambda r: r['counters']['skinned_vertices']):,.0f} | {med(lambda r: r['cpu_ms']['frame']):.2f} |")
PY
rm -rf "$out"
