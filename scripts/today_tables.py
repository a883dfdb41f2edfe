#!/usr/bin/env python3
"""The tables of scripts/bench_today.sh OUT_DIR: medians of each run's frames after its warm-up
(frames 15-49 of 60, 20-119 of 120, 10-29 of 30) of the GPU frame, its passes and the CPU frame."""
import json
import os
import statistics
import sys

out = sys.argv[1]
PEER_DECALS = {"forward_plus": (2.98, 3.13, 4.01), "deferred": (3.06, 3.22, 4.01)}
PEER_WALL = 2.26
PEER_FOXES = {1000: 4.13, 10000: 26.34}
PEER_FOXES_WALL = {1000: 5.8, 10000: 41.7}
NAMES = {"forward": "forward", "forward_plus": "Forward+", "deferred": "deferred", "visbuffer": "visibility buffer"}


def frames(name):
    path = os.path.join(out, name + ".jsonl")
    rows = [json.loads(line) for line in open(path) if line.strip()]
    n = len(rows)
    lo, hi = (15, 50) if n <= 60 else (20, 120)
    if n <= 30:
        lo, hi = 10, 30
    return rows[lo:hi]


def med(rows, get):
    return statistics.median(get(r) for r in rows)


def gpu(rows, key="total"):
    return med(rows, lambda r: r["gpu_ms"].get(key, 0.0))


def cpu(rows, key="frame"):
    return med(rows, lambda r: r["cpu_ms"].get(key, 0.0))


first = frames("courtyard_deferred")[-1]
print(f"Device: {first['device']}; tier {first['tier']}.\n")

pipes = ["forward", "forward_plus", "deferred", "visbuffer"]
court = {p: frames(f"courtyard_{p}") for p in pipes}
passes = sorted({k for rows in court.values() for r in rows for k in r["gpu_ms"] if k != "total"},
                key=lambda k: -max(gpu(court[p], k) for p in pipes))
print("The courtyard, every default (GPU ms a pass; a dash where the pipeline has no such pass):\n")
print("| pass | " + " | ".join(NAMES[p] for p in pipes) + " |")
print("| --- | " + " | ".join("---" for _ in pipes) + " |")
for k in passes:
    vals = [gpu(court[p], k) if any(k in r["gpu_ms"] for r in court[p]) else None for p in pipes]
    if all(v is None or v < 0.005 for v in vals):
        continue
    print(f"| {k} | " + " | ".join("—" if v is None else f"{v:.2f}" for v in vals) + " |")
print("| **GPU frame** | " + " | ".join(f"**{gpu(court[p]):.2f}**" for p in pipes) + " |")
print("| CPU frame | " + " | ".join(f"{cpu(court[p]):.2f}" for p in pipes) + " |")

print("\nDecals and lights (PEERS.md; clustered decals), GPU ms at 0 / 100 / 1,000 decals:\n")
print("| pipeline | ours | Bevy 0.19.1 (H100) |")
print("| --- | --- | --- |")
for p in ["forward_plus", "deferred", "visbuffer"]:
    ours = " / ".join(f"{gpu(frames(f'decals_{p}_{n}')):.2f}" for n in (0, 100, 1000))
    bevy = " / ".join(f"{v:.2f}" for v in PEER_DECALS[p]) if p in PEER_DECALS else "—"
    print(f"| {NAMES[p]} | {ours} | {bevy} |")

print("\nMany instances behind a wall (PEERS.md), GPU ms / CPU record ms / CPU frame ms:\n")
print("| pipeline | 1,600 boxes | 160,000 boxes | Bevy (H200), GPU |")
print("| --- | --- | --- | --- |")
for p in ["forward_plus", "deferred", "visbuffer"]:
    cells = []
    for n in (1600, 160000):
        rows = frames(f"wall_{p}_{n}")
        cells.append(f"{gpu(rows):.2f} / {cpu(rows, 'record'):.2f} / {cpu(rows):.2f}")
    print(f"| {NAMES[p]} | " + " | ".join(cells) + f" | {PEER_WALL:.2f} → 2.29 |")

print("\nSeed 000's 28,587 point lights (`--bench-scene many-lights`), GPU ms:\n")
print("| pipeline | unshadowed | ray-traced shadows (every default) | shadow pass |")
print("| --- | --- | --- | --- |")
for p in ["forward_plus", "deferred", "visbuffer"]:
    plain, shadowed = frames(f"lights_{p}"), frames(f"lights_shadowed_{p}")
    shadow = max((k for k in shadowed[-1]["gpu_ms"] if k.startswith("shadows")), key=lambda k: gpu(shadowed, k), default=None)
    print(f"| {NAMES[p]} | {gpu(plain):.2f} | {gpu(shadowed):.2f} | {shadow + ' ' + format(gpu(shadowed, shadow), '.2f') if shadow else '—'} |")

print("\nAnimated foxes (PEERS.md; no shadows, no decals), ms:\n")
print("| foxes | pipeline | GPU frame | CPU frame | wall time a frame | Bevy GPU | Bevy wall time a frame |")
print("| --- | --- | --- | --- | --- | --- | --- |")
for n in (1000, 10000):
    for p in ("forward", "visbuffer"):
        rows = frames(f"foxes_{p}_{n}")
        wall = med(rows, lambda r: r["wall_ms"])
        print(f"| {n:,} | {NAMES[p]} | {gpu(rows):.2f} | {cpu(rows):.2f} | {wall:.2f} | {PEER_FOXES[n]:.2f} | {PEER_FOXES_WALL[n]} |")
