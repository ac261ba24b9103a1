//! Screen-space bias compensation: K steps of residual transport
//! `S_k = T_r S_{k-1}` over the screen, hierarchically (Nichols et al. 2009
//! style top-down integration over mip chains) or by brute force.
//!
//! Per frame: the geometry pyramid (area-weighted position and normal, summed
//! area `A_y`, discontinuity flag) is built once (`pyramids.rs`); each step
//! (`step.rs`) builds the radiance pyramid of the previous term, integrates
//! the residual, and adds it to the final image. Each kernel has its own
//! push block (`push.rs`) and takes its bindings by the names its shader
//! gives them (`crate::shaders::<kernel>::Bindings`).

mod push;
mod pyramids;
mod step;

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::gbuffer::GBuffer;
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
pub use crate::settings::{Integration, LayerResolution, SsbcSettings};
use crate::shaders::{
    ssbc_eval_comp, ssbc_fallback_comp, ssbc_geometry_base_comp, ssbc_geometry_mips_comp,
    ssbc_layer_residual_comp, ssbc_radiance_mips_comp, ssbc_resolve_comp, ssbc_samples_comp,
};
use crate::vk::{
    Access, Buffer, BufferView, ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image,
    Recorder,
};
pub use pyramids::{check_size, frame_bytes, pyramid_levels};
use pyramids::{all_layers_texels, effective_layer1, pyramid_layout, pyramid_texels};
use push::{
    EvalPush, GeometryBasePush, GeometryMipsPush, IntegralPush, RadiancePush, ResolvePush,
    SamplesPush,
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

/// The SSBC pipelines, one per kernel.
pub struct SsbcPass {
    geometry_base: ComputeKernel<ssbc_geometry_base_comp::Interface, GeometryBasePush>,
    geometry: ComputeKernel<ssbc_geometry_mips_comp::Interface, GeometryMipsPush>,
    radiance: ComputeKernel<ssbc_radiance_mips_comp::Interface, RadiancePush>,
    eval: ComputeKernel<ssbc_eval_comp::Interface, EvalPush>,
    resolve: ComputeKernel<ssbc_resolve_comp::Interface, ResolvePush>,
    fallback: ComputeKernel<ssbc_fallback_comp::Interface, IntegralPush>,
    samples: ComputeKernel<ssbc_samples_comp::Interface, SamplesPush>,
    layer_residual: ComputeKernel<ssbc_layer_residual_comp::Interface, IntegralPush>,
}

/// One frame's SSBC resources. The pyramids and the evaluation points are
/// read and written through texel views (their size is then capped by
/// maxTexelBufferElements, 2^27 texels on lavapipe, not by the 128 MiB of
/// maxStorageBufferRange). Views are declared before their buffers so that
/// they are dropped first.
pub struct SsbcFrame {
    /// `geo` as `R32G32B32A32_UINT` texels (four per `GeoTexel`).
    geo_view: BufferView,
    /// `aux` as `R32G32B32A32_UINT` texels (one per `GeoAux`).
    aux_view: BufferView,
    /// `radiance` as `R32G32B32A32_SFLOAT` texels (two per texel).
    radiance_view: BufferView,
    /// `points` as `R32G32B32A32_UINT` texels (four per `EvalPoint`).
    point_view: BufferView,
    /// Geometry pyramid, every level in one buffer (`GeoTexel` in ssbc_types.glsl).
    pub geo: Buffer,
    /// Summed area, pixel count and continuity per texel (`GeoAux`).
    pub aux: Buffer,
    /// Sum of `A_y S_{k-1}(y)` per texel.
    pub radiance: Buffer,
    /// Evaluation points, one per texel of every level (`EvalPoint`).
    pub points: Buffer,
    /// Per evaluation point, the generation of the step that last asked for
    /// it (the resolve claims each point once per step).
    pub claims: Buffer,
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

/// Sizes of the GLSL structs, in bytes.
const GEO_TEXEL_BYTES: u64 = 64;
const AUX_BYTES: u64 = 16;
const RADIANCE_BYTES: u64 = 32;
const EVAL_POINT_BYTES: u64 = 64;

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
        Ok(Self {
            // Level 0 of the geometry pyramid, from the G-buffer position and
            // normal; its own kernel because lavapipe ran it 3x slower inside
            // the coarser levels' (45 -> 14 ms at 1024x768).
            geometry_base: ComputeKernel::new(device)?.named("ssbc_geometry_base"),
            geometry: ComputeKernel::new(device)?.named("ssbc_geometry_mips"),
            radiance: ComputeKernel::new(device)?.named("ssbc_radiance_mips"),
            eval: ComputeKernel::new(device)?.named("ssbc_residual_eval"),
            resolve: ComputeKernel::new(device)?.named("ssbc_residual_resolve"),
            fallback: ComputeKernel::new(device)?.named("ssbc_residual_fallback"),
            samples: ComputeKernel::new(device)?.named("ssbc_samples"),
            layer_residual: ComputeKernel::new(device)?.named("ssbc_layer1_residual"),
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
        let texel_buffer = |name: &str, size: u64, extra: vk::BufferUsageFlags| {
            Buffer::new(
                device,
                name,
                size,
                vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER
                    | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER
                    | extra,
                MemoryLocation::GpuOnly,
            )
        };
        let list_bytes = 16 + 4 * pyramid_size.0 as u64 * pyramid_size.1 as u64;
        let list = |name: &str| {
            Buffer::new(
                device,
                name,
                list_bytes,
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::INDIRECT_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_DST
                    | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
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
        let none = vk::BufferUsageFlags::empty();
        let geo = texel_buffer("ssbc.pyramid.geometry", all_texels * GEO_TEXEL_BYTES, none)?;
        let aux = texel_buffer("ssbc.pyramid.aux", all_texels * AUX_BYTES, none)?;
        let radiance = texel_buffer("ssbc.pyramid.radiance", all_texels * RADIANCE_BYTES, none)?;
        let points = texel_buffer(
            "ssbc.eval_points",
            texels * EVAL_POINT_BYTES,
            vk::BufferUsageFlags::TRANSFER_DST,
        )?;
        let claims = Buffer::new(
            device,
            "ssbc.eval_points.claims",
            texels * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
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
        let view = |buffer: &Buffer, format, bytes, name: &str| {
            BufferView::new(device, buffer, format, bytes, name)
        };
        let (uint4, float4) = (
            vk::Format::R32G32B32A32_UINT,
            vk::Format::R32G32B32A32_SFLOAT,
        );
        Ok(SsbcFrame {
            geo_view: view(&geo, uint4, 16, "ssbc.pyramid.geometry texels")?,
            aux_view: view(&aux, uint4, 16, "ssbc.pyramid.aux texels")?,
            radiance_view: view(&radiance, float4, 16, "ssbc.pyramid.radiance texels")?,
            point_view: view(&points, uint4, 16, "ssbc.eval_points texels")?,
            geo,
            aux,
            radiance,
            points,
            claims,
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

    /// Declares the pyramids as read through their texel views.
    fn read_pyramids(rec: &mut Recorder<'_>, frame: &SsbcFrame) {
        rec.use_buffer(&frame.geo, Access::ComputeSampled);
        rec.use_buffer(&frame.aux, Access::ComputeSampled);
        rec.use_buffer(&frame.radiance, Access::ComputeSampled);
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
