//! What the post-process examples' hosts share: a small engine of its own
//! in raw `ash` (its allocator, images, buffers, compute kernels compiled
//! from GLSL at run time, barriers and device), and its G-buffer and
//! lighting kernels (a room corner with a box, lit by VPLs).

#![allow(dead_code)] // each example uses part of it

use std::sync::{Arc, Mutex};

use ash::vk;
use glam::Vec3;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme, Allocator};
use gpu_allocator::MemoryLocation;
use ssbc::vk::{Device, HostDevice, Instance, RequiredFeatures};

pub type Error = Box<dyn std::error::Error>;

/// The host's memory: its own allocator on the device ssbc made.
pub struct HostMemory {
    pub device: Arc<Device>,
    pub allocator: Mutex<Allocator>,
}

/// A host image: 2D, one level, with its view.
pub struct Image {
    pub memory: Arc<HostMemory>,
    pub raw: vk::Image,
    pub view: vk::ImageView,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    pub allocation: Option<Allocation>,
}

/// A host buffer.
pub struct Buffer {
    pub memory: Arc<HostMemory>,
    pub raw: vk::Buffer,
    pub allocation: Option<Allocation>,
}

impl HostMemory {
    pub fn new(device: &Arc<Device>) -> Result<Arc<Self>, Error> {
        let allocator = Allocator::new(&gpu_allocator::vulkan::AllocatorCreateDesc {
            instance: device.instance.raw.clone(),
            device: device.raw.clone(),
            physical_device: device.physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        })?;
        Ok(Arc::new(Self {
            device: device.clone(),
            allocator: Mutex::new(allocator),
        }))
    }

    /// Memory for a resource with `requirements` (`linear`: a buffer or a
    /// linearly tiled image).
    pub fn allocate(
        &self,
        name: &str,
        requirements: vk::MemoryRequirements,
        location: MemoryLocation,
        linear: bool,
    ) -> Result<Allocation, Error> {
        Ok(self
            .allocator
            .lock()
            .unwrap()
            .allocate(&AllocationCreateDesc {
                name,
                requirements,
                location,
                linear,
                allocation_scheme: AllocationScheme::GpuAllocatorManaged,
            })?)
    }

    /// A `width` x `height` RGBA32F image for storage and copies.
    pub fn image(self: &Arc<Self>, name: &str, width: u32, height: u32) -> Result<Image, Error> {
        let usage = vk::ImageUsageFlags::STORAGE
            | vk::ImageUsageFlags::TRANSFER_SRC
            | vk::ImageUsageFlags::TRANSFER_DST;
        self.image_of(
            name,
            (width, height),
            vk::Format::R32G32B32A32_SFLOAT,
            usage,
        )
    }

    /// A `width` x `height` image of `format` and `usage`.
    pub fn image_of(
        self: &Arc<Self>,
        name: &str,
        (width, height): (u32, u32),
        format: vk::Format,
        usage: vk::ImageUsageFlags,
    ) -> Result<Image, Error> {
        let raw_device = &self.device.raw;
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width,
                height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage);
        // SAFETY: a valid create info on a live device; destroyed in Drop.
        let raw = unsafe { raw_device.create_image(&info, None)? };
        // SAFETY: `raw` is a live image of this device.
        let requirements = unsafe { raw_device.get_image_memory_requirements(raw) };
        let allocation = self.allocate(name, requirements, MemoryLocation::GpuOnly, false)?;
        // SAFETY: the allocation fits the image's requirements; not bound yet.
        unsafe { raw_device.bind_image_memory(raw, allocation.memory(), allocation.offset())? };
        let view_info = vk::ImageViewCreateInfo::default()
            .image(raw)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(full_range(format));
        // SAFETY: the image is live and bound.
        let view = unsafe { raw_device.create_image_view(&view_info, None)? };
        Ok(Image {
            memory: self.clone(),
            raw,
            view,
            format,
            width,
            height,
            allocation: Some(allocation),
        })
    }

    /// A buffer of `size` bytes at `location`.
    pub fn buffer(
        self: &Arc<Self>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Buffer, Error> {
        let raw_device = &self.device.raw;
        let info = vk::BufferCreateInfo::default().size(size).usage(usage);
        // SAFETY: a valid create info; destroyed in Drop.
        let raw = unsafe { raw_device.create_buffer(&info, None)? };
        // SAFETY: `raw` is a live buffer of this device.
        let requirements = unsafe { raw_device.get_buffer_memory_requirements(raw) };
        let allocation = self.allocate(name, requirements, location, true)?;
        // SAFETY: the allocation fits; the buffer is not bound yet.
        unsafe { raw_device.bind_buffer_memory(raw, allocation.memory(), allocation.offset())? };
        Ok(Buffer {
            memory: self.clone(),
            raw,
            allocation: Some(allocation),
        })
    }
}

