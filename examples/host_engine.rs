//! ssbc inside a host engine's frame loop, end to end.
//!
//! The host (raw `ash`, its own instance, device, allocator, kernels and
//! command buffers) runs two frames in flight. Each frame, with a TAA
//! jitter that changes every frame:
//! - ssbc's resident renderer records the clamped lighting `S0` of the
//!   host's scene (direct light and bounded VPL light, no SSBC step) into
//!   the host's command buffer and RGBA32F lighting image
//!   (`Renderer::record_resident`, the camera's `jitter`);
//! - the host draws its own G-buffer of the same scene with the same
//!   jittered camera, and keeps it as an engine does: `D32_SFLOAT` depth
//!   (reversed infinite Z), `A2B10G10R10_UNORM` normals, `R8G8B8A8_SRGB`
//!   albedo;
//! - `SsbcPostProcess` adds SSBC's compensation onto the lighting image,
//!   given the camera as view and projection matrices with the jitter.
//!
//! After each slot's fence it reads back both parts' per-pass GPU timings
//! and its image, and checks the last frame against ssbc's own `render` of
//! the same scene and jitter (one VPL set: history is off, so each frame
//! stands alone). `cargo run --release --example host_engine`; the test
//! suite runs it (tests/host_engine.rs).

#[path = "common/host.rs"]
mod host;

use std::sync::Arc;

use ash::vk;
use glam::{Mat4, Vec2, Vec3};
use gpu_allocator::MemoryLocation;
use host::{
    array, compile, copy_image_to_buffer, host_barrier, host_device_with, memory_barrier, Buffer,
    Error, HostKernel, HostMemory, Image, GBUFFER_GLSL, PACKED_BYTES, PACKED_FORMATS, PACK_GLSL,
};
use ssbc::postprocess::{
    HostCamera, HostGeometry, NormalEncoding, OutputWrite, PostOutput, PostProcessInputs,
    PostProcessShape, ReceiverBrdf, SsbcPostProcess,
};
use ssbc::resident::ResidentScene;
use ssbc::scene::{Camera, Light, LightKind, Scene};
use ssbc::settings::Bound;
use ssbc::vk::RequiredFeatures;
use ssbc::{Layer, RenderSettings, Renderer};

/// Frames in flight.
const SLOTS: usize = 2;

/// What the example measured.
#[derive(Debug)]
pub struct HostEngineReport {
    /// Frames recorded.
    pub frames: usize,
    /// The last frame's image against ssbc's own render: mean ratio, and
    /// relMSE of 4x4 block means.
    pub mean_ratio: f64,
    pub block_rel_mse: f64,
    /// Mean of the compensation over the mean of S0 (the part SSBC adds).
    pub compensation_share: f64,
    /// The compensation alone (the image less ssbc's S0) against ssbc's
    /// own: relative RMSE and mean ratio.
    pub compensation: (f64, f64),
    /// The last frame's per-pass GPU ms, timed in the host's command
    /// buffer: ssbc's resident frame, the post-process.
    pub resident_passes: Vec<(String, f64)>,
    pub post_passes: Vec<(String, f64)>,
    /// Validation messages.
    pub validation_messages: u32,
}

/// The host's scene as ssbc's data: the room corner with a box of
/// GBUFFER_GLSL (same planes, same albedos, front faces inwards), a point
/// light, and the camera.
fn corner_scene(camera: Camera) -> Result<Scene, Error> {
    let mut scene = Scene::new("host corner");
    let mut quad = |corner: Vec3, u: Vec3, v: Vec3, albedo: Vec3| {
        let material = scene.add_material(albedo, None);
        let positions = [corner, corner + u, corner + u + v, corner + v];
        scene.add_mesh(
            &positions,
            &[],
            &[],
            &[0, 1, 2, 0, 2, 3],
            Mat4::IDENTITY,
            material,
        )
    };
    let corner = Vec3::new(-1.0, 0.0, -1.0);
    quad(corner, 2.0 * Vec3::Z, 2.0 * Vec3::X, Vec3::splat(0.7))?; // floor
    quad(
        corner,
        2.0 * Vec3::X,
        2.0 * Vec3::Y,
        Vec3::new(0.8, 0.6, 0.4),
    )?; // back wall
    quad(
        corner,
        2.0 * Vec3::Y,
        2.0 * Vec3::Z,
        Vec3::new(0.3, 0.6, 0.8),
    )?; // left wall
    let (lo, hi) = (Vec3::new(-0.7, 0.0, -0.6), Vec3::new(-0.3, 0.5, -0.2));
    let d = hi - lo;
    let (x, y, z) = (d.x * Vec3::X, d.y * Vec3::Y, d.z * Vec3::Z);
    let grey = Vec3::splat(0.6);
    quad(Vec3::new(hi.x, lo.y, lo.z), y, z, grey)?; // +x
    quad(lo, z, y, grey)?; // -x
    quad(Vec3::new(lo.x, lo.y, hi.z), x, y, grey)?; // +z
    quad(lo, y, x, grey)?; // -z
    quad(Vec3::new(lo.x, hi.y, lo.z), z, x, grey)?; // top
    scene.lights.push(Light {
        kind: LightKind::Point,
        position: Vec3::new(0.3, 1.4, 0.2),
        direction: -Vec3::Y,
        intensity: Vec3::splat(2.0),
    });
    scene.cameras.push(camera);
    Ok(scene)
}

