#!/usr/bin/env python3
"""The skinning table of docs/experiments/skinning-gpu.md from scripts/bench_skinning.sh's stats files:
medians of frames 20-59 (the first frames build every posed mesh's BLAS)."""
import json
import statistics
import sys


def median(rows, get):
    values = [v for v in (get(r) for r in rows) if v is not None]
    return statistics.median(values) if values else float("nan")


print("| foxes | skinned vertices | CPU animate | CPU extract | CPU frame | skinning pass | BLAS refits | refits+rebuilds | GPU frame |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
results = []
for path in sys.argv[1:]:
    rows = [json.loads(line) for line in open(path)]
    rows = [r for r in rows if r["frame"] >= 20]
    if not rows:
        continue
    foxes = rows[-1]["counters"]["skinned_meshes"]
    results.append((foxes, (
        f"| {foxes:,} | {rows[-1]['counters']['skinned_vertices']:,} "
        f"| {median(rows, lambda r: r['cpu_ms'].get('animate')):.3f} ms "
        f"| {median(rows, lambda r: r['cpu_ms']['extract']):.3f} ms "
        f"| {median(rows, lambda r: r['cpu_ms']['frame']):.2f} ms "
        f"| {median(rows, lambda r: r['gpu_ms'].get('skinning', 0.0)):.3f} ms "
        f"| {median(rows, lambda r: r['gpu_ms'].get('scene_blas_refit', 0.0)):.3f} ms "
        f"| {median(rows, lambda r: r['counters']['scene_blas_refits'] + r['counters']['scene_blas_builds']):.0f} "
        f"| {median(rows, lambda r: r['gpu_ms']['total']):.2f} ms |"
    )))
for _, line in sorted(results):
    print(line)
if results:
    print(f"\n{rows[-1]['device']}")
