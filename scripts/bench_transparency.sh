#!/usr/bin/env bash
# The transparency benchmarks of docs/experiments/transparency-*.md (seed 002 Tables 4.2 to 4.5), run on a
# GPU machine with a release sandbox:
#   scripts/bench_transparency.sh SANDBOX OUT_DIR
# The transparency bench scene (seed 002 §4.2's polygon counts, spot lights only) at 1920×1080,
# every configuration in one process (--compare-transparency, 40 frames each; shadow maps of
# 1024² texels with room for all 64 lights; the tables take
# the median of frames 10–39), then the tables (scripts/transparency_tables.py) and the
# per-pass medians (OUT_DIR/transparency.csv, written by the sandbox).
set -euo pipefail
bin="$1"
out="$2"
mkdir -p "$out"
"$bin" --headless --frames 40 --size 1920x1080 --bench-scene transparency --decal-method off --compare-transparency --shadow-map-tiles 64 \
  --stats "$out/transparency.jsonl" --screenshot "$out/transparency.png"
python3 "$(dirname "$0")/transparency_tables.py" "$out/transparency.jsonl" | tee "$out/tables.md"
