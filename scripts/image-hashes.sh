#!/bin/bash
# Renders every built-in and test scene in several configurations at a small
# size and prints one SHA-256 per EXR (with every layer): run before and
# after a change that must not change images (a refactor), and diff.
#   scripts/image-hashes.sh [SSBC_BINARY [EXR_HASHES_BINARY]] > hashes.txt
# With the second (`cargo build --release --example exr_hashes`), one line
# per channel of every EXR instead, so that a layer added or dropped leaves
# the other layers' lines as they were.
set -eu
bin=${1:-${CARGO_TARGET_DIR:-target}/release/ssbc}
channels=${2:-}
# The EXR's hash, or each channel's.
hash_of() {
  if [ -n "$channels" ]; then
    "$channels" "$1" | sed "s|^|$2 |"
  else
    echo "$(sha256sum < "$1" | cut -c1-16) $2"
  fi
}
root=$(cd "$(dirname "$0")/.." && pwd)
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
scenes="cornell tori spheres $root/assets/open-front-box.gltf $(ls "$root"/tests/scenes/*.gltf)"
configs=(
  ""
  "--steps 2 --ssbc-layers 2 --ssbc-layer1 half"
  "--steps 2 --ssbc-layers 2 --guard-band"
  "--gather full --integration brute"
  "--visibility exact"
  "--accumulate 2"
)
cat > "$out/seq.json" <<'JSON'
{"frames": [{}, {"camera": {"position": [0.1, 1.0, 3.0]}}, {}]}
JSON
for scene in $scenes; do
  for i in "${!configs[@]}"; do
    f="$out/img.exr"
    # shellcheck disable=SC2086
    if "$bin" render "$scene" --size 96x72 --vpls 256 --points-per-vpl 256 --layers ${configs[$i]} -o "$f" >"$out/log" 2>&1; then
      hash_of "$f" "$(basename "$scene") [${configs[$i]}]"
    else
      echo "FAILED $(basename "$scene") [${configs[$i]}]: $(tail -1 "$out/log")"
    fi
  done
done
for scene in cornell spheres; do
  "$bin" render "$scene" --size 96x72 --vpls 256 --sequence "$out/seq.json" -o "$out/seq_%02d.exr" >"$out/log" 2>&1 \
    && echo "$(cat "$out"/seq_*.exr | sha256sum | cut -c1-16) $scene [sequence]" \
    || echo "FAILED $scene [sequence]: $(tail -1 "$out/log")"
done
