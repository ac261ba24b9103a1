//! One frame slot's SSBC resources: the geometry and radiance pyramids
//! (texel buffers), the evaluation points, the lists of pixels evaluated
//! alone, each step's residual and the final image.

use std::sync::Arc;

use ash::vk;

use super::layout::{BufferPlan, FinalImage, FramePlan, Kept};
use super::SsbcPass;
use crate::error::Result;
use crate::settings::LayerResolution;
use crate::vk::{AliasRegion, Buffer, BufferView, Device, Image, ImageDesc};

/// One frame's SSBC resources. The pyramids and the evaluation points are
/// read and written through texel views (their size is then capped by
/// maxTexelBufferElements, 2^27 texels on lavapipe, not by the 128 MiB of
/// maxStorageBufferRange).
pub struct SsbcFrame {
    /// Geometry pyramid, every level in one buffer (`GeoTexel` in
    /// ssbc_types.glsl), as `R32G32B32A32_UINT` texels (three per texel).
    pub geo: BufferView,
    /// Summed area, pixel count and continuity per texel (`GeoAux`), as
    /// `R32G32B32A32_UINT` texels.
    pub aux: BufferView,
    /// Sum of `A_y S_{k-1}(y)` per texel, as `R32G32B32A32_SFLOAT` texels
    /// (two per texel).
    pub radiance: BufferView,
    /// Evaluation points, one per texel of layer 0's levels 1 and up
    /// (`EvalPoint`, `point_index` in ssbc_pyramid.glsl), as
    /// `R32G32B32A32_UINT` texels (three per point).
    pub points: BufferView,
    /// Per evaluation point, its texels read, variation scale and
    /// generation (`pack_point_tail`), as `R32G32_UINT` texels.
    pub point_tails: BufferView,
    /// Per evaluation point at a glossy receiver, the glossy rest of its
    /// BRDF (ssbc_eval.comp; `pack_point_rest`), as `R32G32_UINT` texels.
    pub point_glossy: BufferView,
    /// Per evaluation point, the generation of the step that last asked for
    /// it (the resolve claims each point once per step).
    pub claims: Buffer,
    /// Pixels still to resolve at the next finer level (two, used in
    /// turn); level 1's resolve leaves in one the pixels evaluated alone
    /// (the fallback list).
    pub pending: [Buffer; 2],
    /// In frames with glossy receivers, the coarsest level's evaluation
    /// points as a two-ended list (glossy receivers at the back), made once
    /// per frame.
    pub top_points: Buffer,
    /// Texels whose evaluation points the next level needs.
    pub requests: Buffer,
    /// Per step, the fallback list's header (dispatch x, y, z, pixel count),
    /// for the host.
    pub stats: Buffer,
    /// `residual_k` for k = 1..=K, where kept ([`Kept::residuals`]; else
    /// none).
    pub residuals: Vec<Image>,
    /// What the pixels send as sources of the next step, view-independent
    /// (brdf_source_color; the same as `residuals` on Lambertian
    /// receivers), for every step but the last.
    pub residual_sources: Vec<Image>,
    /// Texels read per pixel of each step (r32f: a pixel's own reads plus its
    /// share of the evaluation points whose blocks it is in).
    pub samples: Vec<Image>,
    /// `S0 + residual_1 + ... + residual_K` in an image of its own
    /// ([`FinalImage::Own`]; None: summed into S0's).
    pub final_image: Option<Image>,
    /// With a second layer: its `residual_k` for k = 1..K-1 (at its
    /// resolution), the next step's sources there.
    pub layer1_residuals: Vec<Image>,
    /// The second layer's resolution, if the pyramids hold one.
    pub(super) layer1: Option<LayerResolution>,
    pub(super) steps: u32,
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

