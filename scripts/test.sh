#!/usr/bin/env bash
# Installs what is missing (Debian 12, as root) and runs the whole test suite
# on Mesa lavapipe with Vulkan validation + synchronization validation: on
# bookworm-backports' Mesa 25 (installed), with a smoke set also on
# bookworm's own Mesa 22.3 (unpacked beside it by scripts/setup.sh,
# tests/previous_driver.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# Tuning variables change what the accuracy tests check: refused here.
tuning=$(env | sed -n 's/^\(SSBC_[A-Z0-9_]*\)=.*/\1/p' | grep -vxE 'SSBC_APT_UPDATED|SSBC_PREVIOUS_ICD' || true)
if [ -n "$tuning" ]; then
  echo "test: unset $(echo $tuning) first: they change what the tests check" >&2
  exit 2
fi
# Force the CPU driver so results do not depend on whatever GPU is present.
export VK_ICD_FILENAMES="${VK_ICD_FILENAMES:-$(ls /usr/share/vulkan/icd.d/lvp_icd*.json | head -n 1)}"
export SSBC_PREVIOUS_ICD="${SSBC_PREVIOUS_ICD:-/usr/local/lib/ssbc-mesa-stock/lvp_icd.json}"
export LP_NUM_THREADS="${LP_NUM_THREADS:-2}"
# Mesa's shader cache does not key entries by lavapipe's vector width: code
# another width cached (a hand-run LP_NATIVE_VECTOR_WIDTH=128, say) crashes
# the driver (tests/lavapipe_shader_cache.rs). The suite keeps its own.
export MESA_SHADER_CACHE_DIR="${XDG_CACHE_HOME:-$HOME/.cache}/ssbc-test-mesa-shaders"
# Tests that cannot run their check fail here instead of skipping.
export SSBC_TEST_COMMAND=1
echo "test: lavapipe $(dpkg-query -W -f='${Version}' mesa-vulkan-drivers), previous driver $(cat "$(dirname "$SSBC_PREVIOUS_ICD")/version" 2>/dev/null || echo '(none)')" >&2
cargo test --release --locked "$@"
# An engine's crate outside this checkout, depending on ssbc, builds and runs.
bash scripts/check-dependent-crate.sh
