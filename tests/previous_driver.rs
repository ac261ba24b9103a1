//! The previous lavapipe keeps working: a smoke set of renders on Debian
//! 12's own Mesa 22.3 (unpacked beside the installed Mesa 25 by
//! scripts/setup.sh, selected with `VK_ICD_FILENAMES`), validation on,
//! each the same as on the installed driver in every layer up to float
//! noise. The two drivers compile the same SPIR-V with the same LLVM 15,
//! and have so far agreed to the bit.

mod common;

use std::path::Path;
use std::process::Command;

/// Renders `ssbc render ARGS --layers --validate` into `out`, on the ICD
/// `icd` (None: the test command's driver); returns the driver line.
fn render(args: &[&str], icd: Option<&str>, out: &Path) -> String {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_ssbc"));
    cmd.arg("render")
        .args(args)
        .args(["--layers", "--validate", "-o"])
        .arg(out)
        .env("RUST_LOG", "info");
    if let Some(icd) = icd {
        cmd.env("VK_ICD_FILENAMES", icd)
            .env_remove("VK_DRIVER_FILES");
    }
    let run = cmd.output().expect("run ssbc");
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(
        run.status.success(),
        "{args:?} on {icd:?} failed ({}):\n{stderr}",
        run.status
    );
    stderr
        .lines()
        .find(|l| l.contains("using Vulkan device"))
        .unwrap_or_else(|| panic!("no device line in:\n{stderr}"))
        .to_string()
}

#[test]
fn the_previous_driver_renders_the_same_images() {
    let Some(previous) = common::previous_driver() else {
        return;
    };
    let scenes = format!("{}/tests/scenes", env!("CARGO_MANIFEST_DIR"));
    let slabs = format!("{scenes}/slabs-room.gltf");
    let grid = format!("{scenes}/sphere-grid.gltf");
    let cases: [&[&str]; 6] = [
        &["cornell", "--size", "128x96", "--vpls", "64"],
        &["spheres", "--size", "128x96", "--vpls", "64"],
        &[
            "tori",
            "--size",
            "128x96",
            "--vpls",
            "64",
            "--steps",
            "2",
            "--ssbc-layers",
            "2",
        ],
        &[&slabs, "--size", "96x72", "--vpls", "128"],
        // ISMs with back-face maps: their own splat, fill and gathers.
        &[
            &slabs,
            "--size",
            "96x72",
            "--vpls",
            "128",
            "--ism-back-faces",
        ],
        &[&grid, "--size", "96x72", "--vpls", "64", "--gather", "full"],
    ];
    let dir = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    for (i, args) in cases.iter().enumerate() {
        let (now, before) = (
            dir.path().join(format!("now{i}.exr")),
            dir.path().join(format!("before{i}.exr")),
        );
        let installed = render(args, None, &now);
        let old = render(args, Some(&previous), &before);
        eprintln!("{args:?}\n  {installed}\n  {old}");
        assert_ne!(installed, old, "both runs used the same driver");
        let (a, b) = (common::exr_channels(&now), common::exr_channels(&before));
        assert_eq!(
            a.iter().map(|c| &c.0).collect::<Vec<_>>(),
            b.iter().map(|c| &c.0).collect::<Vec<_>>()
        );
        assert!(a.len() >= 9, "{args:?}: only {} channels", a.len());
        for ((name, x), (_, y)) in a.iter().zip(&b) {
            // Float noise: a relative 1e-4 of each sample, or of the
            // channel's mean magnitude near zero.
            let scale = y.iter().map(|v| v.abs() as f64).sum::<f64>() / y.len() as f64;
            let worst = x
                .iter()
                .zip(y)
                .map(|(p, q)| (p - q).abs() as f64 / (q.abs() as f64 + 1e-3 * scale + 1e-12))
                .fold(0.0, f64::max);
            let identical = x.iter().zip(y).all(|(p, q)| p.to_bits() == q.to_bits());
            if worst > 1e-4 {
                failures.push(format!(
                    "{args:?} {name}: differs by {worst:.2e} (relative)"
                ));
            } else if !identical {
                eprintln!("  {name}: within float noise ({worst:.1e}), not bit-identical");
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Mesa 22.3's lavapipe has no ray queries: asking it for traced ISM texels
/// or exact visibility is an error that says so, not a panic or a silent
/// fallback.
#[test]
fn without_ray_queries_traced_and_exact_visibility_are_clear_errors() {
    let Some(previous) = common::previous_driver() else {
        return;
    };
    for visibility in ["traced", "exact"] {
        let out = tempfile::tempdir().unwrap().path().join("x.exr");
        let run = Command::new(env!("CARGO_BIN_EXE_ssbc"))
            .args(["render", "cornell", "--size", "64x48", "--vpls", "16"])
            .args(["--visibility", visibility, "-o"])
            .arg(&out)
            .env("VK_ICD_FILENAMES", &previous)
            .env_remove("VK_DRIVER_FILES")
            .output()
            .expect("run ssbc");
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(1), "{visibility}: {stderr}");
        assert!(
            stderr.contains("ray queries") && !stderr.contains("panicked"),
            "{visibility}: {stderr}"
        );
    }
}
