//! SSBC as a post-process in someone else's frame.
//!
//! The "host" here is a small engine with its own pipelines, written
//! against raw `ash`: a compute shader ray-casts its G-buffer (a room
//! corner: floor, back wall, left wall), another computes its clamped VPL
//! lighting `S0` (no ssbc code), both compiled from GLSL at run time. It
//! records its own barriers into its own command buffer, asks
//! [`SsbcPostProcess`] to record one residual step into that same command
//! buffer, submits it with its own fence, reads everything back, and checks
//! the residual against the CPU twin of SSBC on the read-back G-buffer.
//! It uses ssbc's public API only: the device ssbc creates (its raw `ash`
//! handles), `SsbcPostProcess`, and the CPU twin of `ssbc::reference`;
//! its images and buffers come from its own `gpu-allocator`.
//!
//! `cargo run --release --example postprocess [-- --half]` (`--half`: the
//! second layer at half resolution).

#[path = "common/host.rs"]
mod host;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;
use host::{
    compile, host_barrier, host_device, Buffer, Error, HostKernel, HostMemory, Image, GBUFFER_GLSL,
    LIGHTING_GLSL,
};
use ssbc::postprocess::{
    HostCamera, HostGeometry, HostImage, NormalEncoding, OutputWrite, PostOutput,
    PostProcessInputs, PostProcessLayer, PostProcessShape, ReceiverBrdf, SsbcPostProcess,
};
use ssbc::reference::{BruteForceTwin, GBufferView, TwinCamera};
use ssbc::settings::{Integration, LayerResolution, SsbcSettings};
use ssbc::vk::{Instance, Validation};

/// What the example measured.
#[derive(Debug)]
pub struct PostProcessReport {
    /// Relative RMSE of the GPU residual against the CPU twin, per G-buffer
    /// layers (1, or 2 with the hidden surfaces) and integration (brute
    /// force, hierarchical).
    pub relative_rmse: Vec<(u32, Integration, f64)>,
    /// Mean of the residual over the twin's mean, likewise.
    pub mean_ratio: Vec<(u32, Integration, f64)>,
    /// Mean residual radiance (the energy the bound removed and SSBC gives
    /// back), with one layer.
    pub mean_residual: f64,
    /// The same with the second layer: what the hidden surfaces add.
    pub mean_residual_two_layers: f64,
    /// Pixels of the second layer with a surface.
    pub hidden_pixels: usize,
    /// Mean of the host's clamped lighting S0.
    pub mean_s0: f64,
    /// Validation messages.
    pub validation_messages: u32,
    /// Device memory `SsbcPostProcess::memory_on` said one slot of one layer
    /// would hold, before anything was created.
    pub memory_estimate: u64,
    /// What `prepare` then allocated for it.
    pub memory_allocated: u64,
    /// Device memory allocated while recording (record allocates nothing).
    pub allocated_while_recording: i64,
    /// The last frame's passes and GPU ms, timed in the host's command
    /// buffer (`SsbcPostProcess::timings`).
    pub passes: Vec<(String, f64)>,
    /// Its first to last timestamp (ms).
    pub frame_ms: f64,
    /// Why `Renderer::with_device` refused the host's post-process-only
    /// device (None: it did not).
    pub renderer_refusal: Option<String>,
}

