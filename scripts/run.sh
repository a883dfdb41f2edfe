#!/usr/bin/env bash
# The run command: installs what is missing (scripts/setup.sh), builds the sandbox in release
# mode and plays. With a display it opens the game's window; without one it says so, plays a
# short scene headless and writes out/sandbox.png and out/stats.jsonl. Any arguments go to the
# sandbox instead (see `scripts/run.sh --help`).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
if [ $# -eq 0 ]; then
  set -- --size 1280x720 --frames 120 --stats out/stats.jsonl
fi
cargo run --release --locked -p sandbox -- "$@"
