#!/usr/bin/env python3
"""Summarises `sandbox --compare-reflections --stats FILE` runs (issue: reflections) as a
Markdown table: per pipeline and configuration, the median GPU milliseconds of the reflection
passes, the shadow pass and the frame, and the rays traced, over the frames of each run after
its first SKIP (the switch). The first run of a file (reflections off, run again last) only
warms the GPU up and is left out.

    python3 scripts/reflections_table.py [--skip N] STATS.json...
"""
import json
import statistics
import sys


def main():
    args = sys.argv[1:]
    skip = 5
    if args[:1] == ["--skip"]:
        skip, args = int(args[1]), args[2:]
    groups = []  # (key, frames) per run, in order
    for path in args:
        first = len(groups)
        for line in open(path):
            d = json.loads(line)
            r = d["reflections"]
            key = (d["pipeline"], r["mode"], r["half_resolution"], r["decals_at_hits"])
            if len(groups) == first or groups[-1][0] != key:
                groups.append((key, []))
            groups[-1][1].append(d)
        if len(groups) - first > 1 and groups[first][0] == groups[-1][0]:
            del groups[first]  # the warm-up
    print("| pipeline | reflections | decals at hits | rays | ray pass ms | resolve ms | shadow pass ms | frame ms |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for key, run in groups:
        frames = run[skip:] or run
        med = lambda f: statistics.median(f(d) for d in frames)
        gpu = lambda name: med(lambda d: d["gpu_ms"].get(name, 0.0))
        shadows = med(lambda d: sum(v for k, v in d["gpu_ms"].items() if k.startswith("shadows")))
        rays = med(lambda d: d["reflections"].get("rays", 0))
        pipeline, mode, half, decals = key
        label = {"off": "off", "screen_space": "screen space"}.get(mode, "ray traced") + ("" if mode == "off" else (", half" if half else ", full"))
        print(f"| {pipeline} | {label} | {'yes' if decals and mode == 'ray_traced' else '-'} | {rays:.0f} | {gpu('reflection_rays'):.3f} | "
              f"{gpu('reflection_resolve'):.3f} | {shadows:.3f} | {gpu('total'):.3f} |")


if __name__ == "__main__":
    main()