/// Runs the host frame at `w` x `h` with each integration method.
pub fn run(w: u32, h: u32, layer1: LayerResolution) -> Result<PostProcessReport, Error> {
    let instance = Instance::with_validation(Validation::Synchronization, &[])?;
    let log = instance.validation_log();
    let (device, host_raw) = host_device(&instance)?;
    let raw = &device.raw;
    let memory = HostMemory::new(&device)?;

    // --- The host's resources. ---
    let image = |name: &str| memory.image(name, w, h);
    let (position, normal, albedo, s0, output) = (
        image("host.position")?,
        image("host.normal")?,
        image("host.albedo")?,
        image("host.s0")?,
        image("host.output")?,
    );
    // The second layer (hidden surfaces), at full or half resolution.
    let (w1, h1) = layer1.extent((w, h));
    let layer1_image = |name: &str| memory.image(name, w1, h1);
    let hidden = [
        layer1_image("host.layer1.position")?,
        layer1_image("host.layer1.normal")?,
        layer1_image("host.layer1.albedo")?,
        layer1_image("host.layer1.s0")?,
    ];
    let vpl_data = host::corner_vpls();
    let mut vpls = memory.buffer(
        "host.vpls",
        std::mem::size_of_val(&vpl_data[..]) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )?;
    vpls.write(&vpl_data);
    let readback: Vec<Buffer> = (0..9)
        .map(|i| {
            let texels = if i < 5 { w * h } else { w1 * h1 };
            memory.buffer(
                &format!("host.readback{i}"),
                texels as u64 * 16,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )
        })
        .collect::<Result<_, _>>()?;
    let storage = vk::DescriptorType::STORAGE_IMAGE;
    let gbuffer_kernel = HostKernel::new(
        &device,
        &compile(GBUFFER_GLSL, "gbuffer.comp")?,
        &[storage; 3],
        64,
    )?;
    let mut lighting_types = vec![storage; 4];
    lighting_types.push(vk::DescriptorType::STORAGE_BUFFER);
    let lighting_kernel = HostKernel::new(
        &device,
        &compile(LIGHTING_GLSL, "lighting.comp")?,
        &lighting_types,
        8,
    )?;

    // SAFETY (this block): plain object creation on a live device; every
    // object is destroyed below after the host's fence has signalled.
    let (descriptor_pool, command_pool, fence) = unsafe {
        let sizes = [
            vk::DescriptorPoolSize {
                ty: storage,
                descriptor_count: 14,
            },
            vk::DescriptorPoolSize {
                ty: vk::DescriptorType::STORAGE_BUFFER,
                descriptor_count: 2,
            },
        ];
        (
            raw.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(4)
                    .pool_sizes(&sizes),
                None,
            )?,
            host::command_pool(&device)?,
            raw.create_fence(&vk::FenceCreateInfo::default(), None)?,
        )
    };
    // G-buffer and lighting sets of layer 0, then of layer 1.
    let layouts = [gbuffer_kernel.set_layout, lighting_kernel.set_layout].repeat(2);
    // SAFETY: the pool was sized for these four sets.
    let sets = unsafe {
        raw.allocate_descriptor_sets(
            &vk::DescriptorSetAllocateInfo::default()
                .descriptor_pool(descriptor_pool)
                .set_layouts(&layouts),
        )?
    };
    let image_info = |img: &Image| {
        [vk::DescriptorImageInfo::default()
            .image_view(img.view)
            .image_layout(vk::ImageLayout::GENERAL)]
    };
    let infos = [
        [&position, &normal, &albedo, &s0].map(image_info),
        [&hidden[0], &hidden[1], &hidden[2], &hidden[3]].map(image_info),
    ];
    let buffer_info = [vk::DescriptorBufferInfo::default()
        .buffer(vpls.raw)
        .range(vk::WHOLE_SIZE)];
    let mut writes = Vec::new();
    for (layer, infos) in infos.iter().enumerate() {
        let (gbuffer_set, lighting_set) = (sets[2 * layer], sets[2 * layer + 1]);
        for (set, count) in [(gbuffer_set, 3), (lighting_set, 4)] {
            for (i, info) in infos.iter().take(count).enumerate() {
                writes.push(
                    vk::WriteDescriptorSet::default()
                        .dst_set(set)
                        .dst_binding(i as u32)
                        .descriptor_type(storage)
                        .image_info(info),
                );
            }
        }
        writes.push(
            vk::WriteDescriptorSet::default()
                .dst_set(lighting_set)
                .dst_binding(4)
                .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                .buffer_info(&buffer_info),
        );
    }
    // SAFETY: every write points at live descriptors of matching types.
    unsafe { raw.update_descriptor_sets(&writes, &[]) };
    // SAFETY: allocating one primary buffer from the host's pool.
    let cmd = unsafe {
        raw.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(command_pool)
                .command_buffer_count(1),
        )?
    }[0];

    // The camera: looking into the corner from the front right, above.
    let eye = Vec3::new(0.9, 1.1, 1.6);
    let forward = (Vec3::new(-0.4, 0.5, -0.6) - eye).normalize();
    let yfov = 50f32.to_radians();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tan = (yfov * 0.5).tan();
    let aspect = w as f32 / h as f32;
    let camera_push: Vec<f32> = [eye, forward, right * tan * aspect, up * tan]
        .iter()
        .flat_map(|v| [v.x, v.y, v.z, 0.0])
        .collect();
    // Layer 1: at least 5 cm behind layer 0 (eye.w).
    let mut layer1_push = camera_push.clone();
    layer1_push[3] = 0.05;
    let bound = 1.0f32;
    let mut light_push = 64u32.to_ne_bytes().to_vec();
    light_push.extend(bound.to_ne_bytes());

    let mut post = SsbcPostProcess::new(&device, 1)?;
    let host_image = |img: &Image| HostImage {
        image: img.raw,
        view: img.view,
        format: vk::Format::R32G32B32A32_SFLOAT,
        extent: (img.width, img.height),
        layout: vk::ImageLayout::GENERAL,
    };
    let mut report = PostProcessReport {
        relative_rmse: Vec::new(),
        mean_ratio: Vec::new(),
        mean_residual: 0.0,
        mean_residual_two_layers: 0.0,
        hidden_pixels: 0,
        mean_s0: 0.0,
        validation_messages: 0,
        memory_estimate: 0,
        memory_allocated: 0,
        allocated_while_recording: 0,
        passes: Vec::new(),
        frame_ms: 0.0,
        renderer_refusal: None,
    };
    // One layer, then with the second layer of hidden surfaces.
    let runs = [1, 2].into_iter().flat_map(|layers| {
        [Integration::Brute, Integration::Hierarchical].map(|integration| (layers, integration))
    });
    for (layers, integration) in runs {
        let settings = SsbcSettings {
            steps: 1,
            integration,
            ..Default::default()
        };
        // The host budgets and prepares before it records.
        let shape = PostProcessShape::new((w, h), &settings, (layers == 2).then_some(layer1));
        let before = device.memory_in_use();
        post.prepare(shape)?;
        if layers == 1 && integration == Integration::Brute {
            report.memory_estimate = SsbcPostProcess::memory_on(&device, &shape, 1).per_slot;
            report.memory_allocated = device.memory_in_use() - before;
        }
        let before_recording = device.memory_in_use();
        // The last run asks for its layouts back: the output then ends in
        // GENERAL, as declared, instead of TRANSFER_DST_OPTIMAL.
        let restore = layers == 2 && integration == Integration::Hierarchical;
        post.set_restore_layouts(restore);
        let output_exit = if restore {
            vk::ImageLayout::GENERAL
        } else {
            vk::ImageLayout::TRANSFER_DST_OPTIMAL
        };
        let groups = (w.div_ceil(8), h.div_ceil(8));
        let groups1 = (w1.div_ceil(8), h1.div_ceil(8));
        let all = [&position, &normal, &albedo, &s0, &output];
        let everything: Vec<&Image> = all.iter().copied().chain(&hidden).collect();
        // SAFETY (recording): the host's command buffer, pipelines and sets
        // are live; the previous submission's fence was waited on.
        unsafe {
            raw.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
            raw.begin_command_buffer(
                cmd,
                &vk::CommandBufferBeginInfo::default()
                    .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT),
            )?;
        }
        let to_general: Vec<_> = everything
            .iter()
            .map(|&i| (i, vk::ImageLayout::UNDEFINED, vk::ImageLayout::GENERAL))
            .collect();
        host_barrier(
            &device,
            cmd,
            &to_general,
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        );
        // Both layers' G-buffers, then both layers' lighting.
        let camera = bytemuck::cast_slice(&camera_push);
        let camera1 = bytemuck::cast_slice(&layer1_push);
        gbuffer_kernel.dispatch(cmd, sets[0], camera, groups);
        gbuffer_kernel.dispatch(cmd, sets[2], camera1, groups1);
        let gbuffer_done: Vec<_> = [&all[..3], &[&hidden[0], &hidden[1], &hidden[2]][..]]
            .concat()
            .into_iter()
            .map(|i| (i, vk::ImageLayout::GENERAL, vk::ImageLayout::GENERAL))
            .collect();
        host_barrier(
            &device,
            cmd,
            &gbuffer_done,
            vk::PipelineStageFlags2::COMPUTE_SHADER,
            vk::AccessFlags2::SHADER_STORAGE_READ,
        );
        lighting_kernel.dispatch(cmd, sets[1], &light_push, groups);
        lighting_kernel.dispatch(cmd, sets[3], &light_push, groups1);

        // --- SSBC, recorded into the host's command buffer. ---
        post.record(
            cmd,
            0,
            &PostProcessInputs {
                geometry: HostGeometry::Position(host_image(&position)),
                normal: host_image(&normal),
                normal_encoding: NormalEncoding::Signed,
                albedo: host_image(&albedo),
                s0: host_image(&s0),
                sources: None,
                receivers: ReceiverBrdf::Lambertian,
                output: host_image(&output),
                write: OutputWrite::Copy,
                camera: HostCamera::LookAt {
                    position: eye,
                    forward,
                    up,
                    yfov,
                },
                bound,
                typical_depth: 2.0,
                hidden: (layers == 2).then(|| PostProcessLayer {
                    position: host_image(&hidden[0]),
                    normal: host_image(&hidden[1]),
                    albedo: host_image(&hidden[2]),
                    s0: host_image(&hidden[3]),
                }),
            },
            &settings,
            PostOutput::Residual(1),
        )?;
        report.allocated_while_recording += device.memory_in_use() as i64 - before_recording as i64;

        // --- The host reads everything back with its own commands. ---
        let src = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
        let mut layouts: Vec<_> = all[..4]
            .iter()
            .copied()
            .chain(&hidden)
            .map(|i| (i, vk::ImageLayout::GENERAL, src))
            .collect();
        layouts.push((&output, output_exit, src));
        let copy = vk::PipelineStageFlags2::COPY;
        host_barrier(
            &device,
            cmd,
            &layouts,
            copy,
            vk::AccessFlags2::TRANSFER_READ,
        );
        let order: Vec<&Image> = all.iter().copied().chain(&hidden).collect();
        for (image, buffer) in order.iter().zip(&readback) {
            host::copy_image_to_buffer(&device, cmd, image, buffer);
        }
        let host_read = (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ);
        let copied = (
            vk::PipelineStageFlags2::COPY,
            vk::AccessFlags2::TRANSFER_WRITE,
        );
        host::memory_barrier(&device, cmd, copied, host_read);
        host::submit_and_wait(&device, cmd, fence)?;
        // The frame is done (the fence): its GPU times, without waiting.
        if let Some(times) = post.timings(0)? {
            report.passes = times
                .passes
                .iter()
                .map(|p| (p.name.clone(), p.gpu_ms))
                .collect();
            report.frame_ms = times.frame_ms;
        }
        let read: Vec<Vec<f32>> = readback.iter().map(|b| b.read::<f32>()).collect();
        let g = GBufferView {
            width: w,
            height: h,
            position: &read[0],
            normal: &read[1],
            albedo: &read[2],
        };
        let twin_camera = TwinCamera {
            position: eye,
            forward,
            up,
            pixel_side: 2.0 * tan / h as f32,
            min_cos_view: settings.min_cos_view,
            principal: glam::Vec2::ZERO,
        };
        let g1 = GBufferView {
            width: w1,
            height: h1,
            position: &read[5],
            normal: &read[6],
            albedo: &read[7],
        };
        let mut twin = BruteForceTwin::new(&g, &read[3], twin_camera, bound);
        if layers == 2 {
            twin = twin.with_second_layer(&g1, &read[8], twin_camera, layer1);
        }
        let twin = twin.image();
        let (rmse, ratio) = host::compare(&read[4], &twin);
        report.relative_rmse.push((layers, integration, rmse));
        report.mean_ratio.push((layers, integration, ratio));
        let sum_twin: f64 = twin
            .chunks_exact(4)
            .map(|p| (p[0] + p[1] + p[2]) as f64)
            .sum();
        let pixels = w as f64 * h as f64;
        if layers == 1 {
            report.mean_residual = sum_twin / (pixels * 3.0);
        } else {
            report.mean_residual_two_layers = sum_twin / (pixels * 3.0);
        }
        report.hidden_pixels = read[5].chunks_exact(4).filter(|p| p[3] != 0.0).count();
        report.mean_s0 = read[3]
            .chunks_exact(4)
            .map(|p| (p[0] + p[1] + p[2]) as f64)
            .sum::<f64>()
            / (pixels * 3.0);
    }
    // The host waited on its fence; now it tears down its own objects.
    drop(post);
    // SAFETY: no work is pending (the fence was waited on).
    unsafe {
        raw.destroy_fence(fence, None);
        raw.destroy_command_pool(command_pool, None);
        raw.destroy_descriptor_pool(descriptor_pool, None);
    }
    drop((gbuffer_kernel, lighting_kernel));
    drop((position, normal, albedo, s0, output, hidden, vpls, readback));
    drop(memory);
    // The renderer needs more than this device has: refused by name.
    report.renderer_refusal = ssbc::Renderer::with_device(device.clone())
        .err()
        .map(|e| e.to_string());
    drop(device);
    // SAFETY: ssbc's objects on it are gone (its Device dropped last); the
    // instance outlives it.
    unsafe { host_raw.destroy_device(None) };
    drop(instance);
    report.validation_messages = log.total();
    Ok(report)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `--half`: the second layer at half resolution.
    let layer1 = if std::env::args().any(|a| a == "--half") {
        LayerResolution::Half
    } else {
        LayerResolution::Full
    };
    let report = run(160, 120, layer1)?;
    println!("second layer at {layer1:?} resolution");
    for ((layers, integration, rmse), (.., ratio)) in
        report.relative_rmse.iter().zip(&report.mean_ratio)
    {
        println!(
            "{layers} layer(s), {integration:?}: residual vs CPU twin: relative RMSE {:.2e}, mean ratio {ratio:.5}",
            rmse
        );
    }
    println!(
        "mean S0 {:.4}, mean residual {:.4} ({:.1}% of S0), {:.4} with the second layer ({} hidden pixels); {} validation messages",
        report.mean_s0,
        report.mean_residual,
        100.0 * report.mean_residual / report.mean_s0,
        report.mean_residual_two_layers,
        report.hidden_pixels,
        report.validation_messages
    );
    Ok(())
}
