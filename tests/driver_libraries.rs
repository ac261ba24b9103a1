//! The Vulkan loader and driver stay mapped after the last renderer drops:
//! NVIDIA's driver left thread-exit destructors behind, and a thread that
//! outlived its renderer crashed when it exited once the loader had
//! unloaded the driver (src/vk/driver_libraries.rs). Alone in its binary:
//! no other renderer may be alive while it looks.

mod common;

use std::collections::HashSet;

fn mapped() -> HashSet<String> {
    std::fs::read_to_string("/proc/self/maps")
        .expect("/proc/self/maps")
        .lines()
        .filter_map(|l| l.split_whitespace().nth(5))
        .filter(|p| p.starts_with('/') && p.contains(".so"))
        .map(str::to_owned)
        .collect()
}

#[test]
fn the_driver_stays_loaded_after_the_last_renderer_drops() {
    let before = mapped();
    let renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let loaded: HashSet<String> = mapped().difference(&before).cloned().collect();
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
    assert!(
        loaded.iter().any(|p| p.contains("libvulkan")),
        "the renderer loaded no Vulkan loader? {loaded:?}"
    );
    let after = mapped();
    let gone: Vec<&String> = loaded.iter().filter(|p| !after.contains(*p)).collect();
    assert!(gone.is_empty(), "unloaded with the last renderer: {gone:?}");
}