/// The aspect of an image of `format` (the example's formats).
pub fn aspect(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D32_SFLOAT => vk::ImageAspectFlags::DEPTH,
        _ => vk::ImageAspectFlags::COLOR,
    }
}

/// The whole of a one-level image of `format`.
pub fn full_range(format: vk::Format) -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange {
        aspect_mask: aspect(format),
        base_mip_level: 0,
        level_count: 1,
        base_array_layer: 0,
        layer_count: 1,
    }
}

impl Buffer {
    /// The host-visible bytes as `T`s (the device wrote them and the host
    /// waited for its fence).
    pub fn read<T: bytemuck::Pod>(&self) -> Vec<T> {
        let bytes = self
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .expect("a host-visible buffer");
        bytemuck::pod_collect_to_vec(bytes)
    }

    /// Copies `data` into the host-visible buffer.
    pub fn write<T: bytemuck::Pod>(&mut self, data: &[T]) {
        let bytes = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .expect("a host-visible buffer");
        let src = bytemuck::cast_slice(data);
        bytes[..src.len()].copy_from_slice(src);
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        let raw_device = &self.memory.device.raw;
        // SAFETY: the host waited for its work before dropping its images.
        unsafe {
            raw_device.destroy_image_view(self.view, None);
            raw_device.destroy_image(self.raw, None);
        }
        if let Some(a) = self.allocation.take() {
            let _ = self.memory.allocator.lock().unwrap().free(a);
        }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: as for images.
        unsafe { self.memory.device.raw.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take() {
            let _ = self.memory.allocator.lock().unwrap().free(a);
        }
    }
}

/// The host's G-buffer pass: a camera ray per pixel against three quads.
pub const GBUFFER_GLSL: &str = r#"#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform writeonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform writeonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform writeonly image2D g_albedo;
layout(push_constant) uniform Camera { vec4 eye; vec4 forward; vec4 right; vec4 up; } cam;

// A rectangle of the plane n.p = offset within [lo, hi], hit beyond tmin;
// with `front_only`, only from the side n faces.
void try_plane(vec3 o, vec3 d, vec3 n, float offset, vec3 lo, vec3 hi, vec3 albedo, bool front_only,
               float tmin, inout float best, inout vec3 hit_n, inout vec3 hit_albedo) {
    float denom = dot(n, d);
    if (abs(denom) < 1e-6 || (front_only && denom > 0.0)) return;
    float t = (offset - dot(n, o)) / denom;
    vec3 p = o + t * d;
    if (t > tmin && t < best && all(greaterThanEqual(p, lo - 1e-4)) && all(lessThanEqual(p, hi + 1e-4))) {
        best = t; hit_n = n; hit_albedo = albedo;
    }
}

// The corner (floor, back wall, left wall) and a box standing in it.
void trace(vec3 o, vec3 d, bool front_only, float tmin, inout float best, inout vec3 n, inout vec3 albedo) {
    try_plane(o, d, vec3(0, 1, 0), 0.0, vec3(-1, 0, -1), vec3(1, 0, 1), vec3(0.7, 0.7, 0.7), front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(0, 0, 1), -1.0, vec3(-1, 0, -1), vec3(1, 2, -1), vec3(0.8, 0.6, 0.4), front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(1, 0, 0), -1.0, vec3(-1, 0, -1), vec3(-1, 2, 1), vec3(0.3, 0.6, 0.8), front_only, tmin, best, n, albedo);
    vec3 lo = vec3(-0.7, 0.0, -0.6), hi = vec3(-0.3, 0.5, -0.2), a = vec3(0.6);
    try_plane(o, d, vec3(1, 0, 0), hi.x, vec3(hi.x, lo.yz), hi, a, front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(-1, 0, 0), -lo.x, lo, vec3(lo.x, hi.yz), a, front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(0, 0, 1), hi.z, vec3(lo.xy, hi.z), hi, a, front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(0, 0, -1), -lo.z, lo, vec3(hi.xy, lo.z), a, front_only, tmin, best, n, albedo);
    try_plane(o, d, vec3(0, 1, 0), hi.y, vec3(lo.x, hi.y, lo.z), hi, a, front_only, tmin, best, n, albedo);
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(g_position);
    if (any(greaterThanEqual(p, size))) return;
    // (right.w, up.w): the sub-pixel jitter the host draws this frame with.
    vec2 ndc = (vec2(p) + 0.5 - vec2(cam.right.w, cam.up.w)) / vec2(size) * 2.0 - 1.0;
    vec3 d = normalize(cam.forward.xyz + ndc.x * cam.right.xyz - ndc.y * cam.up.xyz);
    vec3 o = cam.eye.xyz;
    float best = 1e30; vec3 n = vec3(0); vec3 albedo = vec3(0);
    trace(o, d, true, 1e-4, best, n, albedo);
    // A second layer (eye.w = the separation; this G-buffer may be half the
    // size): the nearest surface that far behind the visible one, back
    // faces included, with its own outward normal.
    if (cam.eye.w > 0.0 && best < 1e29) {
        float first = best;
        best = 1e30;
        trace(o, d, false, first + cam.eye.w, best, n, albedo);
    }
    bool hit = best < 1e29;
    imageStore(g_position, p, hit ? vec4(o + best * d, 1.0) : vec4(0.0));
    imageStore(g_normal, p, vec4(n, 0.0));
    imageStore(g_albedo, p, vec4(albedo, 1.0));
}
"#;

/// The host's lighting: clamped VPL light, albedo/pi * sum flux * min(G, b)
/// (no shadows: every point of a concave corner sees every other).
pub const LIGHTING_GLSL: &str = r#"#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform writeonly image2D s0;
struct Vpl { vec4 position; vec4 normal; vec4 flux; };
layout(set = 0, binding = 4, std430) readonly buffer Vpls { Vpl vpls[]; };
layout(push_constant) uniform Params { uint count; float bound; } params;

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    if (any(greaterThanEqual(p, imageSize(s0)))) return;
    vec4 x = imageLoad(g_position, p);
    if (x.w == 0.0) { imageStore(s0, p, vec4(0.0)); return; }
    vec3 n = imageLoad(g_normal, p).xyz;
    vec3 sum = vec3(0);
    for (uint i = 0; i < params.count; i++) {
        vec3 d = vpls[i].position.xyz - x.xyz;
        float d2 = max(dot(d, d), 1e-8);
        vec3 w = d / sqrt(d2);
        float g = max(dot(n, w), 0.0) * max(dot(vpls[i].normal.xyz, -w), 0.0) / d2;
        sum += vpls[i].flux.rgb * min(g, params.bound);
    }
    imageStore(s0, p, vec4(imageLoad(g_albedo, p).rgb / 3.14159265 * sum, 1.0));
}
"#;

