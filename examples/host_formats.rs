//! SSBC as a post-process on a G-buffer in the formats engines keep.
//!
//! The host of `examples/postprocess.rs` (raw `ash`, its own kernels and
//! allocator, a device with only `RequiredFeatures::POST_PROCESS`) draws
//! its room corner with a TAA-jittered camera that it gives ssbc as view
//! and projection matrices (Vulkan clip space, reversed infinite Z), and
//! keeps its G-buffer as an engine would: hardware depth in `D32_SFLOAT`,
//! normals in `A2B10G10R10_UNORM_PACK32`, albedo in `R8G8B8A8_SRGB`, its
//! clamped lighting in `R16G16B16A16_SFLOAT` (its own kernel packs them;
//! copies put them into the images). ssbc converts them and writes its
//! result with a compute shader: first the residual, stored into an RGBA32F
//! image; then the compensation, added onto the host's RGBA16F lighting
//! image itself. Both are checked against the CPU twin of SSBC on the
//! unpacked G-buffer, whose camera has the same jitter.
//!
//! `cargo run --release --example host_formats`

#[path = "common/host.rs"]
mod host;

use ash::vk;
use glam::{Mat4, Vec2, Vec3};
use gpu_allocator::MemoryLocation;
use host::{
    array, compare, compile, decode, half, host_barrier, host_device, Buffer, Error, HostKernel,
    HostMemory, Image, GBUFFER_GLSL, LIGHTING_GLSL, PACKED_BYTES, PACKED_FORMATS, PACK_GLSL,
};
use ssbc::postprocess::{
    HostCamera, HostGeometry, NormalEncoding, OutputWrite, PostOutput, PostProcessInputs,
    PostProcessShape, ReceiverBrdf, SsbcPostProcess,
};
use ssbc::reference::{BruteForceTwin, GBufferView, TwinCamera};
use ssbc::settings::{Integration, SsbcSettings};
use ssbc::vk::{Instance, Validation};

