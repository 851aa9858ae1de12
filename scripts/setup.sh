#!/usr/bin/env bash
# Installs what rara needs on Debian 12 (run as root) and what is missing only:
# lavapipe (CPU Vulkan), the Vulkan loader and validation layers, shaderc/glslang for build.rs,
# a C++ runtime for the static shaderc link, and a Rust toolchain when there is none.
set -euo pipefail

packages=(
  mesa-vulkan-drivers   # lavapipe, the CPU Vulkan driver
  libvulkan1            # the Vulkan loader
  vulkan-validationlayers
  libshaderc-dev        # shaderc + glslang + SPIRV-Tools static libraries for build.rs
  glslang-tools
  spirv-tools
  g++                   # libstdc++ for the static shaderc link
  pkg-config
  ca-certificates
  curl
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}" >&2
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: run as root (or install the packages above yourself)" >&2
    exit 1
  fi
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

if ! command -v cargo >/dev/null 2>&1 && [ -f "$HOME/.cargo/env" ]; then
  # shellcheck disable=SC1091
  . "$HOME/.cargo/env"
fi
if ! command -v cargo >/dev/null 2>&1; then
  # Debian 12's own cargo (1.63) is too old for the dependencies: use rustup's stable.
  echo "setup: installing a Rust toolchain with rustup" >&2
  curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --profile minimal >&2
  # shellcheck disable=SC1091
  . "$HOME/.cargo/env"
fi
