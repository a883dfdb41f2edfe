#!/usr/bin/env bash
# The ray-tracing-pipeline decal pass against its floor (issue "decals at a million", item 4), for
# each sandbox given (run them in one call on one machine: hosts differ):
#   scripts/bench_decal_floor.sh OUT_DIR LABEL=SANDBOX [LABEL=SANDBOX...] [-- N...]
# For N scattered decals (default 10,000, 100,000 and 1,000,000) over the courtyard, deferred,
# 1920x1080, 30 frames: the lit pass (--decal-method ray_pipeline), its count-only floor (the same
# with --debug-view decal-floor, where the build has it) and the clustered pass; then the table
# (medians of frames 10-29) in OUT_DIR/floor.md. FRAMES and SIZE override 30 and 1920x1080 (a quick
# try on lavapipe: add --tier ray_tracing_pipeline through the sandbox default or a small SIZE).
# MOVING=1 adds the lit pass with the camera swaying every frame (--move-camera).
set -euo pipefail
source "$(dirname "$0")/builds.sh"
counts=("${rest[@]}")
[ ${#counts[@]} -gt 0 ] || counts=(10000 100000 1000000)
for entry in "${bins[@]}"; do
  label="${entry%%=*}"
  bin="${entry#*=}"
  for n in "${counts[@]}"; do
    run() { "$bin" --headless --frames "${FRAMES:-30}" --size "${SIZE:-1920x1080}" --decals "$n" --pipeline deferred "$@" >/dev/null 2>>"$out/log.txt"; }
    run --decal-method ray_pipeline --stats "$out/${label}_lit_$n.jsonl"
    run --decal-method ray_pipeline --debug-view decal-floor --stats "$out/${label}_floor_$n.jsonl" ||
      echo "$label: no decal-floor view in this build" >&2
    run --decal-method clustered --stats "$out/${label}_clustered_$n.jsonl"
    [ -z "${MOVING:-}" ] || run --decal-method ray_pipeline --move-camera --stats "$out/${label}_moving_$n.jsonl"
  done
done
python3 - "$out" <<'PY' | tee "$out/floor.md"
import glob, json, os, statistics, sys
print("| build | decals | pass | decal pass ms | of which list offsets ms | binning ms | reflection rays ms | frame ms | list entries needed | pixels overflowed |")
print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
for path in sorted(glob.glob(os.path.join(sys.argv[1], "*_*_*.jsonl")), key=lambda p: (os.path.basename(p).split("_")[0], int(p.rsplit("_", 1)[1].split(".")[0]), p)):
    label, kind, n = os.path.basename(path)[:-6].rsplit("_", 2)
    rows = [json.loads(l) for l in open(path)][10:]
    if not rows:
        continue
    med = lambda f: statistics.median(f(r["gpu_ms"]) for r in rows)
    # The ray-tracing-pipeline pass's per-pixel lists are reserved by a compute pass of their own.
    decal = med(lambda g: sum(v for k, v in g.items() if k.startswith("decal_pass") or k == "decal_list_offsets"))
    offsets = med(lambda g: g.get("decal_list_offsets", 0.0))
    lists = [r["decal_lists"]["measured"] for r in rows if "measured" in r.get("decal_lists", {})]
    needed = f"{statistics.median(l['needed'] for l in lists):,.0f}" if lists else "-"
    overflowed = f"{statistics.median(l['overflowed'] for l in lists):,.0f}" if lists else "-"
    binning = med(lambda g: sum(v for k, v in g.items() if k.startswith("decal_cluster")))
    print(f"| {label} | {int(n):,} | {kind} | {decal:.3f} | {offsets:.3f} | {binning:.3f} | {med(lambda g: g.get('reflection_rays', 0.0)):.3f} | {med(lambda g: g['total']):.3f} | {needed} | {overflowed} |")
PY
