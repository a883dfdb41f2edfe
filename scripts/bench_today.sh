#!/usr/bin/env bash
# Today's figures of docs/BENCHMARKS.md, every one from the same build in one call on one
# machine (hosts of the same kind differ by more than most changes):
#   scripts/bench_today.sh SANDBOX CHARACTER OUT_DIR
# 1920×1080. The courtyard with every default in each pipeline; ../shared/PEERS.md's scenes
# beside Bevy's figures there (decals and lights, many instances behind a wall, animated foxes,
# with anti-aliasing, bloom and ambient occlusion off where Bevy's runs had none); seed 000's
# 28,587 lights with and without shadows. Then the tables (scripts/today_tables.py).
set -euo pipefail
bin=$1 character=$2 out=$3
mkdir -p "$out"
run() {
  local name=$1
  shift
  timeout 150 "$bin" --headless --size 1920x1080 "$@" --stats "$out/$name.jsonl" >"$out/$name.log" 2>&1 || { echo "$name failed:"; tail -3 "$out/$name.log"; }
}
bare=(--aa none --no-bloom --ao off)
for p in forward forward_plus deferred visbuffer; do
  run "courtyard_$p" --frames 60 --pipeline "$p"
done
python3 "$(dirname "$0")/peer_decals_gltf.py" "$out/peer.gltf"
for p in forward_plus deferred visbuffer; do
  for n in 0 100 1000; do
    run "decals_${p}_$n" --frames 120 --scene "$out/peer.gltf" --decals "$n" --no-shadows --pipeline "$p" --decal-method clustered "${bare[@]}"
  done
  for n in 1600 160000; do
    run "wall_${p}_$n" --frames 60 --bench-scene behind-wall --instances "$n" --pipeline "$p" --decal-method off --no-shadows "${bare[@]}"
  done
  run "lights_${p}" --frames 30 --bench-scene many-lights --pipeline "$p" --no-shadows
  run "lights_shadowed_${p}" --frames 30 --bench-scene many-lights --pipeline "$p"
done
for p in forward visbuffer; do
  for n in 1000 10000; do
    run "foxes_${p}_$n" --frames 60 --bench-scene foxes --character "$character" --character-clip Run --instances "$n" \
      --pipeline "$p" --decal-method off --no-shadows
  done
done
python3 "$(dirname "$0")/today_tables.py" "$out" | tee "$out/today.md"
