#!/usr/bin/env bash
# The test command: installs what is missing (scripts/setup.sh), then runs the gates in order,
# failing fast: formatting (cargo fmt --check), lints (clippy on every target, warnings are
# errors), then every test with the Vulkan validation layer on, then every example run headless
# (scripts/examples.sh), then the docs (cargo doc, warnings are errors; every public item is
# documented: the workspace lints warn on a missing doc and clippy runs with -D warnings). GPU
# tests run on Mesa lavapipe when there is no GPU. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh

gate() {
  local name="$1"
  shift
  if ! "$@"; then
    echo "test.sh: the $name gate failed: $*" >&2
    exit 1
  fi
}

for tool in fmt clippy; do
  if ! cargo "$tool" --version >/dev/null 2>&1; then
    echo "test.sh: cargo $tool is missing: install it with rustup component add ${tool/fmt/rustfmt}" >&2
    exit 1
  fi
done

gate format cargo fmt --all --check
gate clippy cargo clippy --workspace --all-targets --locked -- -D warnings
gate test cargo test --workspace --locked "$@"
gate examples bash scripts/examples.sh
gate docs env RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --locked
