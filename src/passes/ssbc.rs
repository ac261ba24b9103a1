//! Screen-space bias compensation: K steps of residual transport
//! `S_k = T_r S_{k-1}` over the screen, hierarchically (Nichols et al. 2009
//! style top-down integration over mip chains) or by brute force.
//!
//! Per frame: the geometry pyramid (area-weighted position and normal, summed
//! area `A_y`, discontinuity flag) is built once; each step builds the
//! radiance pyramid of the previous term, integrates the residual, and adds it
//! to the final image.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::gbuffer::GBuffer;
use super::{Pass, Recording, SlotSetup};
use crate::error::{Error, Result};
pub use crate::settings::{Integration, LayerResolution, SsbcSettings};
use crate::shaders;
use crate::vk::{
    Access, Binding, Buffer, BufferView, ComputeKernel, DescriptorPool, DescriptorSetLayout,
    Device, GpuProfiler, Image, Recorder,
};

/// Camera quantities the SSBC shaders need.
#[derive(Clone, Copy, Debug)]
pub struct SsbcCamera {
    /// Eye position.
    pub position: glam::Vec3,
    /// Unit optical axis.
    pub forward: glam::Vec3,
    /// Unit up direction of the image, orthogonal to `forward` (row 0 is
    /// the top).
    pub up: glam::Vec3,
    /// Pixel side on the image plane at distance 1: 2 tan(fov/2) / height.
    pub pixel_side: f32,
}

/// The SSBC pipelines.
pub struct SsbcPass {
    geometry_base: ComputeKernel,
    geometry: ComputeKernel,
    radiance: ComputeKernel,
    eval: ComputeKernel,
    resolve: ComputeKernel,
    fallback: ComputeKernel,
    samples: ComputeKernel,
    layer_residual: ComputeKernel,
}

/// One frame's SSBC resources.
pub struct SsbcFrame {
    /// `geo` as `R32G32B32A32_UINT` texels (four per `GeoTexel`), for the
    /// kernels that only read it. Views are declared before their buffers
    /// so that they are dropped first.
    geo_texels: BufferView,
    /// `radiance` as `R32G32B32A32_SFLOAT` texels (two per texel).
    radiance_texels: BufferView,
    /// `points` as `R32G32B32A32_UINT` texels (four per `EvalPoint`).
    point_texels: BufferView,
    /// Geometry pyramid, every level in one buffer (`GeoTexel` in ssbc.glsl).
    pub geo: Buffer,
    /// Summed area, pixel count and continuity per texel (`GeoAux`).
    pub aux: Buffer,
    /// Sum of `A_y S_{k-1}(y)` per texel.
    pub radiance: Buffer,
    /// Evaluation points, one per texel of every level (`EvalPoint`).
    pub points: Buffer,
    /// Pixels still to resolve at the next finer level (two, used in turn).
    pub pending: [Buffer; 2],
    /// Texels whose evaluation points the next level needs.
    pub requests: Buffer,
    /// Pixels evaluated alone.
    pub fallback: Buffer,
    /// Per step, the fallback list's header (dispatch x, y, z, pixel count),
    /// for the host.
    pub stats: Buffer,
    /// `residual_k` for k = 1..=K.
    pub residuals: Vec<Image>,
    /// Texels read per pixel of each step (r32f: a pixel's own reads plus its
    /// share of the evaluation points whose blocks it is in).
    pub samples: Vec<Image>,
    /// `S0 + residual_1 + ... + residual_K`.
    pub final_image: Image,
    /// With a second layer: its `residual_k` for k = 1..K-1 (at its
    /// resolution), the next step's sources there.
    pub layer1_residuals: Vec<Image>,
    /// The second layer's resolution, if the pyramids hold one.
    layer1: Option<LayerResolution>,
    levels: u32,
    pyramid_size: (u32, u32),
    /// The coarsest evaluation level the descriptor sets are counted for.
    max_eval_level: u32,
}

impl SsbcFrame {
    /// Pyramid levels.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Steps the frame holds residuals for.
    pub fn steps(&self) -> u32 {
        self.residuals.len() as u32
    }

    /// G-buffer layers the pyramids hold (1, or 2 with a deep G-buffer's
    /// second layer).
    pub fn layers(&self) -> u32 {
        1 + self.layer1.is_some() as u32
    }

    /// The second layer's resolution, if the pyramids hold one.
    pub fn layer1(&self) -> Option<LayerResolution> {
        self.layer1
    }

    /// Pixels evaluated alone in each step (after the frame has finished;
    /// `stats` declared as host-read).
    pub fn fallback_counts(&self) -> Result<Vec<u32>> {
        let words: Vec<u32> = self.stats.read()?;
        Ok(words.chunks_exact(4).map(|h| h[3]).collect())
    }
}

/// A texels-read count at least this (`CUT_SHORT` in ssbc.glsl) marks a
/// residual sum whose loops the device cut short (lavapipe runs 65535 loop
/// iterations per shader invocation, then stops them silently).
pub(crate) const CUT_SHORT: u32 = 1 << 30;