/// 64 VPLs on the floor near the corner, facing up: position, normal,
/// flux (`Vpl` in LIGHTING_GLSL).
pub fn corner_vpls() -> Vec<[f32; 12]> {
    (0..64)
        .map(|i| {
            let (u, v) = ((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
            [
                -1.0 + 1.2 * u,
                0.0,
                -1.0 + 1.2 * v,
                1.0,
                0.0,
                1.0,
                0.0,
                0.0,
                0.05,
                0.045,
                0.04,
                0.0,
            ]
        })
        .collect()
}

pub fn compile(source: &str, name: &str) -> Result<Vec<u32>, Box<dyn std::error::Error>> {
    let compiler = shaderc::Compiler::new()?;
    let spirv =
        compiler.compile_into_spirv(source, shaderc::ShaderKind::Compute, name, "main", None)?;
    Ok(spirv.as_binary().to_vec())
}

/// A raw compute pipeline of the host: storage images then storage buffers.
pub struct HostKernel {
    pub device: Arc<Device>,
    pub set_layout: vk::DescriptorSetLayout,
    pub layout: vk::PipelineLayout,
    pub pipeline: vk::Pipeline,
}

impl HostKernel {
    /// Records the kernel over `groups` work groups with `set` and `push`.
    pub fn dispatch(
        &self,
        cmd: vk::CommandBuffer,
        set: vk::DescriptorSet,
        push: &[u8],
        groups: (u32, u32),
    ) {
        let raw = &self.device.raw;
        // SAFETY: recording into the host's command buffer; the pipeline,
        // its layout and the set are live and match.
        unsafe {
            raw.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline);
            raw.cmd_bind_descriptor_sets(
                cmd,
                vk::PipelineBindPoint::COMPUTE,
                self.layout,
                0,
                &[set],
                &[],
            );
            raw.cmd_push_constants(cmd, self.layout, vk::ShaderStageFlags::COMPUTE, 0, push);
            raw.cmd_dispatch(cmd, groups.0, groups.1, 1);
        }
    }

    pub fn new(
        device: &Arc<Device>,
        spirv: &[u32],
        types: &[vk::DescriptorType],
        push_bytes: u32,
    ) -> Result<Self, Box<dyn std::error::Error>> {
        let raw = &device.raw;
        let bindings: Vec<_> = types
            .iter()
            .enumerate()
            .map(|(i, &t)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i as u32)
                    .descriptor_type(t)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .collect();
        let push = [vk::PushConstantRange::default()
            .stage_flags(vk::ShaderStageFlags::COMPUTE)
            .size(push_bytes)];
        // SAFETY: valid create infos on a live device; destroyed in Drop.
        unsafe {
            let set_layout = raw.create_descriptor_set_layout(
                &vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings),
                None,
            )?;
            let set_layouts = [set_layout];
            let layout = raw.create_pipeline_layout(
                &vk::PipelineLayoutCreateInfo::default()
                    .set_layouts(&set_layouts)
                    .push_constant_ranges(&push),
                None,
            )?;
            let module =
                raw.create_shader_module(&vk::ShaderModuleCreateInfo::default().code(spirv), None)?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main");
            let info = vk::ComputePipelineCreateInfo::default()
                .stage(stage)
                .layout(layout);
            let pipeline = raw
                .create_compute_pipelines(vk::PipelineCache::null(), &[info], None)
                .map_err(|(_, e)| e)?[0];
            raw.destroy_shader_module(module, None);
            Ok(Self {
                device: device.clone(),
                set_layout,
                layout,
                pipeline,
            })
        }
    }
}

