#!/usr/bin/env bash
# Builds every example and runs it headless (a few small frames each; an example fails on a
# rendering or Vulkan validation error), as a game programmer would run them with a window:
#   cargo run --example NAME [-- --headless --frames N --size WxH --screenshot PATH]
# The glTF viewer opens the shared DamagedHelmet model beside the project.
set -euo pipefail
cd "$(dirname "$0")/.."
model=../shared/assets/gltf/DamagedHelmet/DamagedHelmet.glb
if [ ! -f "$model" ]; then
  echo "examples.sh: $model is missing (the shared models live beside the project)" >&2
  exit 1
fi
# Built as part of the whole workspace with the test profile, so that the dependencies `cargo
# test --workspace` just compiled are reused (`cargo run -p examples` would resolve the examples'
# features alone and rebuild them: six minutes on a fresh CI machine); then run directly.
cargo build --locked --workspace --examples --profile test
bin="${CARGO_TARGET_DIR:-target}/debug/examples"
for example in minimal decals lights; do
  echo "examples.sh: $example"
  "$bin/$example" --headless --frames 6 --size 160x120
done
echo "examples.sh: gltf_viewer"
"$bin/gltf_viewer" "$model" --headless --frames 4 --size 160x120
echo "examples.sh: shoot (two clicks on the model: two bullet holes)"
out=$("$bin/shoot" "$model" --headless --frames 8 --size 160x120 --click 80,60 --click 70,50)
echo "$out"
grep -q ", 2 decals" <<<"$out" || { echo "examples.sh: shoot did not leave two bullet holes" >&2; exit 1; }
echo "examples.sh: skinned_decals (the shared Fox, shot on its bones: holes on its skin)"
fox=../shared/assets/gltf/Fox/Fox.glb
[ -f "$fox" ] || { echo "examples.sh: $fox is missing" >&2; exit 1; }
out=$("$bin/skinned_decals" "$fox" --headless --frames 30 --size 160x120)
echo "$out"
grep -qE ", ([4-9]|[1-9][0-9]+) decals" <<<"$out" || { echo "examples.sh: skinned_decals left too few holes" >&2; exit 1; }
echo "examples.sh: sparks (a click on the floor: a burst of 60 beside the grinder's stream)"
out=$("$bin/sparks" --headless --frames 8 --size 160x120 --click 80,100)
echo "$out"
grep -qE ", ([6-9][0-9]|[1-9][0-9]{2,}) particles started" <<<"$out" || { echo "examples.sh: sparks started too few particles" >&2; exit 1; }
echo "examples.sh: headless_test"
"$bin/headless_test"
