#!/usr/bin/env bash
# Installs what ssbc needs on Debian 12 (run as root), and nothing else:
#  - Vulkan: the loader, Mesa lavapipe (CPU driver), the Khronos validation layer;
#  - the window-system libraries `ssbc view` loads at run time (X11 and Wayland);
#  - Xvfb, for the viewer's test;
#  - Debian's shaderc, glslang and SPIRV-Tools static archives, merged into
#    the one library the shaderc crate links
#    (/usr/local/lib/ssbc-shaderc/libshaderc_combined.a, named in
#    .cargo/config.toml), so that Google's shaderc is not compiled from
#    source. If that fails, the tools for the source build (cmake, ninja,
#    python3, git) are installed instead.
# Skips apt entirely when everything is already there, so repeat runs are fast.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  mesa-vulkan-drivers libvulkan1 vulkan-validationlayers
  libx11-6 libx11-xcb1 libxcb1 libxcursor1 libxi6 libxkbcommon0 libxkbcommon-x11-0
  libwayland-client0 libwayland-cursor0
  xvfb
  g++ libshaderc-dev glslang-dev spirv-tools
)

install_missing() {
  local missing=()
  for p in "$@"; do
    if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
      missing+=("$p")
    fi
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  echo "setup: installing ${missing[*]}" >&2
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: need root to install packages (run as root or install them yourself)" >&2
    exit 1
  fi
  export DEBIAN_FRONTEND=noninteractive
  if [ -z "${SSBC_APT_UPDATED:-}" ]; then
    apt-get update -q
    export SSBC_APT_UPDATED=1
  fi
  apt-get install -y -q --no-install-recommends "${missing[@]}"
}

install_missing "${packages[@]}"

# One static library from Debian's archives (the order resolves symbols).
lib=/usr/lib/$(gcc -dumpmachine)
archives=(shaderc_combined glslang MachineIndependent GenericCodeGen OSDependent
          OGLCompiler SPIRV SPIRV-Tools-opt SPIRV-Tools)
dir=/usr/local/lib/ssbc-shaderc
combined=$dir/libshaderc_combined.a
merge_shaderc() {
  local script="CREATE $combined.tmp"
  for a in "${archives[@]}"; do
    [ -f "$lib/lib$a.a" ] || return 1
    script+=$'\n'"ADDLIB $lib/lib$a.a"
  done
  mkdir -p "$dir"
  printf '%s\nSAVE\nEND\n' "$script" | ar -M && mv "$combined.tmp" "$combined"
}
if [ ! -f "$combined" ] || [ "$lib/libshaderc_combined.a" -nt "$combined" ]; then
  if ! merge_shaderc; then
    echo "setup: could not merge Debian's shaderc archives; shaderc will be built from source" >&2
    rm -rf "$dir"
    install_missing cmake ninja-build python3 git
  fi
fi
