#!/usr/bin/env bash
# The test command: installs what is missing (scripts/setup.sh), then runs the gates in order,
# failing fast: formatting (cargo fmt --check), lints (clippy on every target, warnings are
# errors), then every test with the Vulkan validation layer on (built, then run; the build's
# time and the 20 slowest tests are printed), then every example run headless
# (scripts/examples.sh), then the docs (cargo doc, warnings are errors; every public item is
# documented: the workspace lints warn on a missing doc and clippy runs with -D warnings). GPU
# tests run on Mesa lavapipe when there is no GPU. Extra arguments go to `cargo test`.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
source scripts/env.sh
# The texture import cache of the tests' glTF loads and generated textures
# (engine::image::cache): inside the target folder, not the user's cache, so that a test run
# neither reads nor leaves the user's files (`cargo clean` empties it).
export XDG_CACHE_HOME="${CARGO_TARGET_DIR:-$PWD/target}/test-cache"
# Lavapipe's vectors four lanes wide instead of eight: the tests' images are small, so their
# frames cost little either way, while the LLVM compile of each shader, which most of a cold
# test's time goes to, takes about half as long (the default courtyard's first frame with
# reflections: 166 s against 90 s on the 2-core machine).
export LP_NATIVE_VECTOR_WIDTH="${LP_NATIVE_VECTOR_WIDTH:-128}"
# Lavapipe's LLVM without its optimization passes: a cold test spends most of its time compiling
# shaders, and the tests' frames are small. `reflections::glass_reflects_what_is_behind_the_camera`
# on the 2-core machine: 198 s from an empty shader cache with the passes, 82 s without; 17.7 s
# against 19.2 s with a warm cache. GALLIVM_PERF= (empty) puts them back.
export GALLIVM_PERF="${GALLIVM_PERF-nopt}"
# Mesa keys its shader cache on the shader and the driver's build, not on the vector width: code
# compiled four lanes wide, loaded by a run at eight, crashes in the shader (seen: a segfault in a
# llvmpipe thread). So each width (and each set of LLVM passes) has a cache of its own.
export MESA_SHADER_CACHE_DIR="$XDG_CACHE_HOME/mesa-shader-cache-$LP_NATIVE_VECTOR_WIDTH${GALLIVM_PERF:+-$GALLIVM_PERF}"

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

# A build from scratch gains nothing from incremental compilation's bookkeeping.
if [ "${CI:-}" = true ]; then
  export CARGO_INCREMENTAL=0
fi

gate format cargo fmt --all --check
gate clippy cargo clippy --workspace --all-targets --locked -- -D warnings

# The tests: built first and timed apart from running them; then run by cargo-nextest where it
# is installed (every test in a process of its own, both cores busy until the last test, each
# test's time printed, the 20 slowest listed at the end), by `cargo test` otherwise.
started=$SECONDS
gate build cargo test --workspace --locked --no-run "$@"
echo "test.sh: building the tests took $((SECONDS - started)) s"
started=$SECONDS
if cargo nextest --version >/dev/null 2>&1; then
  log=$(mktemp)
  run_tests() {
    cargo nextest run --workspace --locked --no-fail-fast --status-level pass --final-status-level fail "$@" 2>&1 | tee "$log"
  }
  gate test run_tests "$@"
  echo "test.sh: the 20 slowest tests:"
  # sed, not head: head would stop reading early and sort would die of SIGPIPE, failing the
  # pipeline under pipefail.
  sed -n -E 's/^ *PASS \[ *([0-9.]+)s\] *(\([^)]*\) )?(.*)$/\1 s  \3/p' "$log" | sort -rn | sed -n '1,20p'
  rm -f "$log"
  gate doctests cargo test --workspace --locked --doc "$@"
else
  echo "test.sh: cargo-nextest is not installed (cargo install cargo-nextest --locked): running the tests with cargo test, without per-test times"
  gate test cargo test --workspace --locked "$@"
fi
echo "test.sh: running the tests took $((SECONDS - started)) s"
gate examples bash scripts/examples.sh
gate docs env RUSTDOCFLAGS="-D warnings" cargo doc --no-deps --workspace --locked
