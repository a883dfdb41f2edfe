#!/usr/bin/env python3
"""The culling table of docs/BENCHMARKS.md from scripts/bench_culling.sh's --stats files:
for each file (pipeline, instance count) and culling mode, the medians over frames 10-39 of
each mode's 40 frames of CPU record time, CPU extract time, the GPU frame, the culling passes
(cull_clear, cull, depth_pyramid, cull_second), draw calls, and what the GPU drew."""
import json
import re
import statistics
import sys

CULL_PASSES = ("cull_clear", "cull", "depth_pyramid", "cull_second")


def rows(path):
    frames = [json.loads(line) for line in open(path) if line.strip()]
    m = re.search(r"culling_(\w+?)_(\d+)\.jsonl$", path)
    pipeline, count = (m.group(1), int(m.group(2))) if m else ("?", 0)
    by_mode = {}
    for f in frames:
        by_mode.setdefault(f["culling"]["mode"], []).append(f)
    for mode, fs in by_mode.items():
        fs = fs[10:40] if len(fs) >= 40 else fs
        med = lambda get: statistics.median(get(f) for f in fs)
        cull = med(lambda f: sum(f["gpu_ms"].get(p, 0.0) for p in CULL_PASSES))
        drawn = [f["culling"].get("after_occlusion") for f in fs if "after_occlusion" in f["culling"]]
        yield {
            "pipeline": pipeline,
            "instances": count,
            "mode": mode,
            "record": med(lambda f: f["cpu_ms"]["record"]),
            "extract": med(lambda f: f["cpu_ms"]["extract"]),
            "gpu": med(lambda f: f["gpu_ms"]["total"]),
            "cull": cull,
            "draws": med(lambda f: f["counters"]["draw_calls"]),
            "drawn": statistics.median(drawn) if drawn else "-",
            "device": fs[0]["device"],
        }


def main():
    out = [r for path in sys.argv[1:] for r in rows(path)]
    out.sort(key=lambda r: (r["pipeline"], r["instances"], ["off", "frustum", "occlusion"].index(r["mode"])))
    devices = sorted({r["device"] for r in out})
    print(f"Device: {', '.join(devices)}; medians of frames 10-39 of each mode's 40 frames, 1920x1080.\n")
    print("| pipeline | instances | culling | CPU record ms | CPU extract ms | GPU frame ms | culling passes ms | draw calls | drawn |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in out:
        print(f"| {r['pipeline']} | {r['instances']:,} | {r['mode']} | {r['record']:.3f} | {r['extract']:.3f} | {r['gpu']:.2f} | "
              f"{r['cull']:.3f} | {r['draws']:.0f} | {r['drawn']} |")


if __name__ == "__main__":
    main()
