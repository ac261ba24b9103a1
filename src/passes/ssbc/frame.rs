//! One frame slot's SSBC resources: the geometry and radiance pyramids
//! (texel buffers), the evaluation points, the lists of pixels evaluated
//! alone, each step's residual and the final image.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::layout::{
    all_layers_texels, effective_layer1, pyramid_layout, pyramid_texels, AUX_BYTES,
    EVAL_POINT_BYTES, GEO_TEXEL_BYTES, LIST_HEADER_BYTES, POINT_GLOSSY_BYTES, RADIANCE_BYTES,
};
use super::SsbcPass;
use crate::error::Result;
use crate::settings::LayerResolution;
use crate::vk::{Buffer, BufferView, Device, Image};

/// One frame's SSBC resources. The pyramids and the evaluation points are
/// read and written through texel views (their size is then capped by
/// maxTexelBufferElements, 2^27 texels on lavapipe, not by the 128 MiB of
/// maxStorageBufferRange).
pub struct SsbcFrame {
    /// Geometry pyramid, every level in one buffer (`GeoTexel` in
    /// ssbc_types.glsl), as `R32G32B32A32_UINT` texels (four per texel).
    pub geo: BufferView,
    /// Summed area, pixel count and continuity per texel (`GeoAux`), as
    /// `R32G32B32A32_UINT` texels.
    pub aux: BufferView,
    /// Sum of `A_y S_{k-1}(y)` per texel, as `R32G32B32A32_SFLOAT` texels
    /// (two per texel).
    pub radiance: BufferView,
    /// Evaluation points, one per texel of every level (`EvalPoint`), as
    /// `R32G32B32A32_UINT` texels (four per point).
    pub points: BufferView,
    /// Per evaluation point at a glossy receiver, the glossy rest of its
    /// BRDF (ssbc_eval.comp), as `R32G32B32A32_SFLOAT` texels.
    pub point_glossy: BufferView,
    /// Per evaluation point, the generation of the step that last asked for
    /// it (the resolve claims each point once per step).
    pub claims: Buffer,
    /// Pixels still to resolve at the next finer level (two, used in turn).
    pub pending: [Buffer; 2],
    /// In frames with glossy receivers, the coarsest level's evaluation
    /// points as a two-ended list (glossy receivers at the back), made once
    /// per frame.
    pub top_points: Buffer,
    /// Texels whose evaluation points the next level needs.
    pub requests: Buffer,
    /// Pixels evaluated alone.
    pub fallback: Buffer,
    /// Per step, the fallback list's header (dispatch x, y, z, pixel count),
    /// for the host.
    pub stats: Buffer,
    /// `residual_k` for k = 1..=K.
    pub residuals: Vec<Image>,
    /// What the pixels send as sources of the next step, view-independent
    /// (brdf_source_color; the same as `residuals` on Lambertian
    /// receivers).
    pub residual_sources: Vec<Image>,
    /// Texels read per pixel of each step (r32f: a pixel's own reads plus its
    /// share of the evaluation points whose blocks it is in).
    pub samples: Vec<Image>,
    /// `S0 + residual_1 + ... + residual_K`.
    pub final_image: Image,
    /// With a second layer: its `residual_k` for k = 1..K-1 (at its
    /// resolution), the next step's sources there.
    pub layer1_residuals: Vec<Image>,
    /// The second layer's resolution, if the pyramids hold one.
    pub(super) layer1: Option<LayerResolution>,
    pub(super) levels: u32,
    pub(super) pyramid_size: (u32, u32),
    /// The coarsest evaluation level the descriptor sets are counted for.
    pub(super) max_eval_level: u32,
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
        // Each a copy of the fallback list's header: its front and back counts.
        Ok(words.chunks_exact(12).map(|h| h[3] + h[7]).collect())
    }
}

impl SsbcPass {
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
        let list_bytes = LIST_HEADER_BYTES + 4 * pyramid_size.0 as u64 * pyramid_size.1 as u64;
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
            crate::passes::storage_image(device, &name, format, extent, vk::ImageUsageFlags::empty())
        };
        let residuals = (1..=steps)
            .map(|k| {
                image(
                    format!("ssbc.residual_{k}"),
                    vk::Format::R32G32B32A32_SFLOAT,
                )
            })
            .collect::<Result<_>>()?;
        let residual_sources = (1..=steps)
            .map(|k| {
                image(
                    format!("ssbc.residual_sources_{k}"),
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
        let point_glossy = texel_buffer(
            "ssbc.eval_points.glossy",
            texels * POINT_GLOSSY_BYTES,
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
                    crate::passes::radiance_image(device, &name, r.extent(extent))
                })
                .collect::<Result<_>>()?,
            None => Vec::new(),
        };
        let view = |buffer: Buffer, format, bytes, name: &str| {
            BufferView::new(device, buffer, format, bytes, name)
        };
        let (uint4, float4) = (
            vk::Format::R32G32B32A32_UINT,
            vk::Format::R32G32B32A32_SFLOAT,
        );
        Ok(SsbcFrame {
            geo: view(geo, uint4, 16, "ssbc.pyramid.geometry texels")?,
            aux: view(aux, uint4, 16, "ssbc.pyramid.aux texels")?,
            radiance: view(radiance, float4, 16, "ssbc.pyramid.radiance texels")?,
            points: view(points, uint4, 16, "ssbc.eval_points texels")?,
            point_glossy: view(point_glossy, float4, 16, "ssbc.eval_points.glossy texels")?,
            claims,
            pending: [list("ssbc.pending_a")?, list("ssbc.pending_b")?],
            requests: list("ssbc.requests")?,
            top_points: list("ssbc.top_points")?,
            fallback: list("ssbc.fallback")?,
            stats: Buffer::new(
                device,
                "ssbc.stats",
                LIST_HEADER_BYTES * steps.max(1) as u64,
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
            residuals,
            residual_sources,
            samples,
            final_image: image("ssbc.final".into(), vk::Format::R32G32B32A32_SFLOAT)?,
            layer1_residuals,
            layer1,
            levels,
            pyramid_size,
            max_eval_level: max_eval_level.min(levels - 1),
        })
    }
}
