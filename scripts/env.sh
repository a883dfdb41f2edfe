# Sourced by run.sh and test.sh: the environment the Vulkan loader and cargo need.
if ! command -v cargo >/dev/null 2>&1; then
  if [ -x "$HOME/.cargo/bin/cargo" ]; then
    export PATH="$HOME/.cargo/bin:$PATH"
  else
    echo "cargo not found: install Rust 1.95 or newer with rustup (https://rustup.rs), then run this again" >&2
    exit 1
  fi
fi
# The Vulkan loader and Mesa want a runtime directory; headless machines often have none.
if [ -z "${XDG_RUNTIME_DIR:-}" ] || [ ! -d "${XDG_RUNTIME_DIR}" ]; then
  export XDG_RUNTIME_DIR="/tmp/xdg-runtime-$(id -u)"
  mkdir -p -m 700 "$XDG_RUNTIME_DIR"
fi