/// Push constants of every SSBC kernel (`SsbcPush` in ssbc.glsl).
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct SsbcPush {
    camera_position: [f32; 4],
    camera_forward: [f32; 4],
    camera_up: [f32; 4],
    size: [u32; 2],
    pyramid_size: [u32; 2],
    levels: u32,
    level: u32,
    eval_level: u32,
    mode: u32,
    bound: f32,
    refine_ratio: f32,
    min_cos_view: f32,
    max_normal_spread: f32,
    max_thickness: f32,
    texels_per_radius: f32,
    scale_fraction: f32,
    generation: u32,
    from_list: u32,
    refine_excess: f32,
    layers: u32,
    build_layer: u32,
}

/// Level 0 of the pyramids for an image (padded so that every level halves
/// exactly) and the number of levels.
fn pyramid_layout(width: u32, height: u32) -> ((u32, u32), u32) {
    let levels = pyramid_levels(width, height);
    let align = 1u32 << (levels - 1);
    (
        (
            width.div_ceil(align) * align,
            height.div_ceil(align) * align,
        ),
        levels,
    )
}

/// Fails with a clear message if SSBC's largest storage buffer (the
/// evaluation points, 64 bytes per texel of every pyramid level; with a
/// second layer the geometry pyramid: a quarter larger at half resolution,
/// twice at full) exceeds what the device can bind (maxStorageBufferRange;
/// 128 MiB on lavapipe, which allows about 1400x1050 with one layer and
/// 1024x768 with a full-resolution second layer).
pub fn check_size(
    device: &Device,
    width: u32,
    height: u32,
    layer1: Option<LayerResolution>,
) -> Result<()> {
    let (size, levels) = pyramid_layout(width, height);
    let layer1 = effective_layer1(layer1, levels);
    let all = all_layers_texels(size, levels, layer1);
    let largest = (all * GEO_TEXEL_BYTES).max(pyramid_texels(size, levels) * EVAL_POINT_BYTES);
    let max = device.limits().max_storage_buffer_range as u64;
    if largest > max {
        return Err(Error::InvalidParameter(format!(
            "SSBC at {width}x{height} needs {} MiB storage buffers; this device binds at most \
             {} MiB (maxStorageBufferRange): render smaller{} or with ssbc.steps 0",
            largest >> 20,
            max >> 20,
            match layer1 {
                Some(LayerResolution::Full) => ", with ssbc.layer1_resolution half",
                Some(LayerResolution::Half) => ", with ssbc.layers 1",
                None => "",
            }
        )));
    }
    Ok(())
}

/// Pyramid levels for an image: down to about 2 texels on the short side.
pub fn pyramid_levels(width: u32, height: u32) -> u32 {
    (31 - width.min(height).max(1).leading_zeros()).clamp(1, 12)
}

/// Texels of all `levels` levels of a pyramid whose level 0 is `size`
/// (padded so every level halves exactly; `texel_index` in ssbc.glsl).
fn pyramid_texels(size: (u32, u32), levels: u32) -> u64 {
    let n = size.0 as u64 * size.1 as u64;
    (4 * n - 4 * (n >> (2 * levels))) / 3
}

/// Texels of layer 0's pyramid and, with a second layer, layer 1's after it
/// (at half resolution half the size, one level fewer: `pyramid_of` in
/// ssbc.glsl).
fn all_layers_texels(size: (u32, u32), levels: u32, layer1: Option<LayerResolution>) -> u64 {
    let first = pyramid_texels(size, levels);
    match layer1 {
        None => first,
        Some(r) => {
            let shift = r.shift();
            first + pyramid_texels((size.0 >> shift, size.1 >> shift), levels - shift)
        }
    }
}

/// The second layer a pyramid of `levels` levels can hold: at half
/// resolution it needs a level to spare (images of at least 2 pixels on the
/// short side).
fn effective_layer1(layer1: Option<LayerResolution>, levels: u32) -> Option<LayerResolution> {
    layer1.filter(|r| levels > r.shift())
}

/// Sizes of the GLSL structs, in bytes.
const GEO_TEXEL_BYTES: u64 = 64;
const AUX_BYTES: u64 = 16;
const RADIANCE_BYTES: u64 = 32;
const EVAL_POINT_BYTES: u64 = 64;
/// A list's header: `VkDispatchIndirectCommand` and the item count.
const LIST_HEADER: [u32; 4] = [0, 1, 1, 0];

/// Everything the recording needs besides the resources.
#[derive(Clone, Copy, Debug)]
pub struct SsbcInputs<'a> {
    /// The camera.
    pub camera: &'a SsbcCamera,
    /// Clamping bound b (1/m²).
    pub bound: f32,
    /// Coarsest level of evaluation points ([`SsbcPass::eval_level`]).
    pub eval_level: u32,
    /// Parameters.
    pub settings: &'a SsbcSettings,
}

