#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root) and runs the whole test suite
# on Mesa lavapipe with Vulkan validation + synchronization validation.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# Force the CPU driver so results do not depend on whatever GPU is present.
export VK_ICD_FILENAMES="${VK_ICD_FILENAMES:-$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json | head -n 1)}"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
cargo test --release --locked "$@"
