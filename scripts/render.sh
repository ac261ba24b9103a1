#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root) and renders the default
# scene (the built-in Cornell box) to out/cornell.exr, out/cornell.png and
# out/cornell-timings.json.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
mkdir -p out
cargo run --release --locked -- render cornell -o out/cornell.exr -o out/cornell.png --timings out/cornell-timings.json "$@"
