//! The SSBC pyramids' layout: levels, their sizes, where each layer's pyramid
//! starts, the sizes of their texels and lists, what a frame's resources
//! take and what a size needs of the device.

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::{Error, Result};
use crate::settings::{LayerResolution, SsbcSettings};
use crate::vk::{buffer_bytes, Device, ImageDesc, Planned, Tenant};

/// Sizes of the GLSL structs, in bytes.
/// `ListHeader` (ssbc_types.glsl).
pub(super) const LIST_HEADER_BYTES: u64 = 48;
/// `GeoTexel` in memory: two clusters' positions and extents, their
/// normals and cones packed (`pack_normals` in ssbc_types.glsl).
pub(super) const GEO_TEXEL_BYTES: u64 = 48;
/// A level-0 texel (a pixel) in memory: its geometry and aux in one word
/// ("Level 0" in ssbc_types.glsl; its position is the G-buffer's); it has
/// no `GeoAux` texel.
pub(super) const LEVEL0_TEXEL_BYTES: u64 = 16;
pub(super) const AUX_BYTES: u64 = 16;
/// A texel's two radiance sums, packed (`pack_radiance` in ssbc_types.glsl);
/// at level 0 its front sum only, two texels in one (`radiance_texel` in
/// ssbc_pyramid.glsl).
pub(super) const RADIANCE_BYTES: u64 = 16;
/// An evaluation point's linear form (`EvalPoint` in ssbc_types.glsl:
/// three texels)...
pub(super) const EVAL_POINT_BYTES: u64 = 48;
/// ...and its tail: texels read, variation scale, generation
/// (`pack_point_tail`).
pub(super) const POINT_TAIL_BYTES: u64 = 8;
/// An evaluation point's glossy rest (`pack_point_rest` in ssbc_types.glsl).
pub(super) const POINT_GLOSSY_BYTES: u64 = 8;

/// Level 0 of the pyramids for an image (the image: nothing is padded) and
/// the number of levels.
pub(super) fn pyramid_layout(width: u32, height: u32) -> ((u32, u32), u32) {
    ((width, height), pyramid_levels(width, height))
}

/// Pyramid levels for an image: down to about 2 texels on the short side.
pub fn pyramid_levels(width: u32, height: u32) -> u32 {
    (31 - width.min(height).max(1).leading_zeros()).clamp(1, 12)
}

/// Texels of level `level` of a pyramid whose level 0 is `size`:
/// ceil(size / 2^level) (`level_size_of` in ssbc_types.glsl).
pub(super) fn level_size((w, h): (u32, u32), level: u32) -> (u32, u32) {
    (
        ((w.max(1) - 1) >> level) + 1,
        ((h.max(1) - 1) >> level) + 1,
    )
}

/// Texels of all `levels` levels of a pyramid whose level 0 is `size`
/// (`level_start` in ssbc_pyramid.glsl).
pub(super) fn pyramid_texels(size: (u32, u32), levels: u32) -> u64 {
    (0..levels)
        .map(|l| {
            let (w, h) = level_size(size, l);
            w as u64 * h as u64
        })
        .sum()
}

/// Texels of layer 0's pyramid and, with a second layer, layer 1's after it
/// (at half resolution layer 0's levels from level 1 on: `pyramid_of` in
/// ssbc_pyramid.glsl).
pub(super) fn all_layers_texels(
    size: (u32, u32),
    levels: u32,
    layer1: Option<LayerResolution>,
) -> u64 {
    let first = pyramid_texels(size, levels);
    match layer1 {
        None => first,
        Some(r) => {
            let shift = r.shift();
            first + pyramid_texels(level_size(size, shift), levels - shift)
        }
    }
}

/// Level-0 texels of layer 0's pyramid and of layer 1's, if any (stored
/// more compactly: [`LEVEL0_TEXEL_BYTES`]; `level0_texels_before` in
/// ssbc_pyramid.glsl).
pub(super) fn level0_texels(size: (u32, u32), layer1: Option<LayerResolution>) -> u64 {
    let texels = |(w, h): (u32, u32)| w as u64 * h as u64;
    texels(size) + layer1.map_or(0, |r| texels(level_size(size, r.shift())))
}

/// Texels of the radiance buffer: one a texel, two level-0 texels of a
/// layer in one.
pub(super) fn radiance_texels(
    size: (u32, u32),
    all_texels: u64,
    layer1: Option<LayerResolution>,
) -> u64 {
    let texels = |(w, h): (u32, u32)| w as u64 * h as u64;
    let halved = |n: u64| n - n.div_ceil(2);
    all_texels - halved(texels(size)) - layer1.map_or(0, |r| halved(texels(level_size(size, r.shift()))))
}

