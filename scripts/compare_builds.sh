#!/usr/bin/env bash
# Renders the same frames with two sandbox binaries and compares the screenshots byte for byte:
# for refactors that must not change a pixel.
#
#   [FRAMES=N] scripts/compare_builds.sh OLD_SANDBOX NEW_SANDBOX [SIZE]   (N: frames, default 4)
#
# Every pipeline with its decal methods, each named (a method the device cannot run falls back,
# so the same build pair compares different work on different devices), on the default
# courtyard with 300 scattered decals (their debug boxes drawn once), headless on whatever
# Vulkan device is present.
set -euo pipefail
old=$1 new=$2 size=${3:-320x240} frames=${FRAMES:-4}
source "$(dirname "$0")/env.sh"
out=$(mktemp -d)
status=0
for combo in forward:ray_query forward:off forward_plus:clustered deferred:ray_query deferred:ray_pipeline deferred:clustered deferred:deferred deferred:off \
  visbuffer:ray_query visbuffer:ray_pipeline visbuffer:off forward:ray_query:boxes; do
  IFS=: read -r pipeline method boxes <<<"$combo"
  extra=()
  [ -n "$boxes" ] && extra=(--decal-boxes)
  for which in old new; do
    bin=$old; [ $which = new ] && bin=$new
    RENDER_VALIDATION=0 "$bin" --headless --frames "$frames" --size "$size" --decals 300 --pipeline "$pipeline" --decal-method "$method" \
      "${extra[@]}" --screenshot "$out/$which-$pipeline-$method$boxes.png" >/dev/null 2>&1
  done
  if cmp -s "$out/old-$pipeline-$method$boxes.png" "$out/new-$pipeline-$method$boxes.png"; then
    echo "identical: $pipeline $method ${boxes:+(decal boxes)}"
  else
    echo "DIFFERENT: $pipeline $method ${boxes:+(decal boxes)} ($out)"
    status=1
  fi
done
exit $status
