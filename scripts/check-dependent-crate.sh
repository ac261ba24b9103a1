#!/usr/bin/env bash
# Builds a new crate outside this repository that depends on ssbc as an
# engine would (`ssbc = { path = ..., default-features = false }`), with
# nothing set by hand: shaderc-sys must find the shaderc library
# scripts/setup.sh prepared (through pkg-config) on its own. Then runs it:
# one small frame of the built-in cornell on the Vulkan driver the
# environment selects. Called by scripts/test.sh; prints the build time.
#
# The crate starts from this repository's Cargo.lock (the same versions) and
# builds into a target folder of its own, kept beside the suite's
# (CARGO_TARGET_DIR/dependent-crate) so that later runs reuse its
# dependencies. shaderc-sys is cleaned first every time: its build script
# is where the library is found, and a cached result would hide a setup
# that no longer provides it.
set -euo pipefail
repo=$(cd "$(dirname "$0")/.." && pwd)
crate=$(mktemp -d "${TMPDIR:-/tmp}/ssbc-dependent.XXXXXX")
trap 'rm -rf "$crate"' EXIT
mkdir -p "$crate/src"
cat >"$crate/Cargo.toml" <<TOML
[package]
name = "ssbc-dependent"
version = "0.0.0"
edition = "2021"
publish = false

[dependencies]
ssbc = { path = "$repo", default-features = false }

[workspace]
TOML
cat >"$crate/src/main.rs" <<'RUST'
fn main() -> ssbc::Result<()> {
    let config = ssbc::RendererConfig {
        validation: true,
        ..Default::default()
    };
    let mut renderer = ssbc::Renderer::new(&config)?;
    let log = renderer.validation_log();
    let mut scene = ssbc::scene::load("cornell")?;
    scene.ensure_light();
    let frame = renderer.render(&scene, &ssbc::RenderSettings::new(32, 24))?;
    drop(renderer);
    let rgba = &frame.image.rgba;
    let mean = rgba.iter().sum::<f32>() / rgba.len() as f32;
    assert!(mean.is_finite() && mean > 0.0, "mean radiance {mean}");
    assert_eq!(log.total(), 0, "validation: {:?}", log.messages());
    println!("dependent crate: cornell 32x24, mean {mean:.4}, validation clean");
    Ok(())
}
RUST
cp "$repo/Cargo.lock" "$crate/Cargo.lock"
# Outside the checkout: none of its .cargo/config.toml applies, as for a user.
target=${CARGO_TARGET_DIR:-$repo/target}/dependent-crate
export CARGO_TARGET_DIR=$target
unset SHADERC_LIB_DIR
cd "$crate"
start=$(date +%s)
cargo clean --release --quiet -p shaderc-sys 2>/dev/null || true
if ! cargo build --release --quiet 2>"$crate/build.log"; then
  cat "$crate/build.log" >&2
  echo "check-dependent-crate: a crate depending on ssbc did not build (above)" >&2
  exit 1
fi
echo "check-dependent-crate: built in $(( $(date +%s) - start )) s" >&2
cargo run --release --quiet