impl SsbcPass {
    /// Creates the pipelines.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        use vk::DescriptorType as T;
        // Bindings 0..2 of every kernel: geo, aux, radiance (ssbc.glsl).
        let with_pyramids = |own: &[T]| [&[T::STORAGE_BUFFER; 3][..], own].concat();
        // Kernels that only read the pyramids see geo and radiance as texels
        // (SSBC_READ_PYRAMIDS in ssbc.glsl; see vk::buffer_view for why).
        let reading_pyramids = |own: &[T]| {
            let pyramids = [
                T::UNIFORM_TEXEL_BUFFER,
                T::STORAGE_BUFFER,
                T::UNIFORM_TEXEL_BUFFER,
            ];
            [&pyramids[..], own].concat()
        };
        let push = std::mem::size_of::<SsbcPush>();
        // Points, pending in, pending out, requests, G-buffer (3), previous
        // sum, final, residual, samples, points as texels (ssbc_output.glsl).
        let output = [
            &[T::STORAGE_BUFFER; 4][..],
            &[T::STORAGE_IMAGE; 7],
            &[T::UNIFORM_TEXEL_BUFFER],
        ]
        .concat();
        let kernel =
            |spirv, own: &[T]| ComputeKernel::new(device, spirv, &with_pyramids(own), push);
        let reader =
            |spirv, own: &[T]| ComputeKernel::new(device, spirv, &reading_pyramids(own), push);
        Ok(Self {
            // Level 0 of the geometry pyramid, from the G-buffer position and
            // normal; its own kernel because lavapipe ran it 3x slower inside
            // the coarser levels' (45 -> 14 ms at 1024x768).
            geometry_base: kernel(shaders::SSBC_GEOMETRY_BASE_COMP, &[T::STORAGE_IMAGE; 2])?
                .named("ssbc_geometry_base"),
            geometry: kernel(shaders::SSBC_GEOMETRY_MIPS_COMP, &[])?.named("ssbc_geometry_mips"),
            // The term S_{k-1}.
            radiance: kernel(shaders::SSBC_RADIANCE_MIPS_COMP, &[T::STORAGE_IMAGE])?
                .named("ssbc_radiance_mips"),
            // Points, requests.
            eval: reader(shaders::SSBC_EVAL_COMP, &[T::STORAGE_BUFFER; 2])?
                .named("ssbc_residual_eval"),
            resolve: reader(shaders::SSBC_RESOLVE_COMP, &output)?.named("ssbc_residual_resolve"),
            fallback: reader(shaders::SSBC_FALLBACK_COMP, &output)?.named("ssbc_residual_fallback"),
            // Points (as texels), samples.
            samples: reader(
                shaders::SSBC_SAMPLES_COMP,
                &[T::UNIFORM_TEXEL_BUFFER, T::STORAGE_IMAGE],
            )?
            .named("ssbc_samples"),
            // Layer 1's G-buffer (3), its residual.
            layer_residual: reader(shaders::SSBC_LAYER_RESIDUAL_COMP, &[T::STORAGE_IMAGE; 4])?
                .named("ssbc_layer1_residual"),
        })
    }

    /// Layouts of every set one frame of `frame` allocates.
    pub fn frame_layouts(&self, frame: &SsbcFrame) -> Vec<&DescriptorSetLayout> {
        let levels = frame.levels as usize;
        // Layer 0's pyramid levels, then layer 1's (one fewer at half resolution).
        let per_layer: Vec<usize> = std::iter::once(levels)
            .chain(frame.layer1.map(|r| levels - r.shift() as usize))
            .collect();
        let built: usize = per_layer.iter().sum();
        let mut v = Vec::new();
        for &layer_levels in &per_layer {
            v.push(self.geometry_base.set_layout());
            v.extend(std::iter::repeat_n(
                self.geometry.set_layout(),
                layer_levels - 1,
            ));
        }
        for step in 0..frame.steps() {
            v.extend(std::iter::repeat_n(self.radiance.set_layout(), built));
            if frame.layer1.is_some() && step + 1 < frame.steps() {
                v.push(self.layer_residual.set_layout());
            }
            for _ in 0..=frame.max_eval_level {
                v.push(self.eval.set_layout());
                v.push(self.resolve.set_layout());
            }
            v.push(self.fallback.set_layout());
            v.push(self.samples.set_layout());
        }
        v
    }

    /// The coarsest level of evaluation points: the coarsest (at most
    /// `max_eval_level`) that puts `texels_per_radius` texels across the
    /// bounding radius 1/sqrt(b) at `depth` (the distance along the optical
    /// axis of the scene's centre). Where the radius is smaller on screen,
    /// pixels use finer points or are evaluated alone.
    pub fn eval_level(
        camera: &SsbcCamera,
        depth: f32,
        bound: f32,
        levels: u32,
        settings: &SsbcSettings,
    ) -> u32 {
        if settings.integration == Integration::Brute || !bound.is_finite() {
            return 0;
        }
        let radius_px = bound.sqrt().recip() / (depth.max(1e-3) * camera.pixel_side);
        let texels = radius_px / settings.texels_per_radius;
        // (NaN for a degenerate camera or bound: evaluate every pixel.)
        if texels.is_nan() || texels < 2.0 {
            return 0;
        }
        (texels.log2().floor() as u32)
            .min(settings.max_eval_level)
            .min(levels - 1)
    }

    /// Allocates one frame's resources for `steps` steps, with descriptor
    /// sets counted for evaluation points from `max_eval_level` (at most)
    /// down ([`SsbcPass::frame_layouts`]).
    pub fn allocate(
        &self,
        device: &Arc<Device>,
        extent: (u32, u32),
        steps: u32,
        max_eval_level: u32,
        layer1: Option<LayerResolution>,
    ) -> Result<SsbcFrame> {
        // Level 0 padded so every level halves exactly (padding has no geometry).
        let (pyramid_size, levels) = pyramid_layout(extent.0, extent.1);
        let layer1 = effective_layer1(layer1, levels);
        // Evaluation points exist for layer 0's texels only.
        let texels = pyramid_texels(pyramid_size, levels);
        let all_texels = all_layers_texels(pyramid_size, levels, layer1);
        let storage = |name: &str, size: u64, extra: vk::BufferUsageFlags| {
            Buffer::new(
                device,
                name,
                size,
                vk::BufferUsageFlags::STORAGE_BUFFER | extra,
                MemoryLocation::GpuOnly,
            )
        };
        let none = vk::BufferUsageFlags::empty();
        let list_bytes = 16 + 4 * pyramid_size.0 as u64 * pyramid_size.1 as u64;
        let list = |name: &str| {
            storage(
                name,
                list_bytes,
                vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
            )
        };
        let image = |name: String, format| {
            super::storage_image(device, &name, format, extent, vk::ImageUsageFlags::empty())
        };
        let residuals = (1..=steps)
            .map(|k| {
                image(
                    format!("ssbc.residual_{k}"),
                    vk::Format::R32G32B32A32_SFLOAT,
                )
            })
            .collect::<Result<_>>()?;
        let samples = (1..=steps)
            .map(|k| image(format!("ssbc.samples_{k}"), vk::Format::R32_SFLOAT))
            .collect::<Result<_>>()?;
        let texel_usage = vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER;
        let geo = storage(
            "ssbc.pyramid.geometry",
            all_texels * GEO_TEXEL_BYTES,
            texel_usage,
        )?;
        let radiance = storage(
            "ssbc.pyramid.radiance",
            all_texels * RADIANCE_BYTES,
            texel_usage,
        )?;
        let layer1_residuals = match layer1 {
            Some(r) => (1..steps)
                .map(|k| {
                    let name = format!("ssbc.layer1_residual_{k}");
                    super::radiance_image(device, &name, r.extent(extent))
                })
                .collect::<Result<_>>()?,
            None => Vec::new(),
        };
        let view =
            |buffer: &Buffer, format, name: &str| BufferView::new(device, buffer, format, 16, name);
        let points = storage(
            "ssbc.eval_points",
            texels * EVAL_POINT_BYTES,
            vk::BufferUsageFlags::TRANSFER_DST | texel_usage,
        )?;
        Ok(SsbcFrame {
            point_texels: view(
                &points,
                vk::Format::R32G32B32A32_UINT,
                "ssbc.eval_points texels",
            )?,
            geo_texels: view(
                &geo,
                vk::Format::R32G32B32A32_UINT,
                "ssbc.pyramid.geometry texels",
            )?,
            radiance_texels: view(
                &radiance,
                vk::Format::R32G32B32A32_SFLOAT,
                "ssbc.pyramid.radiance texels",
            )?,
            geo,
            aux: storage("ssbc.pyramid.aux", all_texels * AUX_BYTES, none)?,
            radiance,
            points,
            pending: [list("ssbc.pending_a")?, list("ssbc.pending_b")?],
            requests: list("ssbc.requests")?,
            fallback: list("ssbc.fallback")?,
            stats: Buffer::new(
                device,
                "ssbc.stats",
                16 * steps.max(1) as u64,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
            residuals,
            samples,
            final_image: image("ssbc.final".into(), vk::Format::R32G32B32A32_SFLOAT)?,
            layer1_residuals,
            layer1,
            levels,
            pyramid_size,
            max_eval_level: max_eval_level.min(levels - 1),
        })
    }

    fn push(&self, inputs: &SsbcInputs<'_>, extent: (u32, u32), frame: &SsbcFrame) -> SsbcPush {
        let (camera, settings) = (inputs.camera, inputs.settings);
        SsbcPush {
            camera_position: camera.position.extend(camera.pixel_side).into(),
            camera_forward: camera.forward.extend(1.0 / camera.pixel_side).into(),
            camera_up: camera.up.extend(0.0).into(),
            size: [extent.0, extent.1],
            pyramid_size: [frame.pyramid_size.0, frame.pyramid_size.1],
            levels: frame.levels,
            level: 0,
            eval_level: inputs.eval_level,
            mode: (settings.integration == Integration::Brute) as u32,
            bound: inputs.bound,
            refine_ratio: settings.refine_ratio,
            min_cos_view: settings.min_cos_view,
            max_normal_spread: settings.max_normal_spread,
            max_thickness: settings.max_thickness,
            texels_per_radius: settings.texels_per_radius,
            scale_fraction: settings.scale_fraction,
            generation: 0,
            from_list: 0,
            refine_excess: settings.refine_excess,
            layers: 1,
            build_layer: 0,
        }
    }

    fn pyramid_bindings(frame: &SsbcFrame) -> [Binding<'_>; 3] {
        [
            Binding::StorageBuffer(&frame.geo),
            Binding::StorageBuffer(&frame.aux),
            Binding::StorageBuffer(&frame.radiance),
        ]
    }

    /// The pyramids for the kernels that only read them (geo and radiance as
    /// texels), declared with [`Self::read_pyramids`].
    fn pyramid_read_bindings(frame: &SsbcFrame) -> [Binding<'_>; 3] {
        [
            Binding::UniformTexelBuffer(&frame.geo_texels),
            Binding::StorageBuffer(&frame.aux),
            Binding::UniformTexelBuffer(&frame.radiance_texels),
        ]
    }

    /// Records the geometry pyramids and every step: `visible` is layer 0
    /// (its G-buffer and `S0 = T Le + T_b L^`, where the residual is
    /// written), `hidden` the optional second layer (at the frame's
    /// [`SsbcFrame::layer1`] resolution), whose surfaces are sources too.
    #[allow(clippy::too_many_arguments)]
    pub fn record_steps(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        visible: SsbcLayer<'_>,
        hidden: Option<SsbcLayer<'_>>,
        inputs: &SsbcInputs<'_>,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let extent = visible.gbuffer.extent();
        let hidden = hidden.filter(|_| frame.layer1.is_some());
        let mut push = self.push(inputs, extent, frame);
        if let (Some(_), Some(r)) = (hidden, frame.layer1) {
            push.layers = 2 | r.shift() << 4;
        }

        let scope = profiler.begin(rec.cmd, "ssbc_geometry_mips");
        for (layer, source) in std::iter::once(visible).chain(hidden).enumerate() {
            self.record_geometry(rec, pool, source.gbuffer, layer as u32, &mut push, frame)?;
        }
        push.build_layer = 0;
        // Evaluation points are stamped with the step's generation (1, 2, ...).
        rec.fill_buffer(&frame.points, 0);
        profiler.end(rec.cmd, scope);

        let steps = inputs.settings.steps as usize;
        for step in 0..steps {
            let previous = if step == 0 {
                visible.s0
            } else {
                &frame.final_image
            };
            let term = if step == 0 {
                visible.s0
            } else {
                &frame.residuals[step - 1]
            };
            push.generation = step as u32 + 1;
            let name = format!("ssbc_step_{}", step + 1);
            let scope = profiler.begin(rec.cmd, &name);
            let sub = profiler.begin(rec.cmd, &format!("{name}/radiance_mips"));
            self.record_radiance_mips(rec, pool, term, 0, &mut push, frame)?;
            if let Some(hidden) = hidden {
                let term = if step == 0 {
                    hidden.s0
                } else {
                    &frame.layer1_residuals[step - 1]
                };
                self.record_radiance_mips(rec, pool, term, 1, &mut push, frame)?;
            }
            push.build_layer = 0;
            profiler.end(rec.cmd, sub);
            let step_out = StepOutput {
                gbuffer: visible.gbuffer,
                previous,
                final_image: &frame.final_image,
                residual: &frame.residuals[step],
                samples: &frame.samples[step],
            };
            self.record_residual(rec, profiler, &name, pool, &step_out, &mut push, frame)?;
            rec.copy_buffer(&frame.fallback, 0, &frame.stats, 16 * step as u64, 16);
            if let (Some(hidden), true) = (hidden, step + 1 < steps) {
                let sub = profiler.begin(rec.cmd, &format!("{name}/layer1_residual"));
                self.record_layer1_residual(rec, pool, hidden.gbuffer, step, &push, frame)?;
                profiler.end(rec.cmd, sub);
            }
            profiler.end(rec.cmd, scope);
        }
        Ok(())
    }

    /// The geometry pyramid of layer `layer` from its G-buffer.
    fn record_geometry(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        gbuffer: SsbcGBuffer<'_>,
        layer: u32,
        push: &mut SsbcPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        push.build_layer = layer;
        for level in 0..frame.levels - Self::layer_shift(frame, layer) {
            if level == 0 {
                rec.use_image(gbuffer.position, Access::ComputeRead);
                rec.use_image(gbuffer.normal, Access::ComputeRead);
            }
            rec.use_buffer(&frame.geo, Access::ComputeWrite);
            rec.use_buffer(&frame.aux, Access::ComputeWrite);
            rec.use_buffer(&frame.radiance, Access::ComputeRead);
            rec.flush_barriers();
            push.level = level;
            let g_buffer = [
                Binding::storage(gbuffer.position),
                Binding::storage(gbuffer.normal),
            ];
            let (kernel, own) = if level == 0 {
                (&self.geometry_base, &g_buffer[..])
            } else {
                (&self.geometry, &[][..])
            };
            let bindings = [&Self::pyramid_bindings(frame)[..], own].concat();
            kernel.dispatch_2d(
                rec.cmd,
                pool,
                &bindings,
                bytemuck::bytes_of(push),
                Self::level_extent(frame, layer, level),
            )?;
        }
        Ok(())
    }

    /// Layer 1's residual of step `step` (its sources in the next step).
    fn record_layer1_residual(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        gbuffer: SsbcGBuffer<'_>,
        step: usize,
        push: &SsbcPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let out = &frame.layer1_residuals[step];
        Self::read_pyramids(rec, frame);
        gbuffer.read_in_compute(rec);
        rec.use_image(out, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = [
            &Self::pyramid_read_bindings(frame)[..],
            &gbuffer.storage_bindings()[..],
            &[Binding::storage(out)],
        ]
        .concat();
        self.layer_residual.dispatch_2d(
            rec.cmd,
            pool,
            &bindings,
            bytemuck::bytes_of(push),
            gbuffer.extent(),
        )
    }

    /// log2 of layer `layer`'s pixel side in image pixels.
    fn layer_shift(frame: &SsbcFrame, layer: u32) -> u32 {
        match (layer, frame.layer1) {
            (1, Some(r)) => r.shift(),
            _ => 0,
        }
    }

    /// Texels of level `level` of layer `layer`'s pyramid (at half
    /// resolution half the size).
    fn level_extent(frame: &SsbcFrame, layer: u32, level: u32) -> (u32, u32) {
        let shift = level + Self::layer_shift(frame, layer);
        (frame.pyramid_size.0 >> shift, frame.pyramid_size.1 >> shift)
    }

    fn record_radiance_mips(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        term: &Image,
        layer: u32,
        push: &mut SsbcPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        push.build_layer = layer;
        for level in 0..frame.levels - Self::layer_shift(frame, layer) {
            rec.use_image(term, Access::ComputeRead);
            rec.use_buffer(&frame.geo, Access::ComputeRead);
            rec.use_buffer(&frame.aux, Access::ComputeRead);
            rec.use_buffer(&frame.radiance, Access::ComputeWrite);
            rec.flush_barriers();
            push.level = level;
            let bindings = [
                &Self::pyramid_bindings(frame)[..],
                &[Binding::storage(term)],
            ]
            .concat();
            self.radiance.dispatch_2d(
                rec.cmd,
                pool,
                &bindings,
                bytemuck::bytes_of(push),
                Self::level_extent(frame, layer, level),
            )?;
        }
        Ok(())
    }

    fn read_pyramids(rec: &mut Recorder<'_>, frame: &SsbcFrame) {
        rec.use_buffer(&frame.geo, Access::ComputeSampled);
        rec.use_buffer(&frame.aux, Access::ComputeRead);
        rec.use_buffer(&frame.radiance, Access::ComputeSampled);
    }

    /// One step's residual, coarse to fine: the evaluation points of the
    /// coarsest level; every pixel interpolates them or asks for finer ones
    /// and waits for the next level; at level 1 what is left is evaluated
    /// pixel by pixel (the fallback list). Then the samples image.
    #[allow(clippy::too_many_arguments)]
    fn record_residual(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        step_name: &str,
        pool: &DescriptorPool,
        out: &StepOutput<'_>,
        push: &mut SsbcPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let pixels = out.gbuffer.extent();
        let top = push.eval_level;
        // The coarsest level: every texel is an evaluation point, every pixel
        // tries to interpolate.
        push.level = top;
        push.from_list = 0;
        let (w, h) = Self::level_extent(frame, 0, top);
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/eval_{top}"));
        self.record_eval(rec, pool, push, frame, [w.div_ceil(64), h, 1])?;
        profiler.end(rec.cmd, sub);
        let mut pending_in = &frame.fallback; // unused while from_list == 0
        let mut pending_out = if top >= 2 {
            &frame.pending[0]
        } else {
            &frame.fallback
        };
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{top}"));
        self.record_resolve(
            rec,
            pool,
            push,
            frame,
            out,
            (pending_in, pending_out),
            Some([pixels.0.div_ceil(64), pixels.1, 1]),
        )?;
        profiler.end(rec.cmd, sub);
        // Finer levels: the points asked for, the pixels still pending.
        push.from_list = 1;
        for level in (1..top).rev() {
            push.level = level;
            let sub = profiler.begin(rec.cmd, &format!("{step_name}/eval_{level}"));
            self.record_eval(rec, pool, push, frame, [0; 3])?;
            profiler.end(rec.cmd, sub);
            pending_in = pending_out;
            pending_out = if level == 1 {
                &frame.fallback
            } else if std::ptr::eq(pending_in, &frame.pending[0]) {
                &frame.pending[1]
            } else {
                &frame.pending[0]
            };
            let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{level}"));
            self.record_resolve(rec, pool, push, frame, out, (pending_in, pending_out), None)?;
            profiler.end(rec.cmd, sub);
        }
        // The pixels no point could stand for.
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/fallback"));
        Self::read_pyramids(rec, frame);
        out.declare(rec);
        rec.use_buffer(&frame.points, Access::ComputeRead);
        rec.use_buffer(&frame.points, Access::ComputeSampled);
        rec.use_buffer(&frame.requests, Access::ComputeRead);
        rec.use_buffer(&frame.fallback, Access::IndirectRead);
        rec.use_buffer(&frame.fallback, Access::ComputeRead);
        rec.flush_barriers();
        // The fallback list is read as pending_in; nothing is written to the
        // other lists.
        let bindings = out.bindings(frame, (&frame.fallback, &frame.requests));
        self.fallback.dispatch_indirect(
            rec.cmd,
            pool,
            &bindings,
            bytemuck::bytes_of(push),
            &frame.fallback,
            0,
        )?;
        profiler.end(rec.cmd, sub);
        // Texels read per pixel.
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/samples"));
        Self::read_pyramids(rec, frame);
        rec.use_buffer(&frame.points, Access::ComputeSampled);
        rec.use_image(out.samples, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = [
            &Self::pyramid_read_bindings(frame)[..],
            &[
                Binding::UniformTexelBuffer(&frame.point_texels),
                Binding::storage(out.samples),
            ],
        ]
        .concat();
        self.samples
            .dispatch_2d(rec.cmd, pool, &bindings, bytemuck::bytes_of(push), pixels)?;
        profiler.end(rec.cmd, sub);
        Ok(())
    }

    /// Evaluation points of `push.level`: every texel (`push.from_list` 0,
    /// `groups` work groups) or the requested ones (indirect).
    fn record_eval(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        push: &SsbcPush,
        frame: &SsbcFrame,
        groups: [u32; 3],
    ) -> Result<()> {
        Self::read_pyramids(rec, frame);
        rec.use_buffer(&frame.points, Access::ComputeWrite);
        if push.from_list == 1 {
            rec.use_buffer(&frame.requests, Access::IndirectRead);
        }
        rec.use_buffer(&frame.requests, Access::ComputeRead);
        rec.flush_barriers();
        let bindings = [
            &Self::pyramid_read_bindings(frame)[..],
            &[
                Binding::StorageBuffer(&frame.points),
                Binding::StorageBuffer(&frame.requests),
            ],
        ]
        .concat();
        let push_bytes = bytemuck::bytes_of(push);
        if push.from_list == 1 {
            self.eval
                .dispatch_indirect(rec.cmd, pool, &bindings, push_bytes, &frame.requests, 0)
        } else {
            self.eval
                .dispatch(rec.cmd, pool, &bindings, push_bytes, groups)
        }
    }

    /// Resolve at `push.level`: pixels of `lists.0` (or every pixel, with
    /// `groups`) interpolate or go on `lists.1`, asking for finer points.
    #[allow(clippy::too_many_arguments)]
    fn record_resolve(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        push: &SsbcPush,
        frame: &SsbcFrame,
        out: &StepOutput<'_>,
        lists: (&Buffer, &Buffer),
        groups: Option<[u32; 3]>,
    ) -> Result<()> {
        let (pending_in, pending_out) = lists;
        rec.update_buffer(pending_out, 0, bytemuck::bytes_of(&LIST_HEADER));
        rec.update_buffer(&frame.requests, 0, bytemuck::bytes_of(&LIST_HEADER));
        Self::read_pyramids(rec, frame);
        out.declare(rec);
        // Points of this level are read as texels, those of the next finer
        // level stamped through the storage binding.
        rec.use_buffer(&frame.points, Access::ComputeWrite);
        rec.use_buffer(&frame.points, Access::ComputeSampled);
        if groups.is_none() {
            rec.use_buffer(pending_in, Access::IndirectRead);
        }
        // Bound (and so, for synchronization, read) even when unused.
        rec.use_buffer(pending_in, Access::ComputeRead);
        rec.use_buffer(pending_out, Access::ComputeWrite);
        rec.use_buffer(&frame.requests, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = out.bindings(frame, lists);
        let push_bytes = bytemuck::bytes_of(push);
        match groups {
            Some(groups) => self
                .resolve
                .dispatch(rec.cmd, pool, &bindings, push_bytes, groups),
            None => self
                .resolve
                .dispatch_indirect(rec.cmd, pool, &bindings, push_bytes, pending_in, 0),
        }
    }
}

/// The G-buffer images SSBC reads, ssbc's own or a host's: world-space
/// position (xyz; w = 0 where there is no geometry), unit normal (xyz) and
/// diffuse albedo (rgb), each `R32G32B32A32_SFLOAT` with storage usage.
#[derive(Clone, Copy)]
pub struct SsbcGBuffer<'a> {
    /// World-space position.
    pub position: &'a Image,
    /// Shading normal.
    pub normal: &'a Image,
    /// Diffuse albedo.
    pub albedo: &'a Image,
}

impl<'a> From<&'a GBuffer> for SsbcGBuffer<'a> {
    fn from(g: &'a GBuffer) -> Self {
        Self {
            position: &g.position,
            normal: &g.normal,
            albedo: &g.albedo,
        }
    }
}

impl SsbcGBuffer<'_> {
    fn targets(&self) -> [&Image; 3] {
        [self.position, self.normal, self.albedo]
    }

    fn read_in_compute(&self, rec: &mut Recorder<'_>) {
        for target in self.targets() {
            rec.use_image(target, Access::ComputeRead);
        }
    }

    fn storage_bindings(&self) -> [Binding<'_>; 3] {
        self.targets().map(Binding::storage)
    }

    /// Width and height.
    pub fn extent(&self) -> (u32, u32) {
        (self.position.desc.width, self.position.desc.height)
    }
}

