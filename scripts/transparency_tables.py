#!/usr/bin/env python3
"""Seed 002's Tables 4.2 to 4.5 from a `sandbox --compare-transparency --stats F.jsonl` run.

    python3 scripts/transparency_tables.py F.jsonl

A run is a stretch of consecutive frames with one pipeline, transparency method, refraction
setting, shadow method, light count and glass shadows (coloured or opaque). Each run's first 10 frames are warm-up (the first run,
twice as long, skips its whole first half); the median GPU frame time (`gpu_ms.total`) of its
last 30 frames is the run's figure. Prints Markdown tables of
milliseconds with the seed's ratios beside them.
"""
import json
import statistics
import sys


def runs(path):
    out = []
    for line in open(path):
        row = json.loads(line)
        key = (row["pipeline"], row.get("transparency", "?"), row.get("refraction", True), row.get("shadows", "none"),
               row["counters"]["lights"], row["lights"].get("coloured_shadows", True))
        if not out or out[-1][0] != key:
            out.append((key, []))
        out[-1][1].append(row)
    medians = {}
    for key, rows in out:
        # The first run comes twice (warm-up) and merges into one: skip its first half.
        rows = rows[max(10, len(rows) - 30):] if len(rows) >= 20 else rows[len(rows) // 2:]
        medians[key] = statistics.median(r["gpu_ms"]["total"] for r in rows)
    return medians


def main():
    m = runs(sys.argv[1])
    counts = sorted({k[4] for k in m})
    traced = next(iter(sorted({k[3] for k in m if k[3] not in ("none", "maps")})), None)

    print("Table 4.2: interlaced deferred, no shadows, GPU ms per frame (seed: FPS)")
    print("| lights | no refraction | refraction | refraction cost |")
    print("| --- | --- | --- | --- |")
    for n in counts:
        a, b = m.get(("deferred", "interlaced", False, "none", n, True)), m.get(("deferred", "interlaced", True, "none", n, True))
        if a and b:
            print(f"| {n} | {a:.3f} | {b:.3f} | {b - a:+.3f} ms ({(b / a - 1) * 100:+.1f} %) |")

    for title, shadows in [("Table 4.4: with shadows", traced), ("Table 4.5: without shadows", "none")]:
        if shadows is None:
            continue
        print()
        print(f"{title} ({shadows}), GPU ms per frame; ratios over interlaced (seed: forward 1.57x at 32 shadowed lights, 3.7x unshadowed;"
              " depth peeling at least 1.18x)")
        print("| lights | interlaced deferred | depth-peeled deferred | deferred + forward transparency | forward | peeling / interlaced | forward / interlaced |")
        print("| --- | --- | --- | --- | --- | --- | --- |")
        for n in counts:
            i = m.get(("deferred", "interlaced", True, shadows, n, True))
            p = m.get(("deferred", "depth_peeling", True, shadows, n, True))
            # Forward glass does not refract: the forward runs say refraction false.
            d = m.get(("deferred", "forward", False, shadows, n, True))
            f = m.get(("forward", "forward", False, shadows, n, True))
            if i and p and d and f:
                print(f"| {n} | {i:.3f} | {p:.3f} | {d:.3f} | {f:.3f} | {p / i:.2f}x | {f / i:.2f}x |")

    print()
    print("Table 4.3: interlaced deferred with refraction, glass casting opaque or coloured shadows, GPU ms per frame "
          "(seed, shadow maps: coloured shadows cost 13 % at 2 lights to 34 % at 64)")
    print(f"| lights | {traced} opaque | {traced} coloured | cost | maps opaque | maps coloured | cost |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for n in counts:
        cells = []
        for method in (traced, "maps"):
            o = m.get(("deferred", "interlaced", True, method, n, False))
            c = m.get(("deferred", "interlaced", True, method, n, True))
            cells += [f"{o:.3f}", f"{c:.3f}", f"{c - o:+.3f} ms ({(c / o - 1) * 100:+.1f} %)"] if o and c else ["", "", ""]
        if any(cells):
            print(f"| {n} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
