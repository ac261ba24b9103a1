//! ssbc inside a host engine's frame loop (examples/host_engine.rs): the
//! host's own instance, device and command buffers, two frames in flight,
//! a TAA-jittered camera; ssbc's resident frame for the clamped lighting and
//! the SSBC post-process on the host's own depth, packed normals and sRGB
//! albedo; per-pass timings read back; the image checked against ssbc's own
//! render, under validation with synchronization checks.

#[path = "../examples/host_engine.rs"]
#[allow(dead_code)]
mod host_engine;

#[test]
fn a_host_engine_frame_loop_matches_ssbcs_own_render() {
    let report = host_engine::run(128, 96, 4).expect("host engine example");
    eprintln!("{report:#?}");
    assert_eq!(report.validation_messages, 0);
    // SSBC must add something for the comparison to mean anything.
    assert!(
        report.compensation_share > 0.02,
        "{}",
        report.compensation_share
    );
    assert!(
        (report.mean_ratio - 1.0).abs() < 0.01,
        "mean {} of ssbc's own render",
        report.mean_ratio
    );
    assert!(
        report.block_rel_mse < 0.002,
        "relMSE of 4x4 blocks {}",
        report.block_rel_mse
    );
    // The image is mostly ssbc's own S0: the compensation alone must match
    // too (measured 5.0% RMSE and 0.9935 at 128x96, from the host's 10-bit
    // normals and 8-bit albedo; docs/embedding.md).
    let (rmse, mean) = report.compensation;
    assert!(
        rmse < 0.1 && (mean - 1.0).abs() < 0.02,
        "compensation: relative RMSE {rmse}, mean {mean}"
    );
    let has =
        |passes: &[(String, f64)], name: &str| passes.iter().any(|(n, ms)| n == name && *ms > 0.0);
    for pass in ["gbuffer", "direct_lighting", "indirect_bounded"] {
        assert!(
            has(&report.resident_passes, pass),
            "{pass} in {:?}",
            report.resident_passes
        );
    }
    for pass in [
        "ssbc_postprocess",
        "ssbc_postprocess_convert",
        "ssbc_step_1",
        "ssbc_postprocess_write",
    ] {
        assert!(
            has(&report.post_passes, pass),
            "{pass} in {:?}",
            report.post_passes
        );
    }
}