impl Drop for HostKernel {
    fn drop(&mut self) {
        // SAFETY: the host waited for its work before dropping its kernels.
        unsafe {
            self.device.raw.destroy_pipeline(self.pipeline, None);
            self.device.raw.destroy_pipeline_layout(self.layout, None);
            self.device
                .raw
                .destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}

/// The host's barrier: everything before, to compute or transfer after.
pub fn host_barrier(
    device: &Device,
    cmd: vk::CommandBuffer,
    images: &[(&Image, vk::ImageLayout, vk::ImageLayout)],
    dst_stage: vk::PipelineStageFlags2,
    dst_access: vk::AccessFlags2,
) {
    let barriers: Vec<_> = images
        .iter()
        .map(|(image, old, new)| {
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
                .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
                .dst_stage_mask(dst_stage)
                .dst_access_mask(dst_access)
                .old_layout(*old)
                .new_layout(*new)
                .image(image.raw)
                .subresource_range(full_range(image.format))
        })
        .collect();
    // SAFETY: recording; the images are live.
    unsafe {
        device.raw.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(&barriers),
        )
    };
}

/// The host's device, with only what the SSBC post-process needs
/// (`RequiredFeatures::POST_PROCESS`: synchronization2 and timeline
/// semaphores; no dynamic rendering, no host query reset), handed to ssbc;
/// and the raw device, which the host destroys.
pub fn host_device(instance: &Arc<Instance>) -> Result<(Arc<Device>, ash::Device), Error> {
    host_device_with(instance, RequiredFeatures::POST_PROCESS)
}

/// The host's device with `features` merged into its own (none), handed to
/// ssbc; and the raw device, which the host destroys.
pub fn host_device_with(
    instance: &Arc<Instance>,
    features: RequiredFeatures,
) -> Result<(Arc<Device>, ash::Device), Error> {
    let raw = &instance.raw;
    // SAFETY: enumeration on a live instance.
    let physical = *unsafe { raw.enumerate_physical_devices()? }
        .first()
        .ok_or("no Vulkan device")?;
    // SAFETY: valid physical device.
    let family = unsafe { raw.get_physical_device_queue_family_properties(physical) }
        .iter()
        .position(|f| {
            f.queue_flags
                .contains(vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE)
        })
        .ok_or("no graphics+compute queue")? as u32;
    let priorities = [1.0];
    let queues = [vk::DeviceQueueCreateInfo::default()
        .queue_family_index(family)
        .queue_priorities(&priorities)];
    // The host's own features (none here), and what ssbc needs merged in.
    let (mut f12, mut f13) = features.merge_into(
        vk::PhysicalDeviceVulkan12Features::default(),
        vk::PhysicalDeviceVulkan13Features::default(),
    );
    let info = vk::DeviceCreateInfo::default()
        .queue_create_infos(&queues)
        .push_next(&mut f12)
        .push_next(&mut f13);
    // SAFETY: a Vulkan 1.3 device offers all four features.
    let device = unsafe { raw.create_device(physical, &info, None)? };
    let ssbc = Device::from_host(
        instance.clone(),
        HostDevice {
            physical,
            device: device.clone(),
            queue_family: family,
            queue_index: 0,
            enabled_features: features,
        },
    )?;
    Ok((ssbc, device))
}

/// The host packs its RGBA32F working images into what it keeps: depth
/// (reversed Z, 0 where nothing was hit), normals as unsigned 10-bit xyz,
/// albedo sRGB-encoded in 8 bits, lighting in halves.
pub const PACK_GLSL: &str = r#"#version 450
layout(local_size_x = 8, local_size_y = 8) in;
layout(set = 0, binding = 0, rgba32f) uniform readonly image2D g_position;
layout(set = 0, binding = 1, rgba32f) uniform readonly image2D g_normal;
layout(set = 0, binding = 2, rgba32f) uniform readonly image2D g_albedo;
layout(set = 0, binding = 3, rgba32f) uniform readonly image2D s0;
layout(set = 0, binding = 4, std430) writeonly buffer Depth { float depth[]; };
layout(set = 0, binding = 5, std430) writeonly buffer Normal { uint normal[]; };
layout(set = 0, binding = 6, std430) writeonly buffer Albedo { uint albedo[]; };
layout(set = 0, binding = 7, std430) writeonly buffer Lighting { uvec2 lighting[]; };
layout(push_constant) uniform Pack { mat4 view_projection; } pc;

vec3 srgb_encode(vec3 x) {
    return mix(12.92 * x, 1.055 * pow(x, vec3(1.0 / 2.4)) - 0.055, greaterThan(x, vec3(0.0031308)));
}

void main() {
    ivec2 p = ivec2(gl_GlobalInvocationID.xy);
    ivec2 size = imageSize(g_position);
    if (any(greaterThanEqual(p, size))) return;
    uint i = uint(p.y * size.x + p.x);
    vec4 x = imageLoad(g_position, p);
    vec4 clip = pc.view_projection * vec4(x.xyz, 1.0);
    depth[i] = x.w != 0.0 ? clip.z / clip.w : 0.0;
    uvec3 n = uvec3(round(clamp(imageLoad(g_normal, p).xyz * 0.5 + 0.5, 0.0, 1.0) * 1023.0));
    normal[i] = n.x | (n.y << 10) | (n.z << 20) | (3u << 30);
    albedo[i] = packUnorm4x8(vec4(srgb_encode(clamp(imageLoad(g_albedo, p).rgb, 0.0, 1.0)), 1.0));
    vec3 c = imageLoad(s0, p).rgb;
    lighting[i] = uvec2(packHalf2x16(c.rg), packHalf2x16(vec2(c.b, 1.0)));
}
"#;

pub const PACKED_FORMATS: [vk::Format; 4] = [
    vk::Format::D32_SFLOAT,
    vk::Format::A2B10G10R10_UNORM_PACK32,
    vk::Format::R8G8B8A8_SRGB,
    vk::Format::R16G16B16A16_SFLOAT,
];
/// Bytes per texel of each packed image.
pub const PACKED_BYTES: [u64; 4] = [4, 4, 4, 8];

/// The `N` resources made for each of `N` names.
pub fn array<T, const N: usize>(v: Vec<T>) -> [T; N] {
    v.try_into().unwrap_or_else(|_| unreachable!("made N"))
}

/// Half to float.
pub fn half(bits: u16) -> f32 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exponent = ((bits >> 10) & 0x1f) as i32;
    let mantissa = (bits & 0x3ff) as f32;
    sign * match exponent {
        0 => mantissa * 2f32.powi(-24),
        31 => f32::INFINITY,
        e => (1.0 + mantissa / 1024.0) * 2f32.powi(e - 15),
    }
}

