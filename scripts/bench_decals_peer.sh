#!/usr/bin/env bash
# PEERS.md's "decals and lights" table with our sandbox: the scene as a glTF
# (scripts/peer_decals_gltf.py), no shadows, 1920x1080, 120 frames, N = 0, 100 and 1,000 decals,
# in Forward+, deferred and the visibility buffer, with ray-traced and clustered decals, for each
# sandbox given (run them in one call on one machine: hosts differ):
#   scripts/bench_decals_peer.sh OUT_DIR LABEL=SANDBOX [LABEL=SANDBOX...] [-- PIPELINE...]
# (FRAMES and SIZE override the 120 frames and 1920x1080, for a quick try on lavapipe; EXTRA
# adds sandbox flags, e.g. EXTRA=--decals-in-forward-shading)
# then the table (scripts/decals_peer_table.py OUT_DIR/*.jsonl): medians of frames 20-119.
set -euo pipefail
source "$(dirname "$0")/builds.sh"
pipelines=("${rest[@]}")
[ ${#pipelines[@]} -gt 0 ] || pipelines=(forward_plus deferred visbuffer)
python3 "$(dirname "$0")/peer_decals_gltf.py" "$out/peer.gltf"
for entry in "${bins[@]}"; do
  label="${entry%%=*}"
  bin="${entry#*=}"
  for pipeline in "${pipelines[@]}"; do
    for n in 0 100 1000; do
      methods=(ray_pipeline clustered)
      [ "$n" = 0 ] && methods=(off)
      for method in "${methods[@]}"; do
        "$bin" --headless --frames "${FRAMES:-120}" --size "${SIZE:-1920x1080}" --scene "$out/peer.gltf" --decals "$n" --no-shadows \
          --pipeline "$pipeline" --decal-method "$method" ${EXTRA:-} --stats "$out/${label}_${pipeline}_${method}_${n}.jsonl" >/dev/null
      done
    done
  done
done
rm "$out/peer.gltf"
python3 "$(dirname "$0")/decals_peer_table.py" "$out"/*.jsonl | tee "$out/peer.md"
