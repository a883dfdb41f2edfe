#!/usr/bin/env python3
"""The culling table of docs/experiments/culling-indirect-draws.md from scripts/bench_culling.sh's --stats files:
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
    # culling_PIPELINE_N.jsonl (scripts/bench_culling.sh) or LABEL_PIPELINE_N.jsonl.
    m = re.search(r"([^/_]+)_(\w+?)_(\d+)\.jsonl$", path)
    label, pipeline, count = (m.group(1), m.group(2), int(m.group(3))) if m else ("?", "?", 0)
    if label != "culling":
        pipeline = f"{label} {pipeline}"
    by_mode = {}
    for f in frames:
        # Builds from before culling have no "culling" key: every instance drawn, one draw each.
        by_mode.setdefault(f.get("culling", {}).get("mode", "before"), []).append(f)
    for mode, fs in by_mode.items():
        fs = fs[10:40] if len(fs) >= 40 else fs
        med = lambda get: statistics.median(get(f) for f in fs)
        cull = med(lambda f: sum(f["gpu_ms"].get(p, 0.0) for p in CULL_PASSES))
        drawn = [
            f["culling"]["after_occlusion"] if "culling" in f else f["counters"]["instances"]
            for f in fs
            if "culling" not in f or "after_occlusion" in f["culling"]
        ]
        yield {
            "pipeline": pipeline,
            "instances": count,
            "mode": mode,
            "record": med(lambda f: f["cpu_ms"]["record"]),
            "extract": med(lambda f: f["cpu_ms"]["extract"]),
            "gpu": med(lambda f: f["gpu_ms"]["total"]),
            "cull": cull,
            "draws": med(lambda f: f["counters"].get("draw_calls", -1)),
            "drawn": statistics.median(drawn) if drawn else "-",
            "device": fs[0]["device"],
        }


def main():
    out = [r for path in sys.argv[1:] for r in rows(path)]
    out.sort(key=lambda r: (r["pipeline"], r["instances"], ["before", "off", "frustum", "occlusion"].index(r["mode"])))
    devices = sorted({r["device"] for r in out})
    print(f"Device: {', '.join(devices)}; medians of frames 10-39 of each mode's 40 frames, 1920x1080.\n")
    print("| pipeline | instances | culling | CPU record ms | CPU extract ms | GPU frame ms | culling passes ms | draw calls | drawn |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for r in out:
        draws = "-" if r["draws"] < 0 else f"{r['draws']:.0f}"
        print(f"| {r['pipeline']} | {r['instances']:,} | {r['mode']} | {r['record']:.3f} | {r['extract']:.3f} | {r['gpu']:.2f} | "
              f"{r['cull']:.3f} | {draws} | {r['drawn']} |")


if __name__ == "__main__":
    main()