/// The packed normals, albedo and lighting read back, decoded to RGBA
/// floats: unsigned 10-bit xyz made unit length, sRGB, halves.
pub fn decode(readback: &[Buffer]) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let normal = readback[0]
        .read::<u32>()
        .iter()
        .flat_map(|&bits| {
            let t = |shift: u32| ((bits >> shift) & 1023) as f32 / 1023.0 * 2.0 - 1.0;
            let n = Vec3::new(t(0), t(10), t(20));
            let n = if n.length() > 0.0 { n / n.length() } else { n };
            [n.x, n.y, n.z, 0.0]
        })
        .collect();
    let srgb = |byte: u8| {
        let c = byte as f32 / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    let albedo = readback[1]
        .read::<u32>()
        .iter()
        .flat_map(|&bits| {
            let b = bits.to_le_bytes();
            [srgb(b[0]), srgb(b[1]), srgb(b[2]), 1.0]
        })
        .collect();
    let lighting = readback[2].read::<u16>().into_iter().map(half).collect();
    (normal, albedo, lighting)
}

/// Relative RMSE and mean ratio of `gpu` against `twin` (rgb of RGBA).
pub fn compare(gpu: &[f32], twin: &[f32]) -> (f64, f64) {
    let (mut err, mut norm, mut sum_gpu, mut sum_twin) = (0f64, 0f64, 0f64, 0f64);
    for (i, (a, b)) in gpu.iter().zip(twin).enumerate() {
        if i % 4 == 3 {
            continue;
        }
        err += ((a - b) as f64).powi(2);
        norm += (*b as f64).powi(2);
        sum_gpu += *a as f64;
        sum_twin += *b as f64;
    }
    (
        (err / norm.max(1e-30)).sqrt(),
        sum_gpu / sum_twin.max(1e-30),
    )
}

