#!/usr/bin/env python3
"""Medians of a sandbox --stats file, per run (as --compare and --compare-lights write them).

    python3 scripts/bench_summary.py STATS.jsonl [STATS.jsonl ...]

A run is a stretch of consecutive frames with one pipeline, decal method, light method and light
settings. For each run, skips the first 10 frames (warm-up) and prints the median GPU time of
every pass and of the frame total, in milliseconds.
"""
import json
import statistics
import sys
from collections import OrderedDict


def summarise(path):
    runs = []
    for line in open(path):
        row = json.loads(line)
        lights = row.get("lights", {})
        lights = dict(lights, direct_light=row.get("direct_light", "none"))
        key = (row["pipeline"], row["decal_method"], row.get("light_method", "all"), row.get("shadows", "none"),
               json.dumps(lights, sort_keys=True))
        if not runs or runs[-1][0] != key:
            runs.append((key, []))
        runs[-1][1].append(row)
    for (pipeline, method, light_method, shadows, lights), rows in runs:
        rows = rows[10:]
        passes = OrderedDict()
        for r in rows:
            for name, ms in r["gpu_ms"].items():
                passes.setdefault(name, []).append(ms)
        cells = " ".join(f"{n}={statistics.median(v):.3f}" for n, v in passes.items())
        # Clustered decals: the medians of what the GPU measured (entries per cluster, decals
        # tested and applied per pixel), where the frames carry them.
        measured = [r["clusters"] for r in rows if "clusters" in r and "entries" in r["clusters"]]
        if measured:
            keys = ["entries", "dropped", "clusters_used", "mean_per_cluster", "max_per_cluster", "mean_tested", "max_tested",
                    "mean_applied", "max_applied", "capacity", "grows"]
            cells += " " + " ".join(f"{k}={statistics.median(m[k] for m in measured):g}" for k in keys)
        measured = [r["light_tiles"] for r in rows if "light_tiles" in r and "entries" in r["light_tiles"]]
        if measured:
            keys = ["entries", "mean_per_tile", "max_per_tile", "overflowed", "capacity", "grows"]
            cells += " " + " ".join(f"{k}={statistics.median(m[k] for m in measured):g}" for k in keys)
        config = json.loads(lights)
        label = f"lights={light_method} shadows={shadows}"
        if config:
            label += (f" tile={config['tile_size']} aabb={int(config['aabb'])} depth_mask={int(config.get('depth_mask', False))}"
                      f" shadow_ray_culling={int(config['shadow_ray_culling'])}"
                      f" normals={config['normals']}")
        print(f"{path} {pipeline}/{method} {label} frames={len(rows)} {cells}")


for p in sys.argv[1:]:
    summarise(p)
