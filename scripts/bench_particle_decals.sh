#!/usr/bin/env bash
# GPU-born decals' benchmark (docs/experiments/particles-gpu.md) with a release sandbox:
#   scripts/bench_particle_decals.sh SANDBOX [PARTICLES...]
# `--bench-scene particles --particles N` (default 120,000: the fountain's particles land about
# 1,000 a frame at the headless 60 frames a second), 1920×1080, every other setting the
# sandbox's default, run without and then with `--particle-decals` (each particle leaves a
# decal where it first lands). Prints the medians of frames 90–179 of 180-frame runs: decals
# born a frame (from the GPU's count), the simulation pass (which writes them), the ring's BLAS call
# (segments rebuilt or refit) and TLAS update (medians; then the mean a frame of the three and the share of
# frames that rebuilt), the GPU frame and the CPU frame; then, per count, the passes
# whose medians grew most with the decals (building them, and applying them).
set -euo pipefail
bin="$1"
shift
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(120000)
out=$(mktemp -d)
echo "| run | decals born a frame | simulate | ring BLAS (build or refit) | ring TLAS | building, mean a frame | GPU frame | CPU frame |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
for n in "${counts[@]}"; do
for decals in "" "--particle-decals"; do
  "$bin" --headless --frames 180 --size 1920x1080 --bench-scene particles --particles "$n" $decals ${PIPELINE:+--pipeline "$PIPELINE"} \
    --stats "$out/p.jsonl" >/dev/null 2>&1
  cp "$out/p.jsonl" "$out/run${decals:+-decals}.jsonl"
  python3 - "$out/p.jsonl" "$n" "$decals" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if r["frame"] >= 90]
med = lambda f: statistics.median(f(r) for r in rows)
gpu = lambda name: med(lambda r: r["gpu_ms"].get(name, 0.0))
born = [r.get("particles", {}).get("decals_born", 0) for r in rows]
per_frame = (born[-1] - born[0]) / max(1, rows[-1]["particles"]["measured_frame"] - rows[0]["particles"]["measured_frame"])
ring = lambda r: r["gpu_ms"].get("particle_decal_blas_build", 0.0) + r["gpu_ms"].get("particle_decal_blas_update", 0.0)
blas = med(ring)
# Builds come every few frames: the mean is what building costs a frame.
building = statistics.mean(ring(r) + r["gpu_ms"].get("particle_decal_tlas_build", 0.0) for r in rows)
builds = sum(1 for r in rows if r["gpu_ms"].get("particle_decal_blas_build", 0.0) > 0) / len(rows)
name = f"{int(sys.argv[2]):,} particles" + (", leaving decals" if sys.argv[3] else "")
print(f"| {name} | {per_frame:,.0f} | {gpu('particles_simulate'):.3f} ms | {blas:.3f} ms | {gpu('particle_decal_tlas_build'):.3f} ms | "
      f"{building:.3f} ms ({builds:.0%} builds) | "
      f"{gpu('total'):.2f} ms | {med(lambda r: r['cpu_ms']['frame']):.2f} ms |")
PY
done
python3 - "$out/run.jsonl" "$out/run-decals.jsonl" "$n" >> "$out/grew.txt" <<'PY'
import json, statistics, sys
def medians(path):
    rows = [json.loads(l) for l in open(path)]
    rows = [r for r in rows if r["frame"] >= 90]
    names = {k for r in rows for k in r["gpu_ms"]}
    return {k: statistics.median(r["gpu_ms"].get(k, 0.0) for r in rows) for k in names if k != "total"}
a, b = medians(sys.argv[1]), medians(sys.argv[2])
grew = sorted(((b.get(k, 0.0) - a.get(k, 0.0), k) for k in set(a) | set(b)), reverse=True)[:6]
print(f"{int(sys.argv[3]):,} particles, grew with decals: " + ", ".join(f"{k} +{d:.3f} ms" for d, k in grew))
PY
done
echo
cat "$out/grew.txt"
rm -rf "$out"
