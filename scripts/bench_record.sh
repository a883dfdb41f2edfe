#!/usr/bin/env bash
# CPU record time of the GPU-driven scene at 1,000 and 1,000,000 instances (issue 24's target),
# each pipeline, occlusion culling, 60 frames, twice; then 1,000 instances at 1080p and at
# 8K (7680x4320), whose only difference is a longer GPU frame for the CPU to wait on.
# Usage: scripts/bench_record.sh SANDBOX OUT_DIR   (prints medians of frames 10-59)
set -u
bin="$1"
out="$2"
mkdir -p "$out"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}
mkdir -p "$XDG_RUNTIME_DIR"
run() {
  local name="$1"
  shift
  timeout 300 "$bin" --headless --frames 60 --bench-scene many-instances --decal-method off --stats "$out/$name.jsonl" "$@" >"$out/$name.log" 2>&1
  python3 - "$out/$name.jsonl" "$name" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
rows = [r for r in rows if 'cpu_ms' in r][10:60]
med = lambda f: round(statistics.median(f(r) for r in rows), 3)
print(sys.argv[2], 'record', med(lambda r: r['cpu_ms']['record']), 'submit', med(lambda r: r['cpu_ms']['submit']),
      'extract', med(lambda r: r['cpu_ms']['extract']), 'frame', med(lambda r: r['cpu_ms']['frame']), 'gpu', med(lambda r: r['gpu_ms']['total']))
PY
}
for rep in 1 2; do
  for p in deferred forward visbuffer; do
    for n in 1000 1000000; do
      run "$p-$n-$rep" --size 1920x1080 --pipeline "$p" --instances "$n"
    done
  done
done
for rep in 1 2; do
  run "deferred-1000-8k-$rep" --size 7680x4320 --pipeline deferred --instances 1000
  run "deferred-1000-off-$rep" --size 1920x1080 --pipeline deferred --instances 1000 --culling off
  run "deferred-1000000-off-$rep" --size 1920x1080 --pipeline deferred --instances 1000000 --culling off
done
