#!/usr/bin/env bash
# Two sandbox builds on the crowd of animated foxes, in one process each, for docs/experiments/crowds-first-step.md:
#   scripts/bench_crowd_ab.sh CHARACTER OLD_SANDBOX NEW_SANDBOX [COUNT]   (COUNT: 10000)
# Three runs a build at 1920×1080, 60 frames, medians of frames 15–49 (`--stats`): the
# visibility buffer with nothing ray-traced (no shadows, screen-space AO, no reflections);
# deferred with every default (ray-traced shadows, AO and reflections); and the peer scene of
# ../shared/PEERS.md (forward, no shadows, no decals). Then the peer scene's wall time a frame, as
# scripts/bench_foxes_peer.sh measures it (a 160-frame run less a 60-frame run, over 100).
set -euo pipefail
character=$1 old=$2 new=$3 count=${4:-10000}
out=$(mktemp -d)
configs=(
  "nothing_traced:--pipeline visbuffer --no-shadows --ao screen_space --reflections off"
  "every_default:--pipeline deferred"
  "peer:--pipeline forward --decal-method off --no-shadows"
)
for which in old new; do
  bin=$old; [ $which = new ] && bin=$new
  for c in "${configs[@]}"; do
    name=${c%%:*} args=${c#*:}
    # shellcheck disable=SC2086
    "$bin" --headless --frames 60 --size 1920x1080 --bench-scene foxes --character "$character" --character-clip Run \
      --instances "$count" $args --stats "$out/$which-$name.jsonl" >"$out/$which-$name.log" 2>&1 || { tail -5 "$out/$which-$name.log"; exit 1; }
  done
  peer() {
    "$bin" --headless --frames "$1" --size 1920x1080 --bench-scene foxes --character "$character" --character-clip Run \
      --instances "$count" --pipeline forward --decal-method off --no-shadows >/dev/null 2>&1
  }
  t0=$(date +%s.%N); peer 60; t1=$(date +%s.%N); peer 160; t2=$(date +%s.%N)
  echo "$t0 $t1 $t2" >"$out/$which-wall.txt"
done
python3 - "$out" "$count" <<'PY'
import json, statistics, sys
out, count = sys.argv[1], int(sys.argv[2])
def rows(path):
    return [r for r in map(json.loads, open(path)) if 15 <= r["frame"] < 50]
def med(rs, f):
    vals = [f(r) for r in rs]
    vals = [v for v in vals if v is not None]
    return statistics.median(vals) if vals else None
fmt = lambda v: "—" if v is None else f"{v:.2f}"
print(f"{count:,} foxes, 1920×1080, medians of frames 15–49")
print("| run | build | GPU frame | scene BLAS refits (GPU) | skinning (GPU) | CPU frame | animate | propagate | skin | extract | record | BLAS refits a frame |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for name in ["nothing_traced", "every_default", "peer"]:
    for which in ["old", "new"]:
        rs = rows(f"{out}/{which}-{name}.jsonl")
        g = lambda key: med(rs, lambda r: r["gpu_ms"].get(key, 0.0))
        c = lambda key: med(rs, lambda r: r["cpu_ms"].get(key))
        refits = med(rs, lambda r: r["counters"].get("scene_blas_refits", 0))
        print(f"| {name} | {which} | {fmt(g('total'))} | {fmt(g('scene_blas_refit'))} | {fmt(g('skinning'))} | {fmt(c('frame'))} | "
              f"{fmt(c('animate'))} | {fmt(c('propagate'))} | {fmt(c('skin'))} | {fmt(c('extract'))} | {fmt(c('record'))} | {refits} |")
for which in ["old", "new"]:
    t0, t1, t2 = map(float, open(f"{out}/{which}-wall.txt").read().split())
    print(f"peer scene, {which}: wall time a frame {((t2 - t1) - (t1 - t0)) / 100 * 1e3:.1f} ms")
PY
rm -rf "$out"