/// The whole of `image`'s one level and layer, for a buffer copy.
fn whole(image: &Image) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: aspect(image.format),
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        })
        .image_extent(vk::Extent3D {
            width: image.width,
            height: image.height,
            depth: 1,
        })
}

/// Records a copy of all of `image` (in TRANSFER_SRC_OPTIMAL) into `buffer`.
pub fn copy_image_to_buffer(
    device: &Device,
    cmd: vk::CommandBuffer,
    image: &Image,
    buffer: &Buffer,
) {
    let layout = vk::ImageLayout::TRANSFER_SRC_OPTIMAL;
    // SAFETY: recording; the caller's barrier put the image in the layout,
    // and the buffer holds a texel per pixel in its format.
    unsafe {
        device
            .raw
            .cmd_copy_image_to_buffer(cmd, image.raw, layout, buffer.raw, &[whole(image)])
    };
}

/// Records a copy of `buffer` into all of `image` (in TRANSFER_DST_OPTIMAL).
pub fn copy_buffer_to_image(
    device: &Device,
    cmd: vk::CommandBuffer,
    buffer: &Buffer,
    image: &Image,
) {
    let layout = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    // SAFETY: as for copy_image_to_buffer.
    unsafe {
        device
            .raw
            .cmd_copy_buffer_to_image(cmd, buffer.raw, image.raw, layout, &[whole(image)])
    };
}