/// What the example measured.
#[derive(Debug)]
pub struct HostFormatsReport {
    /// The residual stored into an RGBA32F image (brute-force
    /// integration) against the twin on the host's G-buffer as stored
    /// (decoded on the CPU): relative RMSE and mean ratio.
    pub stored: (f64, f64),
    /// The same GPU residual against the twin on the host's G-buffer before
    /// packing (world positions, f32 normals, albedo and lighting): what
    /// 10-bit normals, 8-bit albedo and half lighting change (relative
    /// RMSE, mean ratio).
    pub stored_against_unpacked: (f64, f64),
    /// The same GPU residual against a twin whose camera has no jitter:
    /// how much the jitter matters (relative RMSE).
    pub stored_against_unjittered: f64,
    /// The compensation added onto the RGBA16F lighting image
    /// (hierarchical integration), less the host's lighting, against that
    /// twin's residual: relative RMSE and mean ratio.
    pub added: (f64, f64),
    /// Relative RMSE between twins on the unpacked G-buffer and with one
    /// input packed (normals, albedo, lighting).
    pub packing_cost: Vec<(&'static str, f64)>,
    /// Mean residual over mean S0.
    pub residual_share: f64,
    /// `SsbcPostProcess::memory_on` for the converting shape, before
    /// anything existed, and what `prepare` then allocated.
    pub memory_estimate: u64,
    pub memory_allocated: u64,
    /// The last frame's passes and GPU ms.
    pub passes: Vec<(String, f64)>,
    /// Validation messages.
    pub validation_messages: u32,
}

/// The host's images and buffers.
struct Resources {
    /// The host's RGBA32F working G-buffer and lighting (the twin reads
    /// them back), and an RGBA32F output.
    position: Image,
    normal: Image,
    albedo: Image,
    s0: Image,
    output: Image,
    /// What the host keeps: depth, normal, albedo, lighting.
    packed: [Image; 4],
    /// The packing kernel's output, copied into `packed`.
    staging: [Buffer; 4],
    vpls: Buffer,
    /// position, normal, albedo, s0, output (RGBA32F), lighting after SSBC
    /// (RGBA16F), and the packed normal, albedo and lighting as ssbc read
    /// them.
    readback: [Buffer; 9],
}

impl Resources {
    fn new(memory: &std::sync::Arc<HostMemory>, (w, h): (u32, u32)) -> Result<Self, Error> {
        let image = |name: &str| memory.image(name, w, h);
        let sampled = vk::ImageUsageFlags::SAMPLED
            | vk::ImageUsageFlags::TRANSFER_DST
            | vk::ImageUsageFlags::TRANSFER_SRC;
        let lighting_usage = sampled | vk::ImageUsageFlags::STORAGE;
        let names = ["depth", "normal10", "albedo_srgb", "lighting16"];
        let packed: Vec<Image> = (0..4)
            .map(|i| {
                let usage = if i == 3 { lighting_usage } else { sampled };
                memory.image_of(
                    &format!("host.{}", names[i]),
                    (w, h),
                    PACKED_FORMATS[i],
                    usage,
                )
            })
            .collect::<Result<_, _>>()?;
        let texels = w as u64 * h as u64;
        let staging: Vec<Buffer> = (0..4)
            .map(|i| {
                memory.buffer(
                    &format!("host.staging.{}", names[i]),
                    texels * PACKED_BYTES[i],
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<_, _>>()?;
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
                memory.buffer(
                    &format!("host.readback{i}"),
                    texels * [16, 16, 16, 16, 16, 8, 4, 4, 8][i],
                    vk::BufferUsageFlags::TRANSFER_DST,
                    MemoryLocation::GpuToCpu,
                )
            })
            .collect::<Result<_, _>>()?;
        Ok(Self {
            position: image("host.position")?,
            normal: image("host.normal")?,
            albedo: image("host.albedo")?,
            s0: image("host.s0")?,
            output: image("host.output")?,
            packed: array(packed),
            staging: array(staging),
            vpls,
            readback: array(readback),
        })
    }
}

/// The host's three kernels and their sets.
struct Kernels {
    gbuffer: HostKernel,
    lighting: HostKernel,
    pack: HostKernel,
    pool: vk::DescriptorPool,
    /// gbuffer, lighting, pack.
    sets: Vec<vk::DescriptorSet>,
}

impl Kernels {
    fn new(device: &std::sync::Arc<ssbc::vk::Device>, r: &Resources) -> Result<Self, Error> {
        let storage = vk::DescriptorType::STORAGE_IMAGE;
        let buffer = vk::DescriptorType::STORAGE_BUFFER;
        let gbuffer = HostKernel::new(
            device,
            &compile(GBUFFER_GLSL, "gbuffer.comp")?,
            &[storage; 3],
            64,
        )?;
        let lighting = HostKernel::new(
            device,
            &compile(LIGHTING_GLSL, "lighting.comp")?,
            &[storage, storage, storage, storage, buffer],
            8,
        )?;
        let pack = HostKernel::new(
            device,
            &compile(PACK_GLSL, "pack.comp")?,
            &[
                storage, storage, storage, storage, buffer, buffer, buffer, buffer,
            ],
            64,
        )?;
        let raw = &device.raw;
        let sizes = [
            vk::DescriptorPoolSize {
                ty: storage,
                descriptor_count: 11,
            },
            vk::DescriptorPoolSize {
                ty: buffer,
                descriptor_count: 5,
            },
        ];
        // SAFETY: valid create info on a live device; destroyed in Drop.
        let pool = unsafe {
            raw.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(3)
                    .pool_sizes(&sizes),
                None,
            )?
        };
        let layouts = [gbuffer.set_layout, lighting.set_layout, pack.set_layout];
        // SAFETY: the pool was sized for these three sets.
        let sets = unsafe {
            raw.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(pool)
                    .set_layouts(&layouts),
            )?
        };
        let images = [&r.position, &r.normal, &r.albedo, &r.s0].map(|i| {
            [vk::DescriptorImageInfo::default()
                .image_view(i.view)
                .image_layout(vk::ImageLayout::GENERAL)]
        });
        let buffers: Vec<_> = std::iter::once(&r.vpls)
            .chain(&r.staging)
            .map(|b| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let mut writes = Vec::new();
        let image_write = |set, binding: u32, info| {
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(binding)
                .descriptor_type(storage)
                .image_info(info)
        };
        let buffer_write = |set, binding: u32, info| {
            vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(binding)
                .descriptor_type(buffer)
                .buffer_info(info)
        };
        for (i, info) in images.iter().enumerate() {
            if i < 3 {
                writes.push(image_write(sets[0], i as u32, info));
            }
            writes.push(image_write(sets[1], i as u32, info));
            writes.push(image_write(sets[2], i as u32, info));
        }
        writes.push(buffer_write(sets[1], 4, &buffers[0]));
        for (i, info) in buffers[1..].iter().enumerate() {
            writes.push(buffer_write(sets[2], 4 + i as u32, info));
        }
        // SAFETY: every write points at live descriptors of matching types.
        unsafe { raw.update_descriptor_sets(&writes, &[]) };
        Ok(Self {
            gbuffer,
            lighting,
            pack,
            pool,
            sets,
        })
    }
}

/// What one run does with ssbc's result.
#[derive(Clone, Copy, PartialEq)]
enum Run {
    /// Brute force; the residual stored into the RGBA32F output.
    Store,
    /// Hierarchical; the compensation added onto the host's lighting
    /// image (its layouts handed back).
    Add,
}

/// Unit normals (RGBA) through the octahedral map stored in two SNORM16
/// channels, decoded as shaders/postprocess_convert.comp does.
fn octahedral_snorm16(normals: &[f32]) -> Vec<f32> {
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    normals
        .chunks_exact(4)
        .flat_map(|n| {
            let n = Vec3::new(n[0], n[1], n[2]);
            let n = n / (n.x.abs() + n.y.abs() + n.z.abs()).max(1e-30);
            let e = if n.z < 0.0 {
                Vec2::new((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
            } else {
                Vec2::new(n.x, n.y)
            };
            let e = (e * 32767.0).round() / 32767.0;
            let mut d = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
            let t = (-d.z).max(0.0);
            d.x += if d.x >= 0.0 { -t } else { t };
            d.y += if d.y >= 0.0 { -t } else { t };
            let d = d.normalize_or_zero();
            [d.x, d.y, d.z, 0.0]
        })
        .collect()
}

/// Runs the host frame at `w` x `h`, once per [`Run`].
pub fn run(w: u32, h: u32) -> Result<HostFormatsReport, Error> {
    let instance = Instance::with_validation(Validation::Synchronization, &[])?;
    let log = instance.validation_log();
    let (device, host_raw) = host_device(&instance)?;
    let raw = &device.raw;
    let memory = HostMemory::new(&device)?;
    let r = Resources::new(&memory, (w, h))?;
    let kernels = Kernels::new(&device, &r)?;
    // SAFETY: plain object creation; destroyed below after the fence.
    let (command_pool, fence) = unsafe {
        (
            host::command_pool(&device)?,
            raw.create_fence(&vk::FenceCreateInfo::default(), None)?,
        )
    };
    // SAFETY: one primary buffer from the host's pool.
    let cmd = unsafe {
        raw.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(command_pool)
                .command_buffer_count(1),
        )?
    }[0];

    // The camera, as matrices, with this frame's jitter (pixels).
    let eye = Vec3::new(0.9, 1.1, 1.6);
    let forward = (Vec3::new(-0.4, 0.5, -0.6) - eye).normalize();
    let yfov = 50f32.to_radians();
    let aspect = w as f32 / h as f32;
    let jitter = Vec2::new(0.37, -0.21);
    let view = glam::camera::rh::view::look_to_mat4(eye, forward, Vec3::Y);
    let projection =
        glam::camera::rh::proj::vulkan::perspective_infinite_reverse(yfov, aspect, 0.05);
    let jittered =
        Mat4::from_translation((2.0 * jitter / Vec2::new(w as f32, h as f32)).extend(0.0))
            * projection;
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let tan = (yfov * 0.5).tan();
    let gbuffer_push: Vec<f32> = [
        eye.extend(0.0),
        forward.extend(0.0),
        (right * tan * aspect).extend(jitter.x),
        (up * tan).extend(jitter.y),
    ]
    .iter()
    .flat_map(|v| v.to_array())
    .collect();
    let bound = 1.0f32;
    let mut light_push = 64u32.to_ne_bytes().to_vec();
    light_push.extend(bound.to_ne_bytes());
    let pack_push = (jittered * view).to_cols_array();

    let mut post = SsbcPostProcess::new(&device, 1)?;
    let mut report = HostFormatsReport {
        stored: (0.0, 0.0),
        stored_against_unpacked: (0.0, 0.0),
        stored_against_unjittered: 0.0,
        added: (0.0, 0.0),
        packing_cost: Vec::new(),
        residual_share: 0.0,
        memory_estimate: 0,
        memory_allocated: 0,
        passes: Vec::new(),
        validation_messages: 0,
    };
    let groups = (w.div_ceil(8), h.div_ceil(8));
    let general = vk::ImageLayout::GENERAL;
    let transfer_dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    let transfer_src = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
    // The twin on the decoded G-buffer and the lighting as ssbc read it.
    let mut decoded: Option<(Vec<f32>, Vec<f32>)> = None;
    for run in [Run::Store, Run::Add] {
        let settings = SsbcSettings {
            steps: 1,
            integration: match run {
                Run::Store => Integration::Brute,
                Run::Add => Integration::Hierarchical,
            },
            ..Default::default()
        };
        // What the host keeps, declared in the layout its copies left.
        let [depth, normal, albedo, lighting] = r
            .packed
            .each_ref()
            .map(|i| host::host_image(i, transfer_dst));
        let inputs = PostProcessInputs {
            geometry: HostGeometry::Depth {
                image: depth,
                background: 0.0,
            },
            normal,
            normal_encoding: NormalEncoding::Unsigned,
            albedo,
            s0: lighting,
            sources: None,
            receivers: ReceiverBrdf::Lambertian,
            output: match run {
                Run::Store => host::host_image(&r.output, general),
                Run::Add => lighting,
            },
            write: match run {
                Run::Store => OutputWrite::Store,
                Run::Add => OutputWrite::Add,
            },
            camera: HostCamera::Matrices {
                view,
                projection,
                jitter,
            },
            bound,
            typical_depth: 2.0,
            hidden: None,
        };
        let shape = PostProcessShape::for_inputs(&inputs, &settings)?;
        let before = device.memory_in_use();
        post.prepare(shape)?;
        if run == Run::Store {
            report.memory_estimate = SsbcPostProcess::memory_on(&device, &shape, 1).per_slot;
            report.memory_allocated = device.memory_in_use() - before;
        }
        post.set_restore_layouts(run == Run::Add);
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
        let working = [&r.position, &r.normal, &r.albedo, &r.s0, &r.output];
        let to_general: Vec<_> = working
            .iter()
            .map(|&i| (i, vk::ImageLayout::UNDEFINED, general))
            .collect();
        let compute = vk::PipelineStageFlags2::COMPUTE_SHADER;
        host_barrier(
            &device,
            cmd,
            &to_general,
            compute,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        );
        kernels.gbuffer.dispatch(
            cmd,
            kernels.sets[0],
            bytemuck::cast_slice(&gbuffer_push),
            groups,
        );
        let written: Vec<_> = working[..4]
            .iter()
            .map(|&i| (i, general, general))
            .collect();
        let read_write =
            vk::AccessFlags2::SHADER_STORAGE_READ | vk::AccessFlags2::SHADER_STORAGE_WRITE;
        host_barrier(&device, cmd, &written, compute, read_write);
        kernels
            .lighting
            .dispatch(cmd, kernels.sets[1], &light_push, groups);
        host_barrier(&device, cmd, &written, compute, read_write);
        kernels.pack.dispatch(
            cmd,
            kernels.sets[2],
            bytemuck::cast_slice(&pack_push),
            groups,
        );
        // The packed texels into the images the host keeps.
        let copy = vk::PipelineStageFlags2::COPY;
        host::copy_packed(&device, cmd, &r.staging, &r.packed);

        // --- SSBC, recorded into the host's command buffer. ---
        let output = match run {
            Run::Store => PostOutput::Residual(1),
            Run::Add => PostOutput::Compensated,
        };
        post.record(cmd, 0, &inputs, &settings, output)?;

        // --- The host reads back its working images and the result. ---
        let mut to_src: Vec<_> = working[..4]
            .iter()
            .map(|&i| (i, general, transfer_src))
            .collect();
        let result = match run {
            Run::Store => (&r.output, general, &r.readback[4]),
            // Handed back in the layout it was declared in.
            Run::Add => (&r.packed[3], transfer_dst, &r.readback[5]),
        };
        to_src.push((result.0, result.1, transfer_src));
        // What ssbc sampled, left in SHADER_READ_ONLY_OPTIMAL (no layouts
        // handed back in this run).
        let sampled = vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL;
        let packed_read: Vec<_> = match run {
            Run::Store => r.packed[1..].iter().zip(&r.readback[6..]).collect(),
            Run::Add => Vec::new(),
        };
        to_src.extend(packed_read.iter().map(|(i, _)| (*i, sampled, transfer_src)));
        host_barrier(&device, cmd, &to_src, copy, vk::AccessFlags2::TRANSFER_READ);
        let sources = working[..4]
            .iter()
            .copied()
            .zip(&r.readback[..4])
            .chain([(result.0, result.2)])
            .chain(packed_read.iter().copied());
        for (image, buffer) in sources {
            host::copy_image_to_buffer(&device, cmd, image, buffer);
        }
        let host_read = (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ);
        host::memory_barrier(
            &device,
            cmd,
            (copy, vk::AccessFlags2::TRANSFER_WRITE),
            host_read,
        );
        host::submit_and_wait(&device, cmd, fence)?;
        report.passes = host::pass_times(post.timings(0)?);

        // --- The CPU twin on the unpacked G-buffer, with the jitter. ---
        let read: Vec<Vec<f32>> = r.readback[..5].iter().map(|b| b.read::<f32>()).collect();
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
            principal: jitter,
        };
        match run {
            Run::Store => {
                // The twin on what the host stored, decoded as the sampler
                // and shaders/postprocess_convert.comp decode it.
                let (normal, albedo, lighting) = decode(&r.readback[6..]);
                let stored = GBufferView {
                    normal: &normal,
                    albedo: &albedo,
                    ..g
                };
                let twin = BruteForceTwin::new(&stored, &lighting, twin_camera, bound).image();
                report.stored = compare(&read[4], &twin);
                let unjittered = TwinCamera {
                    principal: Vec2::ZERO,
                    ..twin_camera
                };
                let plain = BruteForceTwin::new(&stored, &lighting, unjittered, bound).image();
                report.stored_against_unjittered = compare(&read[4], &plain).0;
                // What packing changed: the twin on the unpacked G-buffer,
                // and with one input packed at a time.
                let unpacked = BruteForceTwin::new(&g, &read[3], twin_camera, bound).image();
                report.stored_against_unpacked = compare(&read[4], &unpacked);
                // The alternative an engine may keep: octahedral normals in
                // two SNORM16 channels (the same 4 bytes).
                let octahedral = octahedral_snorm16(&read[1]);
                let one_packed = [
                    (
                        "normals",
                        GBufferView {
                            normal: &normal,
                            ..g
                        },
                        &read[3],
                    ),
                    (
                        "normals as octahedral SNORM16",
                        GBufferView {
                            normal: &octahedral,
                            ..g
                        },
                        &read[3],
                    ),
                    (
                        "albedo",
                        GBufferView {
                            albedo: &albedo,
                            ..g
                        },
                        &read[3],
                    ),
                    ("lighting", GBufferView { ..g }, &lighting),
                ];
                for (name, view, s0) in one_packed {
                    let image = BruteForceTwin::new(&view, s0, twin_camera, bound).image();
                    report
                        .packing_cost
                        .push((name, compare(&image, &unpacked).0));
                }
                let mean = |v: &[f32]| {
                    v.chunks_exact(4)
                        .map(|p| (p[0] + p[1] + p[2]) as f64)
                        .sum::<f64>()
                };
                report.residual_share = mean(&twin) / mean(&lighting);
                decoded = Some((twin, lighting));
            }
            Run::Add => {
                // The host's lighting plus the compensation, in halves, less
                // the host's lighting as ssbc read it.
                let (twin, lighting) = decoded.as_ref().expect("the store run came first");
                let halves = r.readback[5].read::<u16>();
                let added: Vec<f32> = halves
                    .iter()
                    .zip(lighting)
                    .map(|(&h, &s0)| half(h) - s0)
                    .collect();
                report.added = compare(&added, twin);
            }
        }
    }
    drop(post);
    // SAFETY: no work is pending (the fence was waited on).
    unsafe {
        raw.destroy_fence(fence, None);
        raw.destroy_command_pool(command_pool, None);
        raw.destroy_descriptor_pool(kernels.pool, None);
    }
    drop(kernels);
    drop(r);
    drop(memory);
    drop(device);
    // SAFETY: ssbc's objects on it are gone; the instance outlives it.
    unsafe { host_raw.destroy_device(None) };
    drop(instance);
    report.validation_messages = log.total();
    Ok(report)
}

#[allow(dead_code)] // the test includes this file for `run`
fn main() -> Result<(), Error> {
    let report = run(160, 120)?;
    println!(
        "residual stored (RGBA32F, brute force) vs CPU twin: relative RMSE {:.2e}, mean ratio {:.5} ({:.2e} against a twin without the jitter)",
        report.stored.0, report.stored.1, report.stored_against_unjittered
    );
    println!(
        "against a twin on the unpacked G-buffer: relative RMSE {:.2e}, mean ratio {:.5}; packing one input changes the twin by {}",
        report.stored_against_unpacked.0,
        report.stored_against_unpacked.1,
        report
            .packing_cost
            .iter()
            .map(|(name, rmse)| format!("{rmse:.2e} ({name})"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "compensation added onto RGBA16F lighting (hierarchical) vs twin: relative RMSE {:.2e}, mean ratio {:.5}",
        report.added.0, report.added.1
    );
    println!(
        "residual {:.1}% of S0; memory: estimated {} bytes, allocated {}; {} validation messages",
        100.0 * report.residual_share,
        report.memory_estimate,
        report.memory_allocated,
        report.validation_messages
    );
    for (name, ms) in &report.passes {
        println!("{name:40} {ms:9.3} ms");
    }
    Ok(())
}