/// One frame slot's host resources.
struct Slot {
    /// The working G-buffer (position, normal, albedo), RGBA32F.
    working: [Image; 3],
    /// What the host keeps: depth, normal, albedo.
    packed: [Image; 3],
    /// The packing kernel's output (depth, normal, albedo, and an unused
    /// lighting), copied into `packed`.
    staging: [Buffer; 4],
    /// The lighting: ssbc's S0, then S0 plus the compensation.
    lighting: Image,
    readback: Buffer,
    /// G-buffer and pack sets.
    sets: [vk::DescriptorSet; 2],
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    /// A frame was submitted with `fence`.
    in_flight: bool,
    /// That frame's jitter.
    jitter: Vec2,
}

impl Slot {
    fn new(memory: &Arc<HostMemory>, (w, h): (u32, u32), slot: usize) -> Result<Self, Error> {
        let name = |what: &str| format!("host.slot{slot}.{what}");
        let usage = vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST;
        let packed: Vec<Image> = (0..3)
            .map(|i| {
                memory.image_of(
                    &name(&format!("packed{i}")),
                    (w, h),
                    PACKED_FORMATS[i],
                    usage,
                )
            })
            .collect::<Result<_, _>>()?;
        let staging: Vec<Buffer> = (0..4)
            .map(|i| {
                memory.buffer(
                    &name(&format!("staging{i}")),
                    w as u64 * h as u64 * PACKED_BYTES[i],
                    vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                    MemoryLocation::GpuOnly,
                )
            })
            .collect::<Result<_, _>>()?;
        let lighting = memory.image_of(
            &name("lighting"),
            (w, h),
            vk::Format::R32G32B32A32_SFLOAT,
            vk::ImageUsageFlags::SAMPLED
                | vk::ImageUsageFlags::STORAGE
                | vk::ImageUsageFlags::TRANSFER_DST
                | vk::ImageUsageFlags::TRANSFER_SRC,
        )?;
        Ok(Self {
            working: [
                memory.image(&name("position"), w, h)?,
                memory.image(&name("normal"), w, h)?,
                memory.image(&name("albedo"), w, h)?,
            ],
            packed: array(packed),
            staging: array(staging),
            lighting,
            readback: memory.buffer(
                &name("readback"),
                w as u64 * h as u64 * 16,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
            sets: [vk::DescriptorSet::null(); 2],
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            in_flight: false,
            jitter: Vec2::ZERO,
        })
    }

    /// Points the G-buffer and pack sets at this slot's images and buffers.
    fn write_sets(&self, device: &ssbc::vk::Device) {
        let storage = vk::DescriptorType::STORAGE_IMAGE;
        // The pack kernel's s0 is the lighting image (its packed copy unused).
        let images: Vec<_> = [
            &self.working[0],
            &self.working[1],
            &self.working[2],
            &self.lighting,
        ]
        .iter()
        .map(|i| {
            [vk::DescriptorImageInfo::default()
                .image_view(i.view)
                .image_layout(vk::ImageLayout::GENERAL)]
        })
        .collect();
        let buffers: Vec<_> = self
            .staging
            .iter()
            .map(|b| {
                [vk::DescriptorBufferInfo::default()
                    .buffer(b.raw)
                    .range(vk::WHOLE_SIZE)]
            })
            .collect();
        let mut writes = Vec::new();
        for (i, info) in images.iter().enumerate() {
            for (set, count) in [(self.sets[0], 3), (self.sets[1], 4)] {
                if i < count {
                    writes.push(
                        vk::WriteDescriptorSet::default()
                            .dst_set(set)
                            .dst_binding(i as u32)
                            .descriptor_type(storage)
                            .image_info(info),
                    );
                }
            }
        }
        for (i, info) in buffers.iter().enumerate() {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(self.sets[1])
                    .dst_binding(4 + i as u32)
                    .descriptor_type(vk::DescriptorType::STORAGE_BUFFER)
                    .buffer_info(info),
            );
        }
        // SAFETY: every write points at live descriptors of matching types.
        unsafe { device.raw.update_descriptor_sets(&writes, &[]) };
    }
}

