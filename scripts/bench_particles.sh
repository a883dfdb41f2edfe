#!/usr/bin/env bash
# The particles issue's benchmarks (docs/experiments/particles-gpu.md) with a release sandbox:
#   scripts/bench_particles.sh SANDBOX [COUNTS...]
# `--bench-scene particles --particles N` (the courtyard and a fountain keeping N particles
# alive, bouncing on the ground), 1920×1080, every other setting the sandbox's default. Prints
# the medians of frames 90–179 of a 180-frame run: particles alive, the emission, simulation,
# lighting and drawing passes, the GPU frame and the CPU frame.
set -euo pipefail
bin="$1"
shift
counts=("$@")
[ ${#counts[@]} -gt 0 ] || counts=(0 100000 1000000)
out=$(mktemp -d)
echo "| particles kept alive | alive (measured) | emit | simulate | light | draw | GPU frame | CPU frame |"
echo "| --- | --- | --- | --- | --- | --- | --- | --- |"
for n in "${counts[@]}"; do
  "$bin" --headless --frames 180 --size 1920x1080 --bench-scene particles --particles "$n" ${PIPELINE:+--pipeline "$PIPELINE"} \
    --stats "$out/p.jsonl" >/dev/null 2>&1
  python3 - "$out/p.jsonl" "$n" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
rows = [r for r in rows if r["frame"] >= 90]
n = int(sys.argv[2])
med = lambda f: statistics.median(f(r) for r in rows)
gpu = lambda name: med(lambda r: r["gpu_ms"].get(name, 0.0))
alive = med(lambda r: r.get("particles", {}).get("alive", 0))
print(f"| {n:,} | {alive:,.0f} | {gpu('particles_emit'):.3f} ms | {gpu('particles_simulate'):.3f} ms | {gpu('particles_light'):.3f} ms | {gpu('particles'):.3f} ms | "
      f"{gpu('total'):.2f} ms | {med(lambda r: r['cpu_ms']['frame']):.2f} ms |")
PY
done
rm -rf "$out"
