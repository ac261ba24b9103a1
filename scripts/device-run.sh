#!/bin/bash
# Runs on the lent GPU machine (docs/development.md, "Running on a real
# GPU"), from the checkout's root there: the per-pass bench, then every
# test binary (four at a time), on NVIDIA's Vulkan driver with Debian 12's
# loader, glvnd libraries and validation layer. Prepared here:
#   .devbin/bins.tar.xz  stripped test binaries under tests/, the `passes`
#                        bench as passes, the CLI as ssbc
#   .gl/*.deb            apt-get download libvulkan1 vulkan-validationlayers
#                        libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2
# (both folders listed in .git/info/exclude and carried). Results land in
# $OUT: bench.txt, gpu.txt (clocks), summary.txt, tests.tgz.
set -u
root=$PWD
for f in .gl/lib*.deb; do dpkg -x "$f" /; done; ldconfig
mkdir -p /tmp/vvl && dpkg -x .gl/vulkan-validationlayers_*.deb /tmp/vvl
export VK_LAYER_PATH=/tmp/vvl/usr/share/vulkan/explicit_layer.d
export LD_LIBRARY_PATH=/tmp/vvl/usr/lib/x86_64-linux-gnu
export VK_ICD_FILENAMES=/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json
export VK_DRIVER_FILES=$VK_ICD_FILENAMES
mkdir -p /tmp/b && tar -xJf .devbin/bins.tar.xz -C /tmp/b
mkdir -p /root/.cache/ssbc-target/release && cp /tmp/b/ssbc /root/.cache/ssbc-target/release/ssbc
[ -e /work/main ] || { mkdir -p /work; ln -s "$root" /work/main; }
cd /work/main
(nvidia-smi; nvidia-smi -q -d CLOCK) > "$OUT/gpu.txt" 2>&1
start=$(date +%s)
timeout 240 /tmp/b/passes --bench --frames 5 > "$OUT/bench.txt" 2>&1
echo "bench exit $? in $(( $(date +%s) - start )) s" >> "$OUT/summary.txt"
mkdir -p "$OUT/tests"
start=$(date +%s)
export OUT
run_one() { n=$(basename "$1"); timeout 150 "$1" > "$OUT/tests/$n.log" 2>&1; echo "$n exit $?" >> "$OUT/summary.txt"; }
export -f run_one
timeout 280 bash -c 'ls /tmp/b/tests/* | xargs -P 4 -n 1 bash -c "run_one \$0"' 
echo "tests in $(( $(date +%s) - start )) s" >> "$OUT/summary.txt"
tar -czf "$OUT/tests.tgz" -C "$OUT" tests && rm -rf "$OUT/tests"
cat "$OUT/summary.txt"
