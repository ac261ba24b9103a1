//! SSBC as a post-process in a host's frame (examples/postprocess.rs): the
//! host's own G-buffer and clamped lighting, SSBC recorded into the host's
//! command buffer, and the residual checked against the CPU twin on the
//! read-back G-buffer, under validation with synchronization checks.

#[path = "../examples/postprocess.rs"]
#[allow(dead_code)]
mod postprocess;

use ssbc::settings::{Integration, LayerResolution};

#[test]
fn ssbc_on_the_hosts_images_matches_the_cpu_twin() {
    for layer1 in [LayerResolution::Full, LayerResolution::Half] {
        eprintln!("second layer at {layer1:?} resolution");
        check_report(postprocess::run(96, 72, layer1).expect("post-process example"));
    }
}

fn check_report(report: postprocess::PostProcessReport) {
    // On the host's device with only RequiredFeatures::POST_PROCESS
    // (validation would report any use of what it lacks).
    assert_eq!(report.validation_messages, 0);
    let refusal = report.renderer_refusal.as_deref().unwrap_or("none");
    assert!(
        refusal.contains("dynamicRendering, hostQueryReset"),
        "the renderer on a post-process-only device: {refusal}"
    );
    // Budget first: the estimate made before anything existed is what
    // prepare allocated (up to the allocator's alignment), and recording
    // allocated nothing.
    eprintln!(
        "one slot: estimated {} bytes, allocated {} bytes",
        report.memory_estimate, report.memory_allocated
    );
    let ratio = report.memory_allocated as f64 / report.memory_estimate as f64;
    assert!(
        (1.0..1.01).contains(&ratio),
        "allocated {} bytes against an estimate of {}",
        report.memory_allocated,
        report.memory_estimate
    );
    assert_eq!(report.allocated_while_recording, 0);
    // Timed in the host's command buffer: the post-process and its step,
    // each inside the frame.
    for (name, ms) in &report.passes {
        eprintln!("{name:40} {ms:9.3} ms");
    }
    let ms = |name: &str| {
        report
            .passes
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, ms)| *ms)
            .unwrap_or_else(|| panic!("no pass {name} in {:?}", report.passes))
    };
    let (whole, step) = (ms("ssbc_postprocess"), ms("ssbc_step_1"));
    assert!(
        0.0 < step && step <= whole && whole <= report.frame_ms,
        "step {step} ms, post-process {whole} ms, frame {} ms",
        report.frame_ms
    );
    // The second layer holds hidden surfaces, and they add light.
    assert!(
        report.hidden_pixels > 30,
        "{} hidden pixels",
        report.hidden_pixels
    );
    assert!(
        report.mean_residual_two_layers > 1.02 * report.mean_residual,
        "residual {} with two layers, {} with one",
        report.mean_residual_two_layers,
        report.mean_residual
    );
    // The bound must bite for the check to mean anything.
    assert!(
        report.mean_residual > 0.01 * report.mean_s0,
        "residual {} vs S0 {}",
        report.mean_residual,
        report.mean_s0
    );
    for ((layers, integration, rmse), (.., ratio)) in
        report.relative_rmse.iter().zip(&report.mean_ratio)
    {
        eprintln!(
            "{layers} layer(s), {integration:?}: relative RMSE {rmse:.2e}, mean ratio {ratio:.5}"
        );
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

/// Bad host inputs are clear errors, recorded nothing, and leave the
/// post-process usable.
#[test]
fn bad_host_inputs_are_clear_errors() {
    use ash::vk;
    use ssbc::postprocess::{
        HostCamera, HostGeometry, HostImage, NormalEncoding, OutputWrite, PostOutput,
        PostProcessInputs, PostProcessShape, ReceiverBrdf, SsbcPostProcess,
    };
    use ssbc::settings::SsbcSettings;
    use ssbc::vk::{Device, DeviceSelector, Instance, Validation};

    let instance = Instance::with_validation(Validation::Synchronization, &[]).unwrap();
    let log = instance.validation_log();
    let device = Device::new(instance, &DeviceSelector::default(), &[]).unwrap();
    assert!(SsbcPostProcess::new(&device, 0).is_err());
    let mut post = SsbcPostProcess::new(&device, 2).unwrap();
    // Never dereferenced: every call below fails its checks first. Each
    // input its own (fake) handle: the output may not be one of them.
    use ash::vk::Handle;
    let image = HostImage {
        image: vk::Image::from_raw(1),
        view: vk::ImageView::null(),
        format: vk::Format::R32G32B32A32_SFLOAT,
        extent: (64, 48),
        layout: vk::ImageLayout::GENERAL,
    };
    let half = HostImage {
        extent: (32, 24),
        ..image
    };
    let third = HostImage {
        extent: (22, 16),
        ..image
    };
    let handle = |raw: u64| HostImage {
        image: vk::Image::from_raw(raw),
        ..image
    };
    let inputs = PostProcessInputs {
        geometry: HostGeometry::Position(image),
        normal: handle(2),
        normal_encoding: NormalEncoding::Signed,
        albedo: handle(3),
        s0: handle(4),
        sources: None,
        receivers: ReceiverBrdf::Lambertian,
        output: handle(5),
        write: OutputWrite::Copy,
        camera: HostCamera::LookAt {
            position: glam::Vec3::new(0.0, 1.0, 3.0),
            forward: -glam::Vec3::Z,
            up: glam::Vec3::Y,
            yfov: 0.8,
        },
        bound: 4.0,
        typical_depth: 3.0,
        hidden: None,
    };
    let one = SsbcSettings {
        steps: 1,
        ..Default::default()
    };
    let cmd = vk::CommandBuffer::null();
    let cases: Vec<(PostProcessInputs, SsbcSettings, PostOutput, usize, &str)> = vec![
        (
            PostProcessInputs {
                normal: HostImage {
                    format: vk::Format::R8G8_UNORM,
                    ..inputs.normal
                },
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "normal image is R8G8_UNORM; as normal (xyz) it must be one of",
        ),
        (
            PostProcessInputs {
                s0: HostImage {
                    extent: (32, 48),
                    ..inputs.s0
                },
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "s0 image is (32, 48)",
        ),
        (
            PostProcessInputs {
                bound: f32::NAN,
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "finite and positive",
        ),
        (
            inputs,
            SsbcSettings {
                steps: 0,
                ..Default::default()
            },
            PostOutput::Compensated,
            0,
            "0 steps",
        ),
        (
            inputs,
            one.clone(),
            PostOutput::Residual(2),
            0,
            "residual 2",
        ),
        (
            inputs,
            one.clone(),
            PostOutput::Compensated,
            5,
            "frame slot 5 of 2",
        ),
        (
            // The second layer is the full size or half of it.
            PostProcessInputs {
                hidden: Some(ssbc::postprocess::PostProcessLayer {
                    position: third,
                    normal: third,
                    albedo: third,
                    s0: third,
                }),
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "second layer's position image is (22, 16); it must be the size of the geometry image ((64, 48)) or half of it, rounded up ((32, 24))",
        ),
        (
            // ...all four images alike.
            PostProcessInputs {
                hidden: Some(ssbc::postprocess::PostProcessLayer {
                    position: image,
                    normal: half,
                    albedo: image,
                    s0: image,
                }),
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "second layer's normal image is (32, 24); it must be (64, 48), the size of the second layer's position image",
        ),
        (
            // Depth needs the matrices to become positions.
            PostProcessInputs {
                geometry: HostGeometry::Depth {
                    image: HostImage {
                        format: vk::Format::D32_SFLOAT,
                        ..image
                    },
                    background: 0.0,
                },
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "a depth image needs the camera as matrices",
        ),
        (
            PostProcessInputs {
                camera: HostCamera::Matrices {
                    view: glam::Mat4::IDENTITY,
                    projection: glam::camera::rh::proj::vulkan::orthographic(
                        -1.0, 1.0, -1.0, 1.0, 0.1, 10.0,
                    ),
                    jitter: glam::Vec2::ZERO,
                },
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "not a perspective one",
        ),
        (
            // Roughness in w: not in 2 bits of alpha.
            PostProcessInputs {
                normal: HostImage {
                    format: vk::Format::A2B10G10R10_UNORM_PACK32,
                    ..inputs.normal
                },
                normal_encoding: NormalEncoding::Unsigned,
                receivers: ReceiverBrdf::MetallicRoughnessInW,
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "MetallicRoughnessInW reads the roughness from the normal image's w",
        ),
        (
            PostProcessInputs {
                output: HostImage {
                    format: vk::Format::R8G8B8A8_UNORM,
                    ..inputs.output
                },
                write: OutputWrite::Store,
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "output image is R8G8B8A8_UNORM; as output (store, add) it must be one of",
        ),
        (
            PostProcessInputs {
                output: inputs.normal,
                ..inputs
            },
            one.clone(),
            PostOutput::Compensated,
            0,
            "the output image is one of the inputs",
        ),
    ];
    let check = |post: &mut SsbcPostProcess,
                 case: (PostProcessInputs, SsbcSettings, PostOutput, usize, &str)| {
        let (inputs, settings, output, slot, expected) = case;
        let err = post
            .record(cmd, slot, &inputs, &settings, output)
            .expect_err(expected);
        let text = err.to_string();
        assert!(text.contains(expected), "{text} (expected: {expected})");
        assert!(!text.contains('\n'), "{text}");
    };
    for case in cases {
        check(&mut post, case);
    }
    // record() allocates nothing: unprepared slots, or another shape, are
    // errors naming what prepare() must make.
    check(
        &mut post,
        (
            inputs,
            one.clone(),
            PostOutput::Compensated,
            0,
            "frame slot 0 holds nothing",
        ),
    );
    assert!(post
        .prepare(PostProcessShape::new(
            (64, 48),
            &SsbcSettings {
                steps: 0,
                ..one.clone()
            },
            None
        ))
        .is_err());
    post.prepare(PostProcessShape::new((64, 48), &one, None))
        .unwrap();
    let two = SsbcSettings {
        steps: 2,
        ..one.clone()
    };
    check(
        &mut post,
        (inputs, two, PostOutput::Compensated, 1, "steps: 2"),
    );
    // Inputs in other formats are converted into copies the shape counts:
    // a slot prepared for RGBA32F inputs refuses them.
    let packed = PostProcessInputs {
        albedo: HostImage {
            format: vk::Format::R8G8B8A8_SRGB,
            ..inputs.albedo
        },
        ..inputs
    };
    let shape = PostProcessShape::for_inputs(&packed, &one).unwrap();
    assert_eq!(shape.conversion, ssbc::postprocess::Conversion::Inputs);
    let extra = SsbcPostProcess::memory(&shape, 1).per_slot
        - SsbcPostProcess::memory(&PostProcessShape::new((64, 48), &one, None), 1).per_slot;
    assert_eq!(
        extra,
        64 * 48 * 32,
        "RGBA32F copies of position and S0 (normal and albedo are packed either way)"
    );
    check(
        &mut post,
        (
            packed,
            one.clone(),
            PostOutput::Compensated,
            0,
            "conversion: Inputs",
        ),
    );
    drop(post);
    drop(device);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}
