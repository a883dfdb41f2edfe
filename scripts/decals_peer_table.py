#!/usr/bin/env python3
"""The table of scripts/bench_decals_peer.sh: for each --stats file LABEL_PIPELINE_METHOD_N.jsonl
the medians over frames 20-119 of the GPU frame, the decal passes (clustered binning: clear,
count, scan, fill; the decal pass of any method), the pipeline's depth prepass or G-buffer and
its shading pass, and the decals applied per shaded pixel where the GPU counted them."""
import json
import re
import statistics
import sys

BINNING = ("decal_clusters_clear", "decal_clusters_count", "decal_clusters_scan", "decal_clusters_fill", "decal_clusters_bin")
DECAL_PASSES = ("decal_pass_clustered", "decal_pass_ray_pipeline", "decal_pass_ray_query")
SHADING = ("prepass", "forward", "gbuffer", "lighting", "visibility", "visbuffer_shade")


def main():
    rows = []
    for path in sys.argv[1:]:
        m = re.search(r"([^/]+?)_(forward_plus|forward|deferred|visbuffer)_(\w+?)_(\d+)\.jsonl$", path)
        if not m:
            continue
        label, pipeline, method, n = m.group(1), m.group(2), m.group(3), int(m.group(4))
        frames = [json.loads(line) for line in open(path) if line.strip()]
        fs = frames[20:120] if len(frames) >= 120 else frames
        med = lambda get: statistics.median(get(f) for f in fs)
        passes = lambda names: med(lambda f: sum(f["gpu_ms"].get(p, 0.0) for p in names))
        applied = [f["clusters"]["mean_applied"] for f in fs if f.get("clusters", {}).get("pixels", 0) > 0]
        rows.append((label, pipeline, n, method, med(lambda f: f["gpu_ms"]["total"]), passes(BINNING), passes(DECAL_PASSES),
                     " ".join(f"{p} {passes([p]):.2f}" for p in SHADING if any(p in f["gpu_ms"] for f in fs)),
                     f"{statistics.median(applied):.2f}" if applied else "-", fs[-1].get("tier", "?"), fs[-1].get("device", "?")))
    rows.sort()
    print("| build | pipeline | decals | method | GPU frame ms | binning ms | decal pass ms | shading passes ms | applied/pixel |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in rows:
        print(f"| {r[0]} | {r[1]} | {r[2]:,} | {r[3]} | {r[4]:.2f} | {r[5]:.3f} | {r[6]:.3f} | {r[7]} | {r[8]} |")
    if rows:
        print(f"\n{rows[0][10]}, tier {rows[0][9]}")


if __name__ == "__main__":
    main()
