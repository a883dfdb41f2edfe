#!/usr/bin/env bash
# The run command: installs what is missing (scripts/setup.sh), builds the sandbox in release
# mode and plays the default scene. Without arguments it renders 60 frames of the courtyard and
# writes out/sandbox.png and out/stats.jsonl; any arguments go to the sandbox instead
# (see `scripts/run.sh --help`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
if [ $# -eq 0 ]; then
  set -- --headless --frames 60 --size 1280x720 --screenshot out/sandbox.png --stats out/stats.jsonl
fi
cargo run --release --locked -p sandbox -- "$@"
