//! Shaders checked for out-of-bounds accesses: the ISM, bounded-gather
//! (interleaved with 4x4 and 3x3 patterns, and full) and SSBC passes (with
//! one and two G-buffer layers; and
//! the rest of the frame) under GPU-assisted validation, which instruments
//! every buffer and image access; a deliberately out-of-bounds kernel shows
//! the check can fail. And no layer of a frame holds a NaN or an infinity.

mod common;

use ash::vk;
use ssbc::renderer::Bound;
use ssbc::settings::Integration;
use ssbc::settings::{Gather, LayerResolution};
use ssbc::vk::{
    Binding, BindingAccess, BindingInfo, Buffer, DescriptorPool, DescriptorSetLayout, Device,
    Instance, Pipeline, Shader, Validation,
};

#[test]
fn ism_and_ssbc_stay_in_bounds_under_gpu_assisted_validation() {
    let mut renderer = common::gpu_assisted_renderer();
    let mut open_box = common::ssbc_accuracy::open_box();
    open_box.ensure_light();
    // (spheres: glossy VPLs, receivers, glossy evaluation points (their
    // list and kernel), and SSBC receivers evaluated alone.)
    let scenes = [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
        open_box,
        ssbc::scene::builtin::spheres(),
    ];
    for scene in &scenes {
        // (The odd size also with a half-resolution second G-buffer layer:
        // its images and pyramid 65 x 49 and 20 x 15; brute force with a
        // full-resolution one.)
        for (size, integration, bound, pattern, layer1) in [
            ((96, 72), Integration::Hierarchical, Bound::Auto, 4, None),
            (
                (130, 98),
                Integration::Hierarchical,
                Bound::Value(2.0),
                3,
                Some(LayerResolution::Half),
            ),
            (
                (64, 48),
                Integration::Hierarchical,
                Bound::Auto,
                4,
                Some(LayerResolution::Full),
            ),
            (
                (40, 30),
                Integration::Brute,
                Bound::Auto,
                1,
                Some(LayerResolution::Full),
            ),
        ] {
            let mut s = common::small(size.0, size.1);
            match pattern {
                1 => s.gather = Gather::Full,
                n => s.interleave = n,
            }
            s.vpl.count = 16;
            s.points_per_vpl = 256;
            s.ism_tile = 16;
            s.shadow_map_size = 64;
            s.bound = bound;
            s.ssbc.steps = 2;
            s.ssbc.integration = integration;
            s.ssbc.layers = 1 + layer1.is_some() as u32;
            s.ssbc.layer1_resolution = layer1.unwrap_or_default();
            renderer.render(scene, &s).expect("render");
        }
    }
    common::finish_clean(renderer);
}

/// A kernel that writes one element past the end of its buffer.
const OUT_OF_BOUNDS: &str = r#"#version 460
layout(local_size_x = 1) in;
layout(set = 0, binding = 0) buffer Data { uint data[]; };
void main() { data[data.length() + 7u] = 1u; }
"#;

#[test]
fn gpu_assisted_validation_catches_an_out_of_bounds_write() {
    let compiler = shaderc::Compiler::new().expect("shaderc");
    let mut options = shaderc::CompileOptions::new().unwrap();
    options.set_target_env(
        shaderc::TargetEnv::Vulkan,
        shaderc::EnvVersion::Vulkan1_2 as u32,
    );
    let spirv = compiler
        .compile_into_spirv(
            OUT_OF_BOUNDS,
            shaderc::ShaderKind::Compute,
            "oob.comp",
            "main",
            Some(&options),
        )
        .expect("compile");
    let instance = Instance::with_validation(Validation::GpuAssisted, &[]).unwrap();
    let log = instance.validation_log();
    let device = Device::new(instance, &Default::default(), &[]).unwrap();
    {
        // A shader compiled here, so its pipeline is made by hand.
        let shader = Shader {
            name: "oob.comp",
            spirv: spirv.as_binary_u8().to_vec().leak(),
            bindings: &[BindingInfo {
                number: 0,
                ty: vk::DescriptorType::STORAGE_BUFFER,
                name: "data",
                access: BindingAccess::ReadWrite,
            }],
            push_bytes: 0,
            local_size: [1, 1, 1],
        };
        let layout = DescriptorSetLayout::for_shaders(&device, &[&shader]).unwrap();
        let pipeline = Pipeline::compute(&device, shader.spirv, &[&layout], 0).unwrap();
        let buffer = Buffer::new(
            &device,
            "oob",
            16,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            gpu_allocator::MemoryLocation::GpuOnly,
        )
        .unwrap();
        let pool = DescriptorPool::new(&device, &[&layout]).unwrap();
        let mut commands = ssbc::vk::CommandPool::new(&device).unwrap();
        let rec = commands.begin().unwrap();
        let set = pool
            .allocate(&layout, &[(0, Binding::StorageBuffer(&buffer))])
            .unwrap();
        pipeline.bind(rec.cmd, set, &[]);
        // SAFETY: recording with the pipeline and its set bound.
        unsafe { device.raw.cmd_dispatch(rec.cmd, 1, 1, 1) };
        let done = rec.submit().unwrap();
        device.wait(done).unwrap();
        device.wait_idle().unwrap();
    }
    drop(device);
    let messages = log.messages();
    assert!(
        messages
            .iter()
            .any(|m| m.contains("out of bounds") || m.contains("OOB") || m.contains("outside")),
        "the out-of-bounds write should be reported, got {messages:?}"
    );
}

#[test]
fn no_layer_holds_nan_or_infinity() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    for scene in [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
        ssbc::scene::builtin::spheres(),
    ] {
        let mut s = common::small(128, 96);
        s.vpl.count = 64;
        s.ssbc.steps = 3;
        s.debug_readback = true;
        let f = renderer.render(&scene, &s).unwrap();
        for layer in std::iter::once(&f.image).chain(&f.layers) {
            let bad = layer.rgba.iter().filter(|v| !v.is_finite()).count();
            assert_eq!(
                bad, 0,
                "{}: {} non-finite values in {}",
                scene.name, bad, layer.layer
            );
        }
        for (k, samples) in f.samples.iter().enumerate() {
            assert!(
                samples.iter().all(|v| v.is_finite() && *v >= 0.0),
                "samples_{}",
                k + 1
            );
        }
    }
    drop(renderer);
    assert_eq!(log.total(), 0);
}
