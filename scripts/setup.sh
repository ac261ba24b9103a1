#!/usr/bin/env bash
# Installs what ssbc needs on Debian 12 (run as root): Vulkan loader, Mesa
# lavapipe, the Khronos validation layer, and the tools shaderc builds with.
# Skips apt entirely when everything is already there, so repeat runs are fast.
set -euo pipefail

packages=(
  mesa-vulkan-drivers libvulkan1 libvulkan-dev vulkan-tools vulkan-validationlayers
  cmake ninja-build python3 git g++ pkg-config xvfb
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: need root to install packages (run as root or install them yourself)" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  apt-get update -q
  apt-get install -y -q --no-install-recommends "${missing[@]}"
fi
