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
cargo build --locked -p examples --examples
for example in minimal decals lights; do
  echo "examples.sh: $example"
  cargo run -q --locked -p examples --example "$example" -- --headless --frames 12 --size 160x120
done
echo "examples.sh: gltf_viewer"
cargo run -q --locked -p examples --example gltf_viewer -- "$model" --headless --frames 4 --size 160x120
echo "examples.sh: shoot (two clicks on the model: two bullet holes)"
out=$(cargo run -q --locked -p examples --example shoot -- "$model" --headless --frames 8 --size 160x120 --click 80,60 --click 70,50)
echo "$out"
grep -q ", 2 decals" <<<"$out" || { echo "examples.sh: shoot did not leave two bullet holes" >&2; exit 1; }
echo "examples.sh: headless_test"
cargo run -q --locked -p examples --example headless_test