/// Records a global barrier from `src` to `dst` (stage, access).
pub fn memory_barrier(
    device: &Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags2, vk::AccessFlags2),
    dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
) {
    let barrier = vk::MemoryBarrier2::default()
        .src_stage_mask(src.0)
        .src_access_mask(src.1)
        .dst_stage_mask(dst.0)
        .dst_access_mask(dst.1);
    // SAFETY: recording.
    unsafe {
        device.raw.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().memory_barriers(&[barrier]),
        )
    };
}

/// The host's command pool on `device`'s queue family (buffers resettable).
pub fn command_pool(device: &Device) -> Result<vk::CommandPool, Error> {
    let info = vk::CommandPoolCreateInfo::default()
        .queue_family_index(device.queue_family)
        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER);
    // SAFETY: a valid create info on a live device; the caller destroys it.
    Ok(unsafe { device.raw.create_command_pool(&info, None)? })
}

/// Ends `cmd` and submits it to the queue, signalling `fence`.
pub fn submit(device: &Device, cmd: vk::CommandBuffer, fence: vk::Fence) -> Result<(), Error> {
    let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
    // SAFETY: the host's recording buffer and unsignalled fence.
    unsafe {
        device.raw.end_command_buffer(cmd)?;
        device.raw.queue_submit2(
            device.queue,
            &[vk::SubmitInfo2::default().command_buffer_infos(&cmds)],
            fence,
        )?;
    }
    Ok(())
}

/// [`submit`], then waits for `fence` and resets it.
pub fn submit_and_wait(
    device: &Device,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
) -> Result<(), Error> {
    submit(device, cmd, fence)?;
    // SAFETY: the fence was just submitted.
    unsafe {
        device.raw.wait_for_fences(&[fence], true, u64::MAX)?;
        device.raw.reset_fences(&[fence])?;
    }
    Ok(())
}

/// The passes of a frame's GPU timings, as (name, ms).
pub fn pass_times(times: Option<ssbc::vk::GpuFrameTimes>) -> Vec<(String, f64)> {
    times
        .map(|t| {
            t.passes
                .iter()
                .map(|p| (p.name.clone(), p.gpu_ms))
                .collect()
        })
        .unwrap_or_default()
}

/// After the pack kernel: its buffers into the images the host keeps.
pub fn copy_packed(device: &Device, cmd: vk::CommandBuffer, staging: &[Buffer], packed: &[Image]) {
    let (compute, copy) = (
        vk::PipelineStageFlags2::COMPUTE_SHADER,
        vk::PipelineStageFlags2::COPY,
    );
    let written = (compute, vk::AccessFlags2::SHADER_STORAGE_WRITE);
    memory_barrier(
        device,
        cmd,
        written,
        (copy, vk::AccessFlags2::TRANSFER_READ),
    );
    let dst = vk::ImageLayout::TRANSFER_DST_OPTIMAL;
    let to_dst: Vec<_> = packed
        .iter()
        .map(|i| (i, vk::ImageLayout::UNDEFINED, dst))
        .collect();
    host_barrier(device, cmd, &to_dst, copy, vk::AccessFlags2::TRANSFER_WRITE);
    for (image, buffer) in packed.iter().zip(staging) {
        copy_buffer_to_image(device, cmd, buffer, image);
    }
}

