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
    let passes = t.passes.as_ref().expect("lavapipe has timestamps");
    let frame_ms = t.frame_gpu_ms.expect("lavapipe has timestamps");
    let names: Vec<&str> = passes.iter().map(|p| p.name.as_str()).collect();
    for expected in ["shadow_maps", "gbuffer", "direct_lighting"] {
        assert!(
            names.contains(&expected),
            "pass {expected} missing from {names:?}"
        );
    }
    for p in passes {
        assert!(p.gpu_ms > 0.0, "pass {} has gpu_ms {}", p.name, p.gpu_ms);
        // Each pass lies inside the frame (timestamps are placed, not only
        // differenced).
        assert!(
            p.start_ms >= 0.0 && p.start_ms + p.gpu_ms <= frame_ms + 1e-6,
            "pass {} at {}..{} ms outside the frame's {frame_ms} ms",
            p.name,
            p.start_ms,
            p.start_ms + p.gpu_ms
        );
    }
    // Top-level passes follow each other.
    let top: Vec<_> = passes.iter().filter(|p| !p.name.contains('/')).collect();
    for w in top.windows(2) {
        assert!(
            w[1].start_ms >= w[0].start_ms + w[0].gpu_ms - 1e-6,
            "{} starts before {} ends",
            w[1].name,
            w[0].name
        );
    }
    let sum: f64 = top.iter().map(|p| p.gpu_ms).sum();
    assert!(sum <= frame_ms, "passes sum {sum} > frame {frame_ms}");
    assert!(frame_ms < 60_000.0, "implausible frame time {frame_ms}");
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

/// A frame with more passes than the profiler has queries for still
/// records: the first passes are timed, the rest get labels only (a warning
/// says so), not a panic in the host's frame.
#[test]
fn passes_past_the_profilers_capacity_are_untimed_not_a_panic() {
    use ssbc::vk::{CommandPool, Device, DeviceSelector, GpuProfiler, Instance, Validation};

    let instance = Instance::with_validation(Validation::Synchronization, &[]).unwrap();
    let log = instance.validation_log();
    let device = Device::new(instance, &DeviceSelector::default(), &[]).unwrap();
    {
        let mut profiler = GpuProfiler::new(&device, 2, 1, true, false).unwrap();
        let mut pool = CommandPool::new(&device).unwrap();
        let rec = pool.begin().unwrap();
        profiler.begin_frame(rec.cmd, 0, true);
        let outer = profiler.begin(rec.cmd, "outer");
        let inner: Vec<_> = (0..3)
            .map(|k| profiler.begin(rec.cmd, &format!("outer/{k}")))
            .collect();
        for scope in inner.into_iter().rev() {
            profiler.end(rec.cmd, scope);
        }
        profiler.end(rec.cmd, outer);
        profiler.end_frame(rec.cmd);
        let value = rec.submit().unwrap();
        profiler.submitted(0);
        device.wait(value).unwrap();
        let times = profiler
            .resolve(0)
            .unwrap()
            .expect("timestamps on lavapipe");
        let names: Vec<&str> = times.passes.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["outer", "outer/0"]);
    }
    drop(device);
    assert_eq!(log.total(), 0, "validation: {:?}", log.messages());
}
