#!/usr/bin/env python3
"""Medians of a sandbox --stats file, per pipeline and decal method (as --compare writes them).

    python3 scripts/bench_summary.py STATS.jsonl [STATS.jsonl ...]

For each file and each (pipeline, decal_method) run, skips the run's first 10 frames (warm-up)
and prints the median GPU time of every pass and of the frame total, in milliseconds.
"""
import json
import statistics
import sys
from collections import OrderedDict


def summarise(path):
    runs = OrderedDict()
    for line in open(path):
        row = json.loads(line)
        runs.setdefault((row["pipeline"], row["decal_method"]), []).append(row)
    for (pipeline, method), rows in runs.items():
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
        print(f"{path} {pipeline}/{method} frames={len(rows)} {cells}")


for p in sys.argv[1:]:
    summarise(p)
