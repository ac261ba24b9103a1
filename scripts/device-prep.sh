#!/bin/bash
# Prepares a run on the lent GPU machine (docs/development.md, "Running on a
# real GPU"): builds the release test binaries, the `passes` bench and the
# CLI, strips them into .devbin/bins.tar.xz beside scripts/device-run.sh
# (as .devbin/run.sh), and downloads the Vulkan loader, validation layer and
# glvnd packages into .gl/ (both folders are git-ignored through
# .git/info/exclude). Then: run `bash .devbin/run.sh` there, carrying
# .devbin and .gl.
set -euo pipefail
cd "$(dirname "$0")/.."
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/ssbc-target}"
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
mkdir -p "$stage/tests" .devbin .gl
cargo build --release --bin ssbc
cargo test --release --no-run --message-format=json 2>/dev/null \
  | python3 -c 'import json,sys
for l in sys.stdin:
    m=json.loads(l)
    if m.get("reason")=="compiler-artifact" and m.get("executable") and m["target"]["kind"]==["test"]:
        print(m["executable"])' | while read -r exe; do cp "$exe" "$stage/tests/$(basename "$exe" | sed 's/-[0-9a-f]*$//')"; done
bench=$(cargo bench --bench passes --no-run --message-format=json 2>/dev/null \
  | python3 -c 'import json,sys
for l in sys.stdin:
    m=json.loads(l)
    if m.get("reason")=="compiler-artifact" and m.get("executable"): print(m["executable"])' | tail -1)
cp "$bench" "$stage/passes"
cp "$CARGO_TARGET_DIR/release/ssbc" "$stage/ssbc"
strip "$stage/passes" "$stage/ssbc" "$stage"/tests/*
tar -cJf .devbin/bins.tar.xz -C "$stage" .
cp scripts/device-run.sh .devbin/run.sh
if ! ls .gl/libvulkan1_*.deb > /dev/null 2>&1; then
  (cd .gl && apt-get download libvulkan1 vulkan-validationlayers libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2)
fi
ls -la .devbin
