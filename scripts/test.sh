#!/usr/bin/env bash
# The test command: installs what is missing (scripts/setup.sh), then runs every test with the
# Vulkan validation layer on. GPU tests run on Mesa lavapipe when there is no GPU.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
cargo test --workspace --locked "$@"
