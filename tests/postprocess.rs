//! SSBC as a post-process in a host's frame (examples/postprocess.rs): the
//! host's own G-buffer and clamped lighting, SSBC recorded into the host's
//! command buffer, and the residual checked against the CPU twin on the
//! read-back G-buffer, under validation with synchronization checks.

#[path = "../examples/postprocess.rs"]
#[allow(dead_code)]
mod postprocess;

use ssbc::passes::ssbc::Integration;

#[test]
fn ssbc_on_the_hosts_images_matches_the_cpu_twin() {
    let report = postprocess::run(96, 72).expect("post-process example");
    assert_eq!(report.validation_messages, 0);
    // The bound must bite for the check to mean anything.
    assert!(
        report.mean_residual > 0.01 * report.mean_s0,
        "residual {} vs S0 {}",
        report.mean_residual,
        report.mean_s0
    );
    for ((integration, rmse), (_, ratio)) in report.relative_rmse.iter().zip(&report.mean_ratio) {
        eprintln!("{integration:?}: relative RMSE {rmse:.2e}, mean ratio {ratio:.5}");
        let (max_rmse, max_mean) = match integration {
            Integration::Brute => (1e-4, 1e-4),
            Integration::Hierarchical => (0.03, 0.02),
        };
        assert!(*rmse < max_rmse, "{integration:?}: relative RMSE {rmse}");
        assert!(
            (ratio - 1.0).abs() < max_mean,
            "{integration:?}: mean ratio {ratio}"
        );
    }
}