/// Bytes of the geometry buffer: every texel's `GeoTexel`, a level-0
/// texel's two words instead.
pub(super) fn geo_bytes(all_texels: u64, level0: u64) -> u64 {
    all_texels * GEO_TEXEL_BYTES - level0 * (GEO_TEXEL_BYTES - LEVEL0_TEXEL_BYTES)
}

/// The second layer a pyramid of `levels` levels can hold: at half
/// resolution it needs a level to spare (images of at least 2 pixels on the
/// short side).
pub(super) fn effective_layer1(
    layer1: Option<LayerResolution>,
    levels: u32,
) -> Option<LayerResolution> {
    layer1.filter(|r| levels > r.shift())
}

/// Where a frame's final image `S0 + S_1 + ... + S_K` is summed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FinalImage {
    /// Into S0's own image, in place (the renderer's frames, where nothing
    /// reads S0 after SSBC: a step adds its residual to it pixel by pixel).
    InS0,
    /// Into an image of its own (the post-process, whose S0 is the host's).
    Own,
}

/// What a frame slot's SSBC keeps beyond what its steps read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Kept {
    /// Where the final image is summed.
    pub final_image: FinalImage,
    /// Each step's residual `S_k` in an image of its own (the `residual_k`
    /// output layers); without, a step writes only what it sends to the
    /// next (`NO_RESIDUAL`).
    pub residuals: bool,
    /// The evaluation points' glossy rests (receivers may be glossy);
    /// without, one texel, never read.
    pub glossy_rests: bool,
}

/// A buffer of a frame slot: its size, usage and memory.
#[derive(Clone, Copy, Debug)]
pub(super) struct BufferPlan {
    pub bytes: u64,
    pub usage: vk::BufferUsageFlags,
    pub location: MemoryLocation,
}

/// What one frame slot's SSBC resources are, before any exists: what
/// [`super::SsbcPass::allocate`] creates and what the estimates count.
#[derive(Clone, Debug)]
pub(super) struct FramePlan {
    pub pyramid_size: (u32, u32),
    pub levels: u32,
    pub layer1: Option<LayerResolution>,
    pub steps: u32,
    pub kept: Kept,
    /// The pyramids (every layer's), as texel buffers.
    pub geo: BufferPlan,
    pub aux: BufferPlan,
    pub radiance: BufferPlan,
    /// Layer 0's evaluation points, their tails, glossy rests and claims.
    pub points: BufferPlan,
    pub point_tails: BufferPlan,
    pub point_glossy: BufferPlan,
    pub claims: BufferPlan,
    /// Each of the two lists of pixels (pending, in turn; the last is the
    /// fallback list)...
    pub pixel_list: BufferPlan,
    /// ...and of the two of evaluation points (requests, the coarsest
    /// level's points; at level 1 and up).
    pub point_list: BufferPlan,
    /// The fallback lists' headers, read back.
    pub stats: BufferPlan,
    /// Each kept residual, what each step but the last sends and an own
    /// final image.
    pub radiance_image: ImageDesc,
    /// Per step, the texels read per pixel.
    pub samples_image: ImageDesc,
    /// Per step but the last, layer 1's residual.
    pub layer1_image: Option<ImageDesc>,
}

/// The work lists of pixels and of points there are in a frame slot.
const PIXEL_LISTS: u64 = 2;
const POINT_LISTS: u64 = 2;