/// One G-buffer layer SSBC gathers from: its G-buffer and its `S0`.
#[derive(Clone, Copy)]
pub struct SsbcLayer<'a> {
    /// Position, normal, albedo.
    pub gbuffer: SsbcGBuffer<'a>,
    /// `S0 = T Le + T_b L^` at its pixels.
    pub s0: &'a Image,
}

/// What a step writes, and what it reads from the frame besides the pyramids.
struct StepOutput<'a> {
    gbuffer: SsbcGBuffer<'a>,
    /// `S0 + ... + S_{k-1}` (the final image itself after the first step).
    previous: &'a Image,
    final_image: &'a Image,
    residual: &'a Image,
    samples: &'a Image,
}

impl StepOutput<'_> {
    /// Declares the images of ssbc_output.glsl.
    fn declare(&self, rec: &mut Recorder<'_>) {
        self.gbuffer.read_in_compute(rec);
        // After the first step `previous` is the final image itself (read and
        // written by the same invocation).
        if !std::ptr::eq(self.previous, self.final_image) {
            rec.use_image(self.previous, Access::ComputeRead);
        }
        rec.use_image(self.final_image, Access::ComputeWrite);
        rec.use_image(self.residual, Access::ComputeWrite);
        rec.use_image(self.samples, Access::ComputeWrite);
    }

    /// Every binding of ssbc_output.glsl (after the pyramids') for the
    /// pending lists `lists` (in, out).
    fn bindings<'b>(
        &'b self,
        frame: &'b SsbcFrame,
        lists: (&'b Buffer, &'b Buffer),
    ) -> Vec<Binding<'b>> {
        let [position, normal, albedo] = self.gbuffer.storage_bindings();
        [
            &SsbcPass::pyramid_read_bindings(frame)[..],
            &[
                Binding::StorageBuffer(&frame.points),
                Binding::StorageBuffer(lists.0),
                Binding::StorageBuffer(lists.1),
                Binding::StorageBuffer(&frame.requests),
                position,
                normal,
                albedo,
                Binding::storage(self.previous),
                Binding::storage(self.final_image),
                Binding::storage(self.residual),
                Binding::storage(self.samples),
                Binding::UniformTexelBuffer(&frame.point_texels),
            ],
        ]
        .concat()
    }
}

