#!/usr/bin/env bash
# CPU record time of the GPU-driven city (issue "GPU-driven scene"), builds against each other in
# one call on one machine (hosts differ by 2x), the builds taking turns run after run:
#   scripts/bench_record_ab.sh OUT_DIR LABEL=SANDBOX [LABEL=SANDBOX...] [-- REPS]
# 1,000 instances in each pipeline REPS times (default 3), then 1,000,000 in deferred once; 60
# frames at 1920x1080, occlusion culling, decals off. Prints per run the medians of frames 10-59:
# `cpu_ms.record`, `cpu_ms.submit`, the GPU frame, the depth pyramid's and bloom's GPU passes, and
# how many of those frames submitted their command buffer again (`counters.commands_reused`).
# Extra sandbox flags for every run go in BENCH_FLAGS (e.g. BENCH_FLAGS=--move-camera).
set -euo pipefail
source "$(dirname "$0")/builds.sh"
reps=${rest[0]:-3}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-$(id -u)}
mkdir -p "$XDG_RUNTIME_DIR"
run() {
  local label="$1" bin="$2" name="$3"
  shift 3
  timeout 300 "$bin" --headless --frames 60 --size 1920x1080 --bench-scene many-instances --decal-method off \
    --stats "$out/$label-$name.jsonl" ${BENCH_FLAGS:-} "$@" >"$out/$label-$name.log" 2>&1
  python3 - "$out/$label-$name.jsonl" "$label $name" <<'PY'
import json, statistics, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
rows = [r for r in rows if 'cpu_ms' in r][10:60]
med = lambda f: round(statistics.median(f(r) for r in rows), 3)
gpu = lambda *names: lambda r: sum(r['gpu_ms'].get(n, 0) for n in names)
reused = sum(1 for r in rows if r['counters'].get('commands_reused'))
print(sys.argv[2], 'record', med(lambda r: r['cpu_ms']['record']), 'submit', med(lambda r: r['cpu_ms']['submit']),
      'gpu', med(gpu('total')), 'depth_pyramid', med(gpu('depth_pyramid')), 'bloom', med(gpu('bloom_down', 'bloom_up')),
      'reused', f'{reused}/{len(rows)}')
PY
}
each() {
  for entry in "${bins[@]}"; do run "${entry%%=*}" "${entry#*=}" "$@"; done
}
for rep in $(seq "$reps"); do
  for p in deferred forward visbuffer; do each "$p-1000-$rep" --pipeline "$p" --instances 1000; done
done
each deferred-1000000 --pipeline deferred --instances 1000000
