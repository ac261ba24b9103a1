#!/usr/bin/env bash
# The measurements the defaults were chosen by (docs/performance.md): for
# each configuration, the frame's GPU ms (median of N warm frames), its
# ratio to a direct-light-only frame (--vpls 0 --steps 0) of the same run,
# and relMSE per pixel and on 4x4 blocks against a converged path-traced
# reference (made first if missing: ssbc reference --spp 4096).
#
#   scripts/defaults-study.sh SCENE WxH "OPTIONS" ["OPTIONS" ...]
# e.g. scripts/defaults-study.sh assets/open-front-box.gltf 320x240 "" "--vpls 1024" "--gather full --vpls 256 --ism-res 64"
# BASELINE=path/to/an/older/ssbc adds a first row: that binary's defaults.
set -euo pipefail
scene=$1; size=$2; shift 2
ssbc=${SSBC:-target/release/ssbc}
frames=${FRAMES:-3}
out=${OUT:-out/defaults-study}
mkdir -p "$out"
name=$(basename "$scene" .gltf)
ref=$out/$name-$size-ref.exr
[ -f "$ref" ] || "$ssbc" reference "$scene" --size "$size" --spp "${SPP:-4096}" -o "$ref" >&2
json() { python3 -c "import json,sys; d=json.load(open('$1')); print($2)"; }
"$ssbc" render "$scene" --size "$size" --vpls 0 --steps 0 --frames "$frames" \
  --timings "$out/direct.json" -o "$out/direct.exr" 2>/dev/null
direct=$(json "$out/direct.json" "d['stats']['frame_gpu_ms']['median']")
printf '| options | frame ms | / direct-only (%.1f ms) | relMSE pixel | relMSE 4x4 | mean / ref |\n|---|---|---|---|---|---|\n' "$direct"
row() {
  local bin=$1 options=$2 label=$3
  # shellcheck disable=SC2086
  "$bin" render "$scene" --size "$size" $options --frames "$frames" \
    --timings "$out/run.json" -o "$out/run.exr" 2>/dev/null
  ms=$(json "$out/run.json" "d['stats']['frame_gpu_ms']['median']")
  px=$("$ssbc" compare "$out/run.exr" "$ref" --json)
  blocks=$("$ssbc" compare "$out/run.exr" "$ref" --json --blocks 4)
  python3 - "${label:-${options:-(defaults)}}" "$ms" "$direct" "$px" "$blocks" <<'PY'
import json, sys
options, ms, direct, px, blocks = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), json.loads(sys.argv[4]), json.loads(sys.argv[5])
print(f"| {options} | {ms:.1f} | {ms / direct:.2f}x | {px['rel_mse']:.4f} | {blocks['rel_mse']:.4f} | {px['mean_ratio']:.4f} |")
PY
}
if [ -n "${BASELINE:-}" ]; then row "$BASELINE" "" "defaults of $BASELINE"; fi
for options in "$@"; do
  row "$ssbc" "$options" ""
done
