//! The embedding example runs: a host-owned instance and device, ssbc on
//! them, a frame read back, and the host destroying its own objects after,
//! under the validation layer (a double destroy or a leak of ssbc's own
//! objects would be reported).

#[path = "../examples/embed.rs"]
mod embed;

#[test]
fn host_owned_device_renders_and_survives_the_renderer() {
    let report = embed::run(true).expect("embed example");
    assert_eq!(
        report.validation_messages, 0,
        "validation messages in the host's messenger"
    );
    assert!(report.mean_radiance > 0.0 && report.mean_radiance.is_finite());
    assert_eq!(
        report.handoff_max_difference, 0.0,
        "the GPU image handed over is the frame read back"
    );
    let names: Vec<&str> = report.passes.iter().map(|(n, _)| n.as_str()).collect();
    assert!(
        names.contains(&"indirect_bounded") && names.contains(&"ssbc_step_1"),
        "{names:?}"
    );
}

#[test]
fn missing_features_are_named() {
    let missing = ssbc::vk::RequiredFeatures {
        host_query_reset: false,
        dynamic_rendering: false,
        ..ssbc::vk::RequiredFeatures::ALL
    }
    .missing();
    assert_eq!(missing, ["dynamicRendering", "hostQueryReset"]);
    // The post-process alone needs neither.
    assert!(ssbc::vk::RequiredFeatures::POST_PROCESS
        .missing_from(ssbc::vk::RequiredFeatures::POST_PROCESS)
        .is_empty());
    assert_eq!(
        ssbc::vk::RequiredFeatures::POST_PROCESS.missing(),
        ["dynamicRendering", "hostQueryReset"]
    );
    let none = ssbc::vk::RequiredFeatures::default();
    assert_eq!(
        none.missing_from(ssbc::vk::RequiredFeatures::POST_PROCESS),
        ["synchronization2", "timelineSemaphore"]
    );
}
