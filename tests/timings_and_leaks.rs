//! GPU timestamps are sane, and leaked Vulkan objects are caught.

mod common;

use ash::vk;
use ssbc::renderer::{Renderer, RendererConfig};

#[test]
fn every_pass_is_timed_and_fits_in_the_frame() {
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let frame = common::render_validated(&scene, &common::small(128, 96));
    let t = &frame.timings;
    let names: Vec<&str> = t.passes.iter().map(|p| p.name.as_str()).collect();
    for expected in ["shadow_maps", "gbuffer", "direct_lighting"] {
        assert!(
            names.contains(&expected),
            "pass {expected} missing from {names:?}"
        );
    }
    for p in &t.passes {
        assert!(p.gpu_ms > 0.0, "pass {} has gpu_ms {}", p.name, p.gpu_ms);
    }
    let sum: f64 = t
        .passes
        .iter()
        .filter(|p| !p.name.contains('/'))
        .map(|p| p.gpu_ms)
        .sum();
    assert!(
        sum <= t.frame_gpu_ms,
        "passes sum {sum} > frame {}",
        t.frame_gpu_ms
    );
    assert!(
        t.frame_gpu_ms < 60_000.0,
        "implausible frame time {}",
        t.frame_gpu_ms
    );
}

/// The safety net itself: a leaked buffer is reported by validation when the
/// device is destroyed, so `render_validated`'s zero-message check can fail.
#[test]
fn a_leaked_buffer_is_reported_at_device_destruction() {
    let renderer = Renderer::new(&RendererConfig {
        validation: true,
        ..Default::default()
    })
    .unwrap();
    let log = renderer.validation_log();
    // A raw buffer that nothing owns, so nothing destroys it.
    let info = vk::BufferCreateInfo::default()
        .size(256)
        .usage(vk::BufferUsageFlags::STORAGE_BUFFER);
    // SAFETY: valid create info on a live device; the handle is deliberately leaked.
    let _leaked = unsafe { renderer.device().raw.create_buffer(&info, None) }.unwrap();
    drop(renderer);
    assert!(
        log.total() > 0,
        "validation should report the leaked VkBuffer"
    );
}
