#!/usr/bin/env bash
# Levels of detail on the crowd of animated foxes, for docs/experiments/crowds-lod.md:
#   scripts/bench_lod.sh SANDBOX CHARACTER [COUNT] [LOD_PIXELS] [SCENE]   (10000, 1, foxes)
# SCENE: foxes (the crowd seen from above) or crowd (from eye height at the plaza's edge).
# Each configuration runs in one process with --compare-lod: levels of detail off, on (LOD_PIXELS),
# off again, 60 frames each at 1920×1080; medians of frames 15–49 of each run (`--stats`). The
# configurations are those of scripts/bench_crowd_ab.sh: the visibility buffer with nothing
# ray-traced, deferred with every default, and the peer scene of ../shared/PEERS.md (forward, no
# shadows, no decals). Then the peer scene's wall time a frame with levels of detail off and on
# (a 160-frame run less a 60-frame run, over 100).
set -euo pipefail
bin=$1 character=$2 count=${3:-10000} pixels=${4:-1} bench=${5:-foxes}
out=$(mktemp -d)
configs=(
  "nothing_traced:--pipeline visbuffer --no-shadows --ao screen_space --reflections off"
  "every_default:--pipeline deferred"
  "peer:--pipeline forward --decal-method off --no-shadows"
)
scene=(--headless --size 1920x1080 --bench-scene "$bench" --character "$character" --character-clip Run --instances "$count")
for c in "${configs[@]}"; do
  name=${c%%:*} args=${c#*:}
  # shellcheck disable=SC2086
  "$bin" "${scene[@]}" --frames 60 --compare-lod --lod-pixels "$pixels" $args --stats "$out/$name.jsonl" >"$out/$name.log" 2>&1 || { tail -5 "$out/$name.log"; exit 1; }
done
for lod in 0 "$pixels"; do
  peer() { "$bin" "${scene[@]}" --frames "$1" --lod-pixels "$lod" --pipeline forward --decal-method off --no-shadows >/dev/null 2>&1; }
  t0=$(date +%s.%N); peer 60; t1=$(date +%s.%N); peer 160; t2=$(date +%s.%N)
  echo "$t0 $t1 $t2" >"$out/wall-$lod.txt"
done
python3 - "$out" "$count" "$pixels" "$bench" <<'PY'
import json, statistics, sys
out, count, pixels, bench = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4]
fmt = lambda v: "—" if v is None else f"{v:.2f}"
print(f"--bench-scene {bench}, {count:,} foxes, 1920×1080, medians of frames 15–49 of each run")
print("| run | levels of detail | GPU frame | biggest passes (GPU ms) | triangles drawn | instances by level | CPU frame |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for name in ["nothing_traced", "every_default", "peer"]:
    rows = [json.loads(l) for l in open(f"{out}/{name}.jsonl")]
    for run, label in enumerate(["off", f"{pixels} px", "off again"]):
        rs = [r for r in rows if run * 60 + 15 <= r["frame"] < run * 60 + 50]
        med = lambda f: statistics.median(f(r) for r in rs)
        passes = {k for r in rs for k in r["gpu_ms"] if k != "total"}
        top = sorted(((med(lambda r: r["gpu_ms"].get(k, 0.0)), k) for k in passes), reverse=True)[:3]
        cull = lambda key: med(lambda r: r["culling"].get(key, 0))
        levels = [statistics.median(r["culling"]["lod_instances"][i] for r in rs if "lod_instances" in r["culling"]) for i in range(5)]
        print(f"| {name} | {label} | {fmt(med(lambda r: r['gpu_ms']['total']))} | "
              f"{', '.join(f'{k} {v:.2f}' for v, k in top)} | {cull('triangles'):,.0f} | {[int(x) for x in levels]} | "
              f"{fmt(med(lambda r: r['cpu_ms']['frame']))} |")
for lod in ["0", pixels]:
    t0, t1, t2 = map(float, open(f"{out}/wall-{lod}.txt").read().split())
    print(f"peer scene, --lod-pixels {lod}: wall time a frame {((t2 - t1) - (t1 - t0)) / 100 * 1e3:.1f} ms")
PY
rm -rf "$out"
