#!/usr/bin/env bash
# Installs what building and running the project needs, and nothing that is already there.
# Sourced by scripts/run.sh and scripts/test.sh; safe to run again.
#
# On Debian 12 (bookworm) it installs, through sudo when not root:
#   - the Vulkan loader and validation layers (libvulkan1, libvulkan-dev, vulkan-validationlayers),
#   - the GLSL compiler glslc,
#   - Mesa lavapipe 25 from bookworm-backports when no GPU Vulkan driver is installed
#     (lavapipe in bookworm itself is too old for ray queries),
#   - Xvfb, xauth, x11-apps (xwd), x11-utils (xwininfo) and xdotool, for the windowed tests.
# On any other system it prints what to install instead.
set -euo pipefail

need_pkgs=()
have_cmd() { command -v "$1" >/dev/null 2>&1; }
have_pkg() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q "install ok installed"; }

say() { printf '[setup] %s\n' "$*" >&2; }

if ! [ -r /etc/os-release ] || ! grep -q '^ID=debian' /etc/os-release || ! grep -q 'VERSION_ID="12"' /etc/os-release; then
  if have_cmd glslc && (ldconfig -p 2>/dev/null | grep -q libvulkan.so.1); then
    say "not Debian 12: using the glslc and Vulkan loader already installed"
    exit 0
  fi
  cat >&2 <<'MSG'
[setup] This script installs dependencies on Debian 12 only. On this system install, by hand:
  - a Vulkan 1.3 driver (your GPU's, or Mesa lavapipe >= 25 for a CPU device),
  - the Vulkan loader (libvulkan.so.1) and the Khronos validation layers,
  - glslc (from shaderc or the Vulkan SDK),
  - a Rust toolchain >= 1.95 (rustup.rs),
then run this command again.
MSG
  exit 1
fi

SUDO=""
if [ "$(id -u)" != 0 ]; then
  if have_cmd sudo; then SUDO="sudo"; else say "not root and no sudo: cannot install packages"; exit 1; fi
fi
export DEBIAN_FRONTEND=noninteractive

for p in libvulkan1 libvulkan-dev vulkan-validationlayers glslc xvfb xauth x11-apps x11-utils xdotool; do
  have_pkg "$p" || need_pkgs+=("$p")
done

# A GPU driver counts if an ICD other than Mesa's software ones is present.
gpu_icd=$(ls /usr/share/vulkan/icd.d/ /etc/vulkan/icd.d/ 2>/dev/null | grep -v -E 'lvp|intel|radeon|virtio|nouveau|asahi|freedreno|broadcom|panfrost|powervr|gfxstream|dzn' || true)
need_backports=0
if [ -z "$gpu_icd" ]; then
  ver=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers 2>/dev/null || true)
  case "$ver" in
    25.*|26.*|27.*) ;;
    *) need_backports=1 ;;
  esac
fi

if [ ${#need_pkgs[@]} -eq 0 ] && [ $need_backports -eq 0 ]; then
  exit 0
fi

if [ $need_backports -eq 1 ] && ! grep -rqs 'bookworm-backports' /etc/apt/sources.list /etc/apt/sources.list.d/; then
  say "adding bookworm-backports to apt sources (for Mesa lavapipe 25)"
  echo 'deb http://deb.debian.org/debian bookworm-backports main' | $SUDO tee /etc/apt/sources.list.d/bookworm-backports.list >/dev/null
fi
say "installing: ${need_pkgs[*]} $([ $need_backports -eq 1 ] && echo 'mesa-vulkan-drivers (bookworm-backports)')"
$SUDO apt-get update -qq
if [ ${#need_pkgs[@]} -gt 0 ]; then
  $SUDO apt-get install -y -qq --no-install-recommends "${need_pkgs[@]}" >/dev/null
fi
if [ $need_backports -eq 1 ]; then
  $SUDO apt-get install -y -qq --no-install-recommends -t bookworm-backports mesa-vulkan-drivers >/dev/null
fi
say "done"