impl Pass for SsbcPass {
    const NAME: &'static str = "ssbc";
    /// (width, height, steps, coarsest evaluation level, second layer).
    type Key = (u32, u32, u32, u32, Option<LayerResolution>);
    type Resources = SsbcFrame;
    /// The visible layer and, with `layers` 2, the hidden one.
    type Reads<'a> = (SsbcLayer<'a>, Option<SsbcLayer<'a>>);

    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key {
        let (w, h) = setup.extent();
        let ssbc = &setup.settings.ssbc;
        (w, h, ssbc.steps, ssbc.max_eval_level, ssbc.second_layer())
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<SsbcFrame> {
        let ssbc = &setup.settings.ssbc;
        self.allocate(
            setup.device,
            setup.extent(),
            ssbc.steps,
            ssbc.max_eval_level,
            ssbc.second_layer(),
        )
    }

    fn set_layouts(&self, frame: &SsbcFrame) -> Vec<&DescriptorSetLayout> {
        self.frame_layouts(frame)
    }

    /// The geometry pyramid and the K steps (nothing with 0 steps).
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (visible, hidden): (SsbcLayer<'_>, Option<SsbcLayer<'_>>),
        frame: &SsbcFrame,
    ) -> Result<()> {
        let settings = &cx.settings.ssbc;
        if settings.steps == 0 {
            return Ok(());
        }
        let view = cx.view;
        let inputs = SsbcInputs {
            camera: &view.camera,
            bound: view.bound,
            eval_level: Self::eval_level(
                &view.camera,
                view.centre_depth,
                view.bound,
                frame.levels(),
                settings,
            ),
            settings,
        };
        self.record_steps(cx.rec, cx.profiler, pool, visible, hidden, &inputs, frame)
    }
}