impl FramePlan {
    pub fn new(
        extent: (u32, u32),
        steps: u32,
        layer1: Option<LayerResolution>,
        kept: Kept,
    ) -> Self {
        let (pyramid_size, levels) = pyramid_layout(extent.0, extent.1);
        let layer1 = effective_layer1(layer1, levels);
        // Evaluation points exist for layer 0's levels 1 and up only
        // (`point_index` in ssbc_pyramid.glsl; at least one, for a binding).
        let level0 = pyramid_size.0 as u64 * pyramid_size.1 as u64;
        let points = (pyramid_texels(pyramid_size, levels) - level0).max(1);
        let all_texels = all_layers_texels(pyramid_size, levels, layer1);
        let level0 = level0_texels(pyramid_size, layer1);
        let gpu = |bytes, usage| BufferPlan {
            bytes,
            usage,
            location: MemoryLocation::GpuOnly,
        };
        let texel_usage =
            vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER | vk::BufferUsageFlags::STORAGE_TEXEL_BUFFER;
        let cleared = texel_usage | vk::BufferUsageFlags::TRANSFER_DST;
        let list = |items: u64| BufferPlan {
            bytes: LIST_HEADER_BYTES + 4 * items,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::INDIRECT_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            location: MemoryLocation::GpuOnly,
        };
        let image = |format, (w, h): (u32, u32)| {
            let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
            ImageDesc::new_2d(format, w, h, usage)
        };
        Self {
            pyramid_size,
            levels,
            layer1,
            steps,
            kept,
            geo: gpu(geo_bytes(all_texels, level0), texel_usage),
            aux: gpu((all_texels - level0).max(1) * AUX_BYTES, texel_usage),
            radiance: gpu(
                radiance_texels(pyramid_size, all_texels, layer1) * RADIANCE_BYTES,
                texel_usage,
            ),
            points: gpu(points * EVAL_POINT_BYTES, cleared),
            point_tails: gpu(points * POINT_TAIL_BYTES, cleared),
            point_glossy: gpu(
                if kept.glossy_rests { points } else { 1 } * POINT_GLOSSY_BYTES,
                cleared,
            ),
            claims: gpu(
                points * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
            ),
            pixel_list: list(level0),
            point_list: list({
                let (w, h) = level_size(pyramid_size, 1);
                w as u64 * h as u64
            }),
            stats: BufferPlan {
                bytes: LIST_HEADER_BYTES * steps.max(1) as u64,
                usage: vk::BufferUsageFlags::TRANSFER_DST,
                location: MemoryLocation::GpuToCpu,
            },
            radiance_image: image(vk::Format::R32G32B32A32_SFLOAT, extent),
            samples_image: image(vk::Format::R32_SFLOAT, extent),
            layer1_image: layer1.map(|r| image(vk::Format::R32G32B32A32_SFLOAT, r.extent(extent))),
        }
    }

    /// Bytes of device memory the plan takes, as (pyramids and evaluation
    /// points, lists, images): on `device`, what its memory requirements
    /// say (alignment and padding included); without one, the bytes asked
    /// for.
    pub fn memory(&self, device: Option<&Device>) -> SsbcMemory {
        let buffer = |b: &BufferPlan| buffer_bytes(device, b.bytes, b.usage);
        let image = |i: &ImageDesc| i.bytes(device);
        let steps = self.steps as u64;
        let work_lists =
            PIXEL_LISTS * buffer(&self.pixel_list) + POINT_LISTS * buffer(&self.point_list);
        // Each kept residual, each step but the last's sources, an own
        // final image.
        let own = (self.kept.final_image == FinalImage::Own) as u64;
        let residuals = if self.kept.residuals { steps } else { 0 };
        let radiance_images = residuals + steps.saturating_sub(1) + own;
        let images = radiance_images * image(&self.radiance_image)
            + steps * image(&self.samples_image)
            + self
                .layer1_image
                .as_ref()
                .map_or(0, |i| steps.saturating_sub(1) * image(i));
        let pyramids = self.pyramids().iter().map(|b| buffer(b)).sum();
        SsbcMemory {
            pyramids,
            work_lists,
            stats: buffer(&self.stats),
            images,
        }
    }

    /// The pyramids and evaluation points, in the order they are made.
    pub fn pyramids(&self) -> [&BufferPlan; 7] {
        [
            &self.geo,
            &self.aux,
            &self.radiance,
            &self.points,
            &self.point_tails,
            &self.point_glossy,
            &self.claims,
        ]
    }

    /// What lives only while the steps run, in the order it is made: the
    /// pyramids and evaluation points, then the work lists (two of pixels,
    /// the requests and the coarsest level's points). The statistics
    /// buffer, which the host reads after the frame, is not among them.
    pub fn transient(&self) -> [&BufferPlan; 11] {
        let [geo, aux, radiance, points, tails, glossy, claims] = self.pyramids();
        let (pixels, points_list) = (&self.pixel_list, &self.point_list);
        [geo, aux, radiance, points, tails, glossy, claims, pixels, pixels, points_list, points_list]
    }
}

/// Bytes of device memory of one frame slot's SSBC resources, by kind.
#[derive(Clone, Copy, Debug)]
pub struct SsbcMemory {
    /// The pyramids, the evaluation points, their tails, glossy rests and
    /// claims.
    pub pyramids: u64,
    /// The lists of pixels and of points (in a slot's transient memory
    /// with the pyramids, `transient_resources`).
    pub work_lists: u64,
    /// The fallback lists' headers, read back after the frame (kept).
    pub stats: u64,
    /// The per-step images.
    pub images: u64,
}

