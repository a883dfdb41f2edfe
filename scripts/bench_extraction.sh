#!/usr/bin/env bash
# CPU cost of extraction in the release sandbox (issue: decals at a million, items 1 and 2):
# median cpu_ms (frame, extract, record) of frames 10-29 with 100k and 1M static decals, 1 % of
# 1M moving, 1,000 spawned and despawned per frame among 100k, and 1k/1M instances, for the
# binaries .bin/sandbox-before and .bin/sandbox-new (a build from before and after the change;
# a missing one is skipped). On the lent GPU machine, unpack the loader first (docs/experiments/cpu-extraction-change-lists.md).
# Usage: OUT=DIR bash scripts/bench_extraction.sh
set -u
: "${OUT:?set OUT to a directory}"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}; mkdir -p "$XDG_RUNTIME_DIR" "$OUT"
r() { n=$1; shift; timeout 240 "$@" --headless --size 1920x1080 --decal-method off --frames 30 --stats $OUT/$n.jsonl > $OUT/$n.log 2>&1; echo "$n rc=$?"; }
for b in before new; do
  [ -x .bin/sandbox-$b ] || continue
  r $b-100k .bin/sandbox-$b --decals 100000
  r $b-1m .bin/sandbox-$b --decals 1000000
  r $b-1m-move .bin/sandbox-$b --decals 1000000 --move-decals 1
done
r new-churn .bin/sandbox-new --decals 100000 --churn-decals 1000
r new-inst1m .bin/sandbox-new --bench-scene many-instances --instances 1000000
r new-inst1k .bin/sandbox-new --bench-scene many-instances --instances 1000
python3 - <<'PY'
import json,statistics,glob,os
for f in sorted(glob.glob(os.environ['OUT']+'/*.jsonl')):
    rows=[json.loads(l) for l in open(f)]
    rows=[r for r in rows if 'cpu_ms' in r][10:30]
    if not rows: print(f,'no rows'); continue
    c={k: round(statistics.median(r['cpu_ms'][k] for r in rows),3) for k in rows[0]['cpu_ms']}
    print(os.path.basename(f), c, 'visited', rows[-1].get('visited'), 'bytes', statistics.median(r['counters']['bytes_uploaded'] for r in rows), 'gpu', round(statistics.median(r['gpu_ms']['total'] for r in rows),2), 'decals', rows[-1]['counters']['decals'], 'inst', rows[-1]['counters']['instances'])
PY
