#!/usr/bin/env bash
# Checks the README's two commands the way a newcomer meets them: in a fresh
# Debian 12 root (debootstrap minbase) with only Rust, gcc, g++, make and
# git, on a clean clone of this repository's HEAD, runs
#   ./scripts/render.sh   then   ./scripts/test.sh
# and prints their wall times. Run as root on Debian (it installs
# debootstrap); needs network access to Debian's mirror and crates.io.
#
#   scripts/fresh-check.sh [WORKDIR]     (default /var/tmp/ssbc-fresh)
#
# Rust is copied from the host's active toolchain (no rustup download). The
# minbase root is cached as WORKDIR/base.tar; each run starts from a copy.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
work=${1:-/var/tmp/ssbc-fresh}
root=$work/root
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}

if [ "$(id -u)" -ne 0 ]; then
  echo "fresh-check: run as root (debootstrap and chroot)" >&2
  exit 1
fi
if ! command -v debootstrap >/dev/null; then
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends debootstrap
fi
mkdir -p "$work"

cleanup() {
  for m in dev proc sys; do
    if mountpoint -q "$root/$m"; then umount -R -l "$root/$m"; fi
  done
}
trap cleanup EXIT
cleanup
rm -rf "$root"

if [ ! -f "$work/base.tar" ]; then
  echo "fresh-check: debootstrap --variant=minbase bookworm" >&2
  debootstrap --variant=minbase bookworm "$work/base" "$mirror" >/dev/null
  tar -C "$work/base" -cf "$work/base.tar" .
  rm -rf "$work/base"
fi
mkdir -p "$root"
tar -C "$root" -xf "$work/base.tar"
cp /etc/resolv.conf "$root/etc/resolv.conf"
mount -t proc proc "$root/proc"
mount -t sysfs sys "$root/sys"
mount --rbind /dev "$root/dev"
mount --make-rslave "$root/dev"

# The newcomer's machine: Rust, gcc, g++, make, git.
chroot "$root" /bin/bash -c "export DEBIAN_FRONTEND=noninteractive; apt-get update -q >/dev/null && \
  apt-get install -y -q --no-install-recommends gcc g++ make git ca-certificates libc6-dev >/dev/null"
# Networks with an intercepting proxy: trust what the host trusts.
if [ -f /etc/ssl/certs/ca-certificates.crt ]; then
  mkdir -p "$root/etc/ssl/certs"
  cp /etc/ssl/certs/ca-certificates.crt "$root/etc/ssl/certs/ca-certificates.crt"
fi
toolchain=$(rustc --print sysroot)
mkdir -p "$root/opt/rust"
cp -a "$toolchain/." "$root/opt/rust/"
git clone -q "$repo" "$root/root/ssbc"
git -C "$root/root/ssbc" checkout -q "$(git -C "$repo" rev-parse HEAD)"

run() {
  local name=$1
  local start end status
  start=$(date +%s)
  set +e
  chroot "$root" /usr/bin/env -i HOME=/root TERM=dumb PATH=/opt/rust/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    /bin/bash -c "cd /root/ssbc && $name" >"$work/$(basename "$name").log" 2>&1
  status=$?
  set -e
  end=$(date +%s)
  printf 'fresh-check: %-20s exit %d, %d min %02d s (log: %s)\n' "$name" "$status" \
    $(((end - start) / 60)) $(((end - start) % 60)) "$work/$(basename "$name").log"
  return $status
}

echo "fresh-check: Debian $(cat "$root/etc/debian_version"), $(nproc) cores, rustc $("$root/opt/rust/bin/rustc" --version | cut -d' ' -f2), commit $(git -C "$repo" rev-parse --short HEAD)"
run ./scripts/render.sh
run ./scripts/test.sh
tail -n 3 "$work/test.sh.log"
# The README's commands must leave the checkout clean (outputs go to out/).
dirty=$(git -C "$root/root/ssbc" status --porcelain)
if [ -n "$dirty" ]; then
  echo "fresh-check: the checkout is not clean after both commands:"
  echo "$dirty"
  exit 1
fi
echo "fresh-check: checkout clean after both commands"