    /// SSBC steps the frame is made for.
    pub fn steps(&self) -> u32 {
        self.steps
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
    /// down ([`SsbcPass::frame_layouts`]). The pyramids and evaluation
    /// points go to `transient` (a frame slot's transient memory) where
    /// given.
    #[allow(clippy::too_many_arguments)]
    pub fn allocate(
        &self,
        device: &Arc<Device>,
        extent: (u32, u32),
        steps: u32,
        max_eval_level: u32,
        layer1: Option<LayerResolution>,
        kept: Kept,
        mut transient: Option<AliasRegion>,
    ) -> Result<SsbcFrame> {
        let plan = FramePlan::new(extent, steps, layer1, kept);
        let buffer = |name: &str, b: &BufferPlan| Buffer::new(device, name, b.bytes, b.usage, b.location);
        let mut in_phase = |name: &str, b: &BufferPlan| match transient.as_mut() {
            Some(region) => Buffer::new_aliased(device, name, b.bytes, b.usage, region),
            None => buffer(name, b),
        };
        let image = |name: String, desc: &ImageDesc| Image::new(device, &name, *desc);
        let per_step = |name: &str, desc: &ImageDesc| {
            (1..=steps)
                .map(|k| image(format!("{name}_{k}"), desc))
                .collect::<Result<Vec<_>>>()
        };
        let residuals = match kept.residuals {
            true => per_step("ssbc.residual", &plan.radiance_image)?,
            false => Vec::new(),
        };
        // What each step but the last sends to the next.
        let residual_sources = (1..steps)
            .map(|k| image(format!("ssbc.residual_sources_{k}"), &plan.radiance_image))
            .collect::<Result<Vec<_>>>()?;
        let samples = per_step("ssbc.samples", &plan.samples_image)?;
        // In the order of `FramePlan::transient` (the transient plan's).
        let geo = in_phase("ssbc.pyramid.geometry", &plan.geo)?;
        let aux = in_phase("ssbc.pyramid.aux", &plan.aux)?;
        let radiance = in_phase("ssbc.pyramid.radiance", &plan.radiance)?;
        let points = in_phase("ssbc.eval_points", &plan.points)?;
        let point_tails = in_phase("ssbc.eval_points.tails", &plan.point_tails)?;
        let point_glossy = in_phase("ssbc.eval_points.glossy", &plan.point_glossy)?;
        let claims = in_phase("ssbc.eval_points.claims", &plan.claims)?;
        let pending = [
            in_phase("ssbc.pending_a", &plan.pixel_list)?,
            in_phase("ssbc.pending_b", &plan.pixel_list)?,
        ];
        let requests = in_phase("ssbc.requests", &plan.point_list)?;
        let top_points = in_phase("ssbc.top_points", &plan.point_list)?;
        let layer1_residuals = match &plan.layer1_image {
            Some(desc) => (1..steps)
                .map(|k| image(format!("ssbc.layer1_residual_{k}"), desc))
                .collect::<Result<_>>()?,
            None => Vec::new(),
        };
        let view = |buffer: Buffer, format, bytes, name: &str| {
            BufferView::new(device, buffer, format, bytes, name)
        };
        let (uint4, uint2) = (vk::Format::R32G32B32A32_UINT, vk::Format::R32G32_UINT);
        Ok(SsbcFrame {
            geo: view(geo, uint4, 16, "ssbc.pyramid.geometry texels")?,
            aux: view(aux, uint4, 16, "ssbc.pyramid.aux texels")?,
            radiance: view(radiance, uint4, 16, "ssbc.pyramid.radiance texels")?,
            points: view(points, uint4, 16, "ssbc.eval_points texels")?,
            point_tails: view(point_tails, uint2, 8, "ssbc.eval_points.tails texels")?,
            point_glossy: view(point_glossy, uint2, 8, "ssbc.eval_points.glossy texels")?,
            claims,
            pending,
            requests,
            top_points,
            stats: buffer("ssbc.stats", &plan.stats)?,
            residuals,
            residual_sources,
            samples,
            final_image: match kept.final_image {
                FinalImage::Own => Some(image("ssbc.final".into(), &plan.radiance_image)?),
                FinalImage::InS0 => None,
            },
            layer1_residuals,
            layer1: plan.layer1,
            steps,
            levels: plan.levels,
            pyramid_size: plan.pyramid_size,
            max_eval_level: max_eval_level.min(plan.levels - 1),
        })
    }
}