/// The r-th point of the base-b Halton sequence, centred on 0 (TAA jitter).
fn halton(mut index: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0, 0.0);
    while index > 0 {
        f /= base as f32;
        r += f * (index % base) as f32;
        index /= base;
    }
    r - 0.5
}

/// Runs `frames` frames at `w` x `h` with two in flight.
pub fn run(w: u32, h: u32, frames: usize) -> Result<HostEngineReport, Error> {
    // The host's own instance (validation and synchronization validation),
    // and its device with what the resident renderer needs merged in.
    let own = host::OwnInstance::new(true)?;
    let instance = own.for_ssbc();
    let before = host::OwnInstance::messages();
    let (device, host_raw) = host_device_with(&instance, RequiredFeatures::ALL)?;
    let raw = &device.raw;
    let memory = HostMemory::new(&device)?;
    let storage = vk::DescriptorType::STORAGE_IMAGE;
    let buffer = vk::DescriptorType::STORAGE_BUFFER;
    let gbuffer_kernel = HostKernel::new(
        &device,
        &compile(GBUFFER_GLSL, "gbuffer.comp")?,
        &[storage; 3],
        64,
    )?;
    let pack_kernel = HostKernel::new(
        &device,
        &compile(PACK_GLSL, "pack.comp")?,
        &[
            storage, storage, storage, storage, buffer, buffer, buffer, buffer,
        ],
        64,
    )?;
    let mut slots: Vec<Slot> = (0..SLOTS)
        .map(|i| Slot::new(&memory, (w, h), i))
        .collect::<Result<_, _>>()?;
    // SAFETY: plain object creation on a live device; destroyed below after
    // every fence has signalled.
    let (descriptor_pool, command_pool) = unsafe {
        let sizes = [
            vk::DescriptorPoolSize {
                ty: storage,
                descriptor_count: 7 * SLOTS as u32,
            },
            vk::DescriptorPoolSize {
                ty: buffer,
                descriptor_count: 4 * SLOTS as u32,
            },
        ];
        (
            raw.create_descriptor_pool(
                &vk::DescriptorPoolCreateInfo::default()
                    .max_sets(2 * SLOTS as u32)
                    .pool_sizes(&sizes),
                None,
            )?,
            host::command_pool(&device)?,
        )
    };
    for slot in &mut slots {
        let layouts = [gbuffer_kernel.set_layout, pack_kernel.set_layout];
        // SAFETY: the pool holds two sets per slot; one buffer and fence each.
        unsafe {
            let sets = raw.allocate_descriptor_sets(
                &vk::DescriptorSetAllocateInfo::default()
                    .descriptor_pool(descriptor_pool)
                    .set_layouts(&layouts),
            )?;
            slot.sets = [sets[0], sets[1]];
            slot.cmd = raw.allocate_command_buffers(
                &vk::CommandBufferAllocateInfo::default()
                    .command_pool(command_pool)
                    .command_buffer_count(1),
            )?[0];
            slot.fence = raw.create_fence(&vk::FenceCreateInfo::default(), None)?;
        }
        slot.write_sets(&device);
    }

    // The camera: the host's view, ssbc's Camera and matrices of it.
    let eye = Vec3::new(0.9, 1.1, 1.6);
    let forward = (Vec3::new(-0.4, 0.5, -0.6) - eye).normalize();
    let yfov = 50f32.to_radians();
    let base_camera = Camera::look_at(eye, eye + forward, yfov);
    let (right, up) = (forward.cross(base_camera.up).normalize(), base_camera.up);
    let tan = (yfov * 0.5).tan();
    let aspect = w as f32 / h as f32;
    let view = glam::camera::rh::view::look_to_mat4(eye, forward, up);
    let projection =
        glam::camera::rh::proj::vulkan::perspective_infinite_reverse(yfov, aspect, 0.05);

    let scene = corner_scene(base_camera.clone())?;
    let mut resident = ResidentScene::new(scene.clone())?;
    let mut settings = RenderSettings::new(w, h);
    settings.vpl.count = 256;
    settings.bound = Bound::Value(0.5);
    settings.history.enabled = false; // each frame stands alone (compared below)
    let mut lighting_settings = settings.clone();
    lighting_settings.ssbc.steps = 0; // S0: SSBC comes from the post-process
    let typical_depth = (scene.bounds().center() - eye).dot(forward);

    let mut renderer = Renderer::with_device(device.clone())?;
    let mut post = SsbcPostProcess::new(&device, SLOTS)?;
    let mut report = HostEngineReport {
        frames,
        mean_ratio: 0.0,
        block_rel_mse: 0.0,
        compensation_share: 0.0,
        compensation: (0.0, 0.0),
        resident_passes: Vec::new(),
        post_passes: Vec::new(),
        validation_messages: 0,
    };
    let general = vk::ImageLayout::GENERAL;
    let transfer_dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    let compute = vk::PipelineStageFlags2::COMPUTE_SHADER;
    let copy = vk::PipelineStageFlags2::COPY;
    // The last frame read back: its image and jitter.
    let mut last = (Vec::new(), Vec2::ZERO);
    let mut prepared = false;
    for frame in 0..frames + SLOTS {
        let s = frame % SLOTS;
        // The slot's previous frame: wait for it, then read its timings and
        // image without stalling anything else.
        if slots[s].in_flight {
            // SAFETY: waiting on the host's own fence.
            unsafe {
                raw.wait_for_fences(&[slots[s].fence], true, u64::MAX)?;
                raw.reset_fences(&[slots[s].fence])?;
            }
            slots[s].in_flight = false;
            let passes = |t: Option<ssbc::vk::GpuFrameTimes>| {
                t.map(|t| {
                    t.passes
                        .iter()
                        .map(|p| (p.name.clone(), p.gpu_ms))
                        .collect()
                })
                .unwrap_or_default()
            };
            report.resident_passes = passes(renderer.host_timings(s)?);
            report.post_passes = passes(post.timings(s)?);
            last = (slots[s].readback.read::<f32>(), slots[s].jitter);
        }
        if frame >= frames {
            continue;
        }
        let jitter = Vec2::new(halton(frame as u32 + 1, 2), halton(frame as u32 + 1, 3));
        let camera = Camera {
            jitter,
            ..base_camera.clone()
        };
        resident.set_camera(camera);
        slots[s].jitter = jitter;
        let slot = &slots[s];
        let cmd = slot.cmd;
        // SAFETY: the slot's buffer is not in flight (waited above).
        unsafe {
            raw.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())?;
            raw.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())?;
        }
        // ssbc's resident frame: S0 into the host's lighting image.
        let lighting = host::host_image(&slot.lighting, vk::ImageLayout::UNDEFINED);
        renderer.record_resident(
            &resident,
            &lighting_settings,
            cmd,
            s,
            &lighting,
            Layer::Final,
        )?;

        // The host's G-buffer, with the same jitter, packed as it keeps it.
        let to_general: Vec<_> = slot
            .working
            .iter()
            .map(|i| (i, vk::ImageLayout::UNDEFINED, general))
            .collect();
        host_barrier(
            &device,
            cmd,
            &to_general,
            compute,
            vk::AccessFlags2::SHADER_STORAGE_WRITE,
        );
        let camera_push: Vec<f32> = [
            eye.extend(0.0),
            forward.extend(0.0),
            (right * tan * aspect).extend(jitter.x),
            (up * tan).extend(jitter.y),
        ]
        .iter()
        .flat_map(|v| v.to_array())
        .collect();
        let groups = (w.div_ceil(8), h.div_ceil(8));
        gbuffer_kernel.dispatch(
            cmd,
            slot.sets[0],
            bytemuck::cast_slice(&camera_push),
            groups,
        );
        // The lighting image, read (not used) by the pack kernel: from the
        // resident frame's copy into GENERAL.
        let mut written: Vec<_> = slot.working.iter().map(|i| (i, general, general)).collect();
        written.push((&slot.lighting, transfer_dst, general));
        host_barrier(
            &device,
            cmd,
            &written,
            compute,
            vk::AccessFlags2::SHADER_STORAGE_READ,
        );
        let jittered =
            Mat4::from_translation((2.0 * jitter / Vec2::new(w as f32, h as f32)).extend(0.0))
                * projection;
        let pack_push = (jittered * view).to_cols_array();
        pack_kernel.dispatch(cmd, slot.sets[1], bytemuck::cast_slice(&pack_push), groups);
        host::copy_packed(&device, cmd, &slot.staging[..3], &slot.packed);

        // SSBC on the host's G-buffer, added onto its lighting.
        let [depth, normal, albedo] = slot
            .packed
            .each_ref()
            .map(|i| host::host_image(i, transfer_dst));
        let lighting = host::host_image(&slot.lighting, general);
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
            output: lighting,
            write: OutputWrite::Add,
            camera: HostCamera::Matrices {
                view,
                projection,
                jitter,
            },
            bound: settings.bound.resolve(1.0),
            typical_depth,
            hidden: None,
        };
        if !prepared {
            // Budget first, outside recording... here, before the first
            // frame's post-process (nothing is in flight yet).
            post.prepare(PostProcessShape::for_inputs(&inputs, &settings.ssbc)?)?;
            prepared = true;
        }
        post.set_restore_layouts(true);
        post.record(cmd, s, &inputs, &settings.ssbc, PostOutput::Compensated)?;

        // Read the image back after the frame (its layout handed back).
        let src = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
        host_barrier(
            &device,
            cmd,
            &[(&slot.lighting, general, src)],
            copy,
            vk::AccessFlags2::TRANSFER_READ,
        );
        copy_image_to_buffer(&device, cmd, &slot.lighting, &slot.readback);
        let host_read = (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ);
        memory_barrier(
            &device,
            cmd,
            (copy, vk::AccessFlags2::TRANSFER_WRITE),
            host_read,
        );
        host::submit(&device, cmd, slot.fence)?;
        slots[s].in_flight = true;
    }

    // ssbc's own render of the last frame's scene and jitter.
    device.wait_idle()?;
    let mut own_scene = scene.clone();
    own_scene.cameras = vec![Camera {
        jitter: last.1,
        ..base_camera.clone()
    }];
    let own = renderer.render(&own_scene, &settings)?;
    let s0 = renderer.render(&own_scene, &lighting_settings)?;
    let host_image = &last.0;
    let blocks = |rgba: &[f32]| ssbc::compare::block_average(rgba, w, h, 4);
    let whole = ssbc::compare::compare(host_image, &own.image.rgba)?;
    report.mean_ratio = whole.mean_ratio;
    report.block_rel_mse =
        ssbc::compare::compare(&blocks(host_image), &blocks(&own.image.rgba))?.rel_mse;
    let sum = |v: &[f32]| {
        v.chunks_exact(4)
            .map(|p| (p[0] + p[1] + p[2]) as f64)
            .sum::<f64>()
    };
    report.compensation_share = sum(&own.image.rgba) / sum(&s0.image.rgba) - 1.0;
    let less_s0 = |rgba: &[f32]| -> Vec<f32> {
        rgba.iter()
            .zip(&s0.image.rgba)
            .map(|(a, b)| a - b)
            .collect()
    };
    let c = ssbc::compare::compare(&less_s0(host_image), &less_s0(&own.image.rgba))?;
    report.compensation = (c.relative_rmse, c.mean_ratio);

    drop(post);
    drop(renderer);
    // SAFETY: no work is pending (waited idle).
    unsafe {
        for slot in &slots {
            raw.destroy_fence(slot.fence, None);
        }
        raw.destroy_command_pool(command_pool, None);
        raw.destroy_descriptor_pool(descriptor_pool, None);
    }
    drop((gbuffer_kernel, pack_kernel, slots));
    drop(memory);
    drop(device);
    // SAFETY: ssbc's objects on it are gone; the instance outlives it.
    unsafe { host_raw.destroy_device(None) };
    drop(instance);
    drop(own);
    report.validation_messages = host::OwnInstance::messages() - before;
    Ok(report)
}

#[allow(dead_code)] // the test includes this file for `run`
fn main() -> Result<(), Error> {
    let report = run(320, 240, 6)?;
    println!(
        "{} frames, two in flight: the last against ssbc's own render: mean ratio {:.5}, relMSE of 4x4 blocks {:.2e}; SSBC adds {:.1}% to S0, the host's compensation vs ssbc's: relative RMSE {:.3}, mean ratio {:.4}; {} validation messages",
        report.frames,
        report.mean_ratio,
        report.block_rel_mse,
        100.0 * report.compensation_share,
        report.compensation.0,
        report.compensation.1,
        report.validation_messages
    );
    println!("ssbc's resident frame (S0), timed in the host's command buffer:");
    for (name, ms) in &report.resident_passes {
        println!("  {name:40} {ms:9.3} ms");
    }
    println!("the SSBC post-process on the host's G-buffer:");
    for (name, ms) in &report.post_passes {
        println!("  {name:40} {ms:9.3} ms");
    }
    Ok(())
}
