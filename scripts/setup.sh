#!/usr/bin/env bash
# Installs what ssbc needs on Debian 12 (run as root), and nothing else:
#  - Vulkan: the loader, Mesa lavapipe (CPU driver) 25.x from Debian's own
#    bookworm-backports suite (added to apt's sources if missing), the
#    Khronos validation layer;
#  - Debian 12's stock lavapipe (Mesa 22.3.x), extracted (not installed)
#    into /usr/local/lib/ssbc-mesa-stock, for the test suite's smoke set on
#    the previous driver (tests/previous_driver.rs);
#  - the window-system libraries `ssbc view` loads at run time (X11 and Wayland);
#  - Xvfb, for the viewer's test;
#  - Debian's shaderc, glslang and SPIRV-Tools static archives, merged into
#    the one library the shaderc crate links
#    (/usr/local/lib/ssbc-shaderc/libshaderc_combined.a), so that Google's
#    shaderc is not compiled from source, with a pkg-config file naming it
#    (/usr/local/lib/pkgconfig/shaderc.pc, ahead of Debian's in pkg-config's
#    search path): shaderc-sys asks pkg-config first, so any crate that
#    depends on ssbc, in this checkout or outside it, links it with nothing
#    set by hand. (Debian's own shaderc.pc names a shared libshaderc whose
#    glslang symbols it does not link.) If the merge fails, the tools for
#    the source build (cmake, ninja, python3, git) are installed instead.
# Skips apt entirely when everything is already there, so repeat runs are fast.
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."

packages=(
  libvulkan1 vulkan-validationlayers
  libx11-6 libx11-xcb1 libxcb1 libxcursor1 libxi6 libxkbcommon0 libxkbcommon-x11-0
  libwayland-client0 libwayland-cursor0
  xvfb
  g++ pkg-config libshaderc-dev glslang-dev spirv-tools
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

# lavapipe comes from bookworm-backports: Mesa 25 is 1.8x faster than bookworm's
# 22.3, has one large heap (22.3: 2 GiB) and ray queries. Its libdrm comes
# from the same suite (apt selects it).
backports=/etc/apt/sources.list.d/ssbc-bookworm-backports.sources
if ! grep -rqs "bookworm-backports" /etc/apt/sources.list /etc/apt/sources.list.d/; then
  if [ "$(id -u)" -ne 0 ]; then
    echo "setup: need root to add Debian's bookworm-backports suite" >&2
    exit 1
  fi
  echo "setup: adding Debian's bookworm-backports suite ($backports)" >&2
  cat >"$backports" <<'SOURCES'
Types: deb
URIs: http://deb.debian.org/debian
Suites: bookworm-backports
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
SOURCES
  unset SSBC_APT_UPDATED
fi
install_missing "${packages[@]}"

installed_mesa=$(dpkg-query -W -f='${Status} ${Version}' mesa-vulkan-drivers 2>/dev/null |
  sed -n 's/^install ok installed //p' || true)
if [ -z "$installed_mesa" ] || dpkg --compare-versions "$installed_mesa" lt 25; then
  if [ -z "${SSBC_APT_UPDATED:-}" ]; then
    apt-get update -q
    export SSBC_APT_UPDATED=1
  fi
  echo "setup: installing mesa-vulkan-drivers from bookworm-backports (was: ${installed_mesa:-none})" >&2
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    mesa-vulkan-drivers/bookworm-backports
fi

# The previous driver (bookworm's own lavapipe), unpacked beside the system
# with an ICD manifest naming its absolute path; selected per process with
# VK_ICD_FILENAMES, never installed. It uses the installed libdrm (newer is
# compatible) and LLVM 15.
stock=/usr/local/lib/ssbc-mesa-stock
if [ ! -f "$stock/lvp_icd.json" ]; then
  if [ -z "${SSBC_APT_UPDATED:-}" ]; then
    apt-get update -q
    export SSBC_APT_UPDATED=1
  fi
  echo "setup: unpacking bookworm's stock lavapipe into $stock" >&2
  tmp=$(mktemp -d)
  (cd "$tmp" && apt-get download -q -o APT::Sandbox::User=root mesa-vulkan-drivers/bookworm)
  rm -rf "$stock.tmp" && mkdir -p "$stock.tmp"
  dpkg-deb -x "$tmp"/mesa-vulkan-drivers_*.deb "$stock.tmp/root"
  dpkg-deb -f "$tmp"/mesa-vulkan-drivers_*.deb Version >"$stock.tmp/version"
  # The manifest as shipped, its library path made absolute.
  manifest=$(find "$stock.tmp/root" -name 'lvp_icd*.json' | head -n 1)
  sed "s#\"library_path\": *\"[^\"]*/#\"library_path\": \"$stock/root/usr/lib/$(gcc -dumpmachine)/#" \
    "$manifest" >"$stock.tmp/lvp_icd.json"
  rm -rf "$tmp" "$stock" && mv "$stock.tmp" "$stock"
fi

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
# The pkg-config file shaderc-sys finds. Without the merged library it names
# an empty folder, where shaderc-sys finds nothing and builds from source
# (rather than linking Debian's shared libshaderc, which fails).
mkdir -p "$dir" /usr/local/lib/pkgconfig
pc=$(cat <<PC
# Written by ssbc's scripts/setup.sh: Debian's shaderc, glslang and
# SPIRV-Tools static archives merged into one library.
libdir=$dir
includedir=/usr/include

Name: shaderc
Description: shaderc (Debian's static archives, merged)
Version: $(dpkg-query -W -f='${Version}' libshaderc-dev 2>/dev/null || echo 0)
Libs: -L\${libdir} -lshaderc_combined -lstdc++
Cflags: -I\${includedir}
PC
)
if [ "$(cat /usr/local/lib/pkgconfig/shaderc.pc 2>/dev/null)" != "$pc" ]; then
  echo "setup: writing /usr/local/lib/pkgconfig/shaderc.pc" >&2
  printf '%s\n' "$pc" >/usr/local/lib/pkgconfig/shaderc.pc
fi