/// `image` as ssbc sees a host's image, in `layout` when ssbc's commands start.
pub fn host_image(image: &Image, layout: vk::ImageLayout) -> ssbc::vk::HostImage {
    ssbc::vk::HostImage {
        image: image.raw,
        view: image.view,
        format: image.format,
        extent: (image.width, image.height),
        layout,
    }
}

/// Validation messages the host's messenger saw.
static MESSAGES: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);

unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    _user: *mut std::ffi::c_void,
) -> vk::Bool32 {
    let counted = vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR;
    if severity.intersects(counted) {
        MESSAGES.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        // SAFETY: the layer passes a valid struct with a NUL-terminated message.
        let text = unsafe { std::ffi::CStr::from_ptr((*data).p_message) };
        eprintln!("[host validation] {}", text.to_string_lossy());
    }
    vk::FALSE
}

/// The host's own Vulkan 1.3 instance, made with `ash`: with the Khronos
/// validation layer, synchronization validation and a messenger counting
/// warnings and errors when asked. ssbc never destroys it; the host does
/// (on drop), after everything made on it.
pub struct OwnInstance {
    pub entry: ash::Entry,
    pub raw: ash::Instance,
    debug_utils: ash::ext::debug_utils::Instance,
    messenger: Option<vk::DebugUtilsMessengerEXT>,
}

impl OwnInstance {
    pub fn new(validation: bool) -> Result<Self, Error> {
        // SAFETY: loading the system Vulkan loader.
        let entry = unsafe { ash::Entry::load()? };
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let layers = [c"VK_LAYER_KHRONOS_validation".as_ptr()];
        let extensions = [
            ash::ext::debug_utils::NAME.as_ptr(),
            ash::ext::validation_features::NAME.as_ptr(),
        ];
        let sync = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&sync);
        let messenger_info = || {
            vk::DebugUtilsMessengerCreateInfoEXT::default()
                .message_severity(
                    vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                        | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
                )
                .message_type(
                    vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                        | vk::DebugUtilsMessageTypeFlagsEXT::GENERAL,
                )
                .pfn_user_callback(Some(on_message))
        };
        // Also for messages while the instance is created and destroyed.
        let mut creation_messenger = messenger_info();
        let mut info = vk::InstanceCreateInfo::default().application_info(&app);
        if validation {
            info = info
                .enabled_layer_names(&layers)
                .enabled_extension_names(&extensions)
                .push_next(&mut features)
                .push_next(&mut creation_messenger);
        }
        // SAFETY: valid create info; destroyed in Drop.
        let raw = unsafe { entry.create_instance(&info, None)? };
        let debug_utils = ash::ext::debug_utils::Instance::new(&entry, &raw);
        let messenger = if validation {
            // SAFETY: debug utils are enabled; destroyed before the instance.
            Some(unsafe { debug_utils.create_debug_utils_messenger(&messenger_info(), None)? })
        } else {
            None
        };
        Ok(Self {
            entry,
            raw,
            debug_utils,
            messenger,
        })
    }

    /// The instance as ssbc sees a host's (never destroyed by ssbc).
    pub fn for_ssbc(&self) -> Arc<Instance> {
        Instance::from_host(self.entry.clone(), self.raw.clone())
    }

    /// Validation warnings and errors so far.
    pub fn messages() -> u32 {
        MESSAGES.load(std::sync::atomic::Ordering::SeqCst)
    }
}

impl Drop for OwnInstance {
    fn drop(&mut self) {
        // SAFETY: everything made on the instance is gone (the host drops it
        // last).
        unsafe {
            if let Some(m) = self.messenger.take() {
                self.debug_utils.destroy_debug_utils_messenger(m, None);
            }
            self.raw.destroy_instance(None);
        }
    }
}