impl SsbcMemory {
    /// All of it.
    pub fn total(&self) -> u64 {
        self.pyramids + self.work_lists + self.stats + self.images
    }
}

/// What SSBC places in a frame slot's transient memory
/// (`passes::transient`), in the order [`super::SsbcPass::allocate`] makes
/// them: the pyramids, the evaluation points, their glossy rests and
/// claims, the work lists (`FramePlan::transient`).
pub fn transient_resources(
    extent: (u32, u32),
    (steps, layer1): (u32, Option<LayerResolution>),
    kept: Kept,
) -> Tenant {
    FramePlan::new(extent, steps, layer1, kept)
        .transient()
        .iter()
        .map(|b| Planned::Buffer {
            bytes: b.bytes,
            usage: b.usage,
        })
        .collect()
}

/// Bytes of device memory one frame slot's SSBC resources take at `extent`
/// with `steps` steps, by kind: on `device` as its memory requirements
/// say, without one as asked for.
pub fn frame_memory(
    device: Option<&Device>,
    extent: (u32, u32),
    (steps, layer1): (u32, Option<LayerResolution>),
    kept: Kept,
) -> SsbcMemory {
    FramePlan::new(extent, steps, layer1, kept).memory(device)
}

/// [`frame_memory`] in all.
pub fn frame_bytes(
    device: Option<&Device>,
    extent: (u32, u32),
    (steps, layer1): (u32, Option<LayerResolution>),
    kept: Kept,
) -> u64 {
    frame_memory(device, extent, (steps, layer1), kept).total()
}

/// Largest image the SSBC lists can address: an item packs a pixel's x in
/// 16 bits and its y in 15, the top bit marking a fallback pixel whose
/// points stood for its Lambertian part (`REST_ONLY` in ssbc_types.glsl).
const MAX_LIST_SIZE: (u32, u32) = (1 << 16, 1 << 15);

fn check_list_coordinates(width: u32, height: u32) -> Result<()> {
    if width <= MAX_LIST_SIZE.0 && height <= MAX_LIST_SIZE.1 {
        return Ok(());
    }
    Err(Error::InvalidParameter(format!(
        "SSBC at {width}x{height}: its lists address at most {}x{} pixels; render smaller \
         or with ssbc.steps 0",
        MAX_LIST_SIZE.0, MAX_LIST_SIZE.1
    )))
}

/// Fails with a clear message if SSBC's largest texel view (the geometry
/// pyramid, three texels per texel of every pyramid, two at level 0) or work list exceeds
/// what the device can view or bind (maxTexelBufferElements, 2^27 texels on
/// lavapipe; maxStorageBufferRange for the lists, 128 MiB there).
/// Or if the image is larger than the lists can address.
pub fn check_size(
    device: &Device,
    width: u32,
    height: u32,
    layer1: Option<LayerResolution>,
) -> Result<()> {
    check_list_coordinates(width, height)?;
    let (size, levels) = pyramid_layout(width, height);
    let layer1 = effective_layer1(layer1, levels);
    let texels = geo_bytes(all_layers_texels(size, levels, layer1), level0_texels(size, layer1)) / 16;
    let limits = device.limits();
    let max_texels = limits.max_texel_buffer_elements as u64;
    let list_bytes = LIST_HEADER_BYTES + 4 * size.0 as u64 * size.1 as u64;
    let max_range = limits.max_storage_buffer_range as u64;
    if texels <= max_texels && list_bytes <= max_range {
        return Ok(());
    }
    Err(Error::InvalidParameter(format!(
        "SSBC at {width}x{height} needs texel views of {texels} texels and lists of {} MiB; \
         this device views at most {max_texels} texels (maxTexelBufferElements) and binds \
         {} MiB (maxStorageBufferRange): render smaller{} or with ssbc.steps 0",
        list_bytes >> 20,
        max_range >> 20,
        SsbcSettings::lighter_second_layer(layer1)
    )))
}

#[cfg(test)]
mod tests {
    use super::check_list_coordinates;

    #[test]
    fn lists_refuse_images_their_items_cannot_address() {
        assert!(check_list_coordinates(65536, 32768).is_ok());
        assert!(check_list_coordinates(40000, 1).is_ok());
        assert!(check_list_coordinates(1, 32769).is_err());
        assert!(check_list_coordinates(65537, 1).is_err());
    }
}
