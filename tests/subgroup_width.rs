//! Subgroup width stays irrelevant: lavapipe forced to 4-wide subgroups
//! (`LP_NATIVE_VECTOR_WIDTH=128`) renders every layer bit-identically to
//! its 8-wide default. Real GPUs run 32 or 64 wide; no shader may depend on
//! which invocations share a subgroup (reductions in a fixed order, claims
//! resolved by value, not by arrival).
//!
//! Each width renders with a Mesa shader cache of its own: lavapipe's disk
//! cache does not key its entries by the vector width, so a 128-bit
//! process that loads the vertex shaders a 256-bit one cached writes eight
//! vertices' outputs into room for four and corrupts its heap (the crash
//! this test used to retry; tests/lavapipe_shader_cache.rs reproduces it
//! without ssbc). Any crash now fails the test, with the signal and what
//! the driver printed.

mod common;

use std::os::unix::process::ExitStatusExt;
use std::path::Path;
use std::process::Command;

/// Renders `ssbc render cornell ARGS --layers` (validation on) into `out`
/// with the extra environment `env` and the Mesa shader cache `cache`;
/// returns the device line it printed.
fn render(args: &[&str], env: &[(&str, &str)], cache: &Path, out: &Path) -> String {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_ssbc"));
    cmd.args(["render", "cornell", "--size", "128x96", "--vpls", "64"])
        .args(args)
        .args(["--layers", "--validate", "-o"])
        .arg(out)
        .env("MESA_SHADER_CACHE_DIR", cache)
        .env_remove("MESA_SHADER_CACHE_DISABLE");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let run = cmd.output().expect("run ssbc");
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    if let Some(signal) = run.status.signal() {
        panic!("{args:?} {env:?} killed by signal {signal}:\n{stderr}");
    }
    assert!(
        run.status.success(),
        "{args:?} {env:?} failed ({}):\n{stderr}",
        run.status
    );
    stderr
        .lines()
        .find(|l| l.starts_with("GPU timings on"))
        .unwrap_or_else(|| panic!("no device line in:\n{stderr}"))
        .to_string()
}

#[test]
fn four_wide_subgroups_render_the_same_bits() {
    let dir = tempfile::tempdir().unwrap();
    let (wide_cache, narrow_cache) = (dir.path().join("cache256"), dir.path().join("cache128"));
    // The default interleaved gather with both layers and two steps, the
    // full gather, and brute-force integration: every kernel runs.
    let configs: [&[&str]; 3] = [
        &["--steps", "2", "--ssbc-layers", "2"],
        &["--gather", "full", "--steps", "1"],
        &["--integration", "brute", "--steps", "1"],
    ];
    for (i, args) in configs.iter().enumerate() {
        let wide = dir.path().join(format!("wide{i}.exr"));
        let narrow = dir.path().join(format!("narrow{i}.exr"));
        let default_device = render(args, &[], &wide_cache, &wide);
        if !default_device.contains("llvmpipe") {
            common::cannot_check(&format!(
                "not lavapipe ({default_device}): the width cannot be forced"
            ));
            return;
        }
        let forced = render(
            args,
            &[("LP_NATIVE_VECTOR_WIDTH", "128")],
            &narrow_cache,
            &narrow,
        );
        assert!(forced.contains("128 bits"), "width not forced: {forced}");
        assert_ne!(default_device, forced, "the default is already 4 wide");
        let (a, b) = (common::exr_channels(&wide), common::exr_channels(&narrow));
        assert!(a.len() >= 12, "{args:?}: only {} channels", a.len());
        assert_eq!(
            a.iter().map(|c| &c.0).collect::<Vec<_>>(),
            b.iter().map(|c| &c.0).collect::<Vec<_>>()
        );
        for ((name, x), (_, y)) in a.iter().zip(&b) {
            let differing = x
                .iter()
                .zip(y)
                .filter(|(p, q)| p.to_bits() != q.to_bits())
                .count();
            assert_eq!(
                differing, 0,
                "{args:?}: {name} differs in {differing} samples"
            );
        }
    }
}
