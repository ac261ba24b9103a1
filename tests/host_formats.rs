//! SSBC as a post-process on a G-buffer in the host's own formats
//! (examples/host_formats.rs): hardware depth with the camera as jittered
//! matrices, packed normals, sRGB albedo, half-float lighting, converted by
//! ssbc; its result stored or added by a compute shader; checked against
//! the CPU twin under validation with synchronization checks.

#[path = "../examples/host_formats.rs"]
#[allow(dead_code)]
mod host_formats;

/// The host's own formats (depth, RGB10A2 normals, sRGB albedo, RGBA16F
/// lighting) and a jittered camera given as matrices: converted by ssbc,
/// its result stored or added by a compute shader.
#[test]
fn ssbc_on_the_hosts_own_formats_matches_the_cpu_twin() {
    let report = host_formats::run(96, 72).expect("host formats example");
    eprintln!("{report:#?}");
    assert_eq!(report.validation_messages, 0);
    assert!(
        report.residual_share > 0.01,
        "the bound must bite: {}",
        report.residual_share
    );
    // Against the twin on the host's G-buffer as stored (decoded on the
    // CPU): ssbc's conversion and jittered camera are exact up to the
    // sampler's sRGB decoding (measured 1.6e-3 at 160x120).
    let (rmse, mean) = report.stored;
    assert!(
        rmse < 5e-3 && (mean - 1.0).abs() < 3e-3,
        "stored: {rmse} {mean}"
    );
    // The jitter is where the pixels are: a twin without it is far off.
    assert!(
        report.stored_against_unjittered > 10.0 * rmse,
        "{} against the unjittered twin, {rmse} with the jitter",
        report.stored_against_unjittered
    );
    // What packing costs the residual against the unpacked G-buffer: mostly
    // the 10-bit normals at the pixels beside creases (docs/embedding.md),
    // little in the mean.
    let (_, mean) = report.stored_against_unpacked;
    assert!(
        (mean - 1.0).abs() < 0.01,
        "against the unpacked G-buffer: mean {mean}"
    );
    // Added onto the RGBA16F lighting, hierarchical integration: halves of
    // S0 + S_1 (S_1 a few % of it) less S0.
    let (rmse, mean) = report.added;
    assert!(
        rmse < 0.04 && (mean - 1.0).abs() < 0.02,
        "added: {rmse} {mean}"
    );
    let ratio = report.memory_allocated as f64 / report.memory_estimate as f64;
    assert!(
        (1.0..1.01).contains(&ratio),
        "allocated {} against {}",
        report.memory_allocated,
        report.memory_estimate
    );
    for pass in [
        "ssbc_postprocess",
        "ssbc_postprocess_convert",
        "ssbc_step_1",
        "ssbc_postprocess_write",
    ] {
        assert!(
            report.passes.iter().any(|(n, ms)| n == pass && *ms > 0.0),
            "{pass} in {:?}",
            report.passes
        );
    }
}
