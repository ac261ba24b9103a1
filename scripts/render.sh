#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root) and renders the default
# scene (the built-in Cornell box) to cornell.exr and cornell.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo run --release --locked -- render cornell -o cornell.exr -o cornell.png --timings cornell-timings.json "$@"
