//! Bounded VPL lighting `T_b L^` (clamped geometry term, ISM visibility), and
//! `S0 = T Le + T_b L^`, the term the SSBC steps start from.
//!
//! Interleaved (the default, [`Gather::Interleaved`]; Keller & Heidrich
//! 2001, Segovia et al. 2006), three kernels:
//! - `indirect_interleaved`: each pixel of an N x N block evaluates one of
//!   N² random subsets of the VPLs, dispatched de-interleaved so that a work
//!   group shares one subset;
//! - `indirect_filter`: a depth- and normal-aware filter sums the subsets
//!   back on each pixel's own surface, and lists the pixels beside creases
//!   and contacts;
//! - `indirect_creases`: those pixels evaluate every VPL (there the light
//!   changes within a pixel).
//!
//! The full gather (`indirect_bounded`) evaluates every VPL at every pixel:
//! the reference.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::direct_lighting::DirectLight;
use super::gbuffer::GBuffer;
use super::ssbc::{SsbcGBuffer, SsbcLayer};
use super::ism::Ism;
use super::{FrameView, Pass, Recording, SlotSetup};
use crate::cpu::bvh::length_floor;
use crate::error::Result;
use crate::layer::Layer;
use crate::settings::{Gather, Visibility};
use crate::shaders::{
    indirect_bounded_back_comp, indirect_bounded_comp, indirect_bounded_exact_comp,
    indirect_creases_back_comp, indirect_creases_comp, indirect_creases_exact_comp,
    indirect_filter_comp, indirect_filter_exact_comp, indirect_interleaved_back_comp,
    indirect_interleaved_comp, indirect_interleaved_exact_comp,
};
use crate::shaders::blocks::{FilterPush, GatherPush};
use crate::vk::{
    AccelerationStructure, AliasRegion, Buffer, ComputeKernel, DescriptorPool,
    DescriptorSetLayout, Device, Image, ImageDesc, Planned, Tenant, Work,
};

/// The interleaved gather's sums (the diffuse and glossy parts, packed):
/// one texel a pixel (interleaved_sums.glsl).
fn packed_desc(extent: (u32, u32)) -> ImageDesc {
    let usage = vk::ImageUsageFlags::empty();
    super::storage_desc(vk::Format::R32G32B32A32_UINT, extent, usage)
}

/// The crease list: a dispatch header, then a pixel per word.
fn creases_bytes(extent: (u32, u32)) -> u64 {
    16 + 4 * extent.0 as u64 * extent.1 as u64
}

const CREASES_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
    vk::BufferUsageFlags::STORAGE_BUFFER.as_raw()
        | vk::BufferUsageFlags::INDIRECT_BUFFER.as_raw()
        | vk::BufferUsageFlags::TRANSFER_DST.as_raw(),
);

/// What the interleaved gather hands its filter at `extent` (nothing for
/// the full gather), in the order [`IndirectBoundedPass`] makes it: the
/// subsets' sums and the crease list (the filter reads the G-buffer's
/// position and normal for its surface tests). It
/// lives in the frame slot's transient memory (`passes::transient`).
pub(crate) fn transient_resources(extent: (u32, u32), gather: Gather) -> Tenant {
    match gather {
        Gather::Full => Vec::new(),
        Gather::Interleaved => vec![
            Planned::Image(packed_desc(extent)),
            Planned::Buffer {
                bytes: creases_bytes(extent),
                usage: CREASES_USAGE,
            },
        ],
    }
}

/// Bytes of device memory a layer's bounded lighting takes at `extent` with
/// `gather` (on `device` as its memory requirements say): S0 (its sources
/// are added in place to the direct light's; the `indirect_bounded` layer
/// is made from it on request) and, interleaved, the intermediates
/// ([`transient_resources`]) unless they live in the slot's `transient`
/// memory.
pub(crate) fn memory_bytes(
    device: Option<&Device>,
    extent: (u32, u32),
    gather: Gather,
    transient: bool,
) -> u64 {
    let s0 = super::radiance_desc(extent).bytes(device);
    if transient {
        return s0;
    }
    let intermediates = transient_resources(extent, gather).into_iter().map(|r| match r {
        Planned::Image(desc) => desc.bytes(device),
        Planned::Buffer { bytes, usage } => crate::vk::buffer_bytes(device, bytes, usage),
    });
    s0 + intermediates.sum::<u64>()
}

/// Relative depth tolerance of the ISM visibility test: trades false
/// shadows against leaks. Since every ISM texel holds its surface along
/// its centre ray (shaders/include/ism_splat.glsl), 0.08 passed more of the
/// visible light and let through less of the occluded than 0.16 did
/// before, at the same mean; with tiles by projected solid angle, whose
/// texels are finer where a VPL sends most light, 0.05 lets a sixth less
/// through thin walls (measured: docs/accuracy.md, "Tuned constants").
pub const ISM_BIAS: f32 = 0.05;

/// [`ISM_BIAS`] for traced ISM texels ([`Visibility::Traced`]): each texel
/// holds its surface's exact distance and plane along its centre ray, so
/// less tolerance is needed; 0.04 leaks less through thin walls than 0.08
/// for 0.1% of the visible light (measured: docs/accuracy.md, "ISM texels
/// traced").
pub const ISM_BIAS_TRACED: f32 = 0.04;

/// The relative depth tolerance of the ISM test for atlases made as
/// `visibility` makes them.
pub fn ism_bias(visibility: Visibility) -> f32 {
    match visibility {
        Visibility::Traced => ISM_BIAS_TRACED,
        _ => ISM_BIAS,
    }
}

/// How the ISM test treats a receiver (`ism_visible` in
/// shaders/include/vpl_gather.glsl; [`ism_test_for`] picks it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IsmTest {
    /// The relative depth tolerance (a fraction of the distance).
    pub relative_bias: f32,
    /// Whether the receiver passes only where, lifted off its surface by
    /// 0.75 of a footprint, it passes too: what stands on the receiver's
    /// surface between the texel's centre ray and the receiver (a plinth on
    /// a floor), or where a hole in that occluder's splats lets the
    /// receiver through, then shadows it.
    pub lifted: bool,
}

/// The ISM test at a receiver of BRDF `brdf` in an atlas whose relative
/// tolerance is `relative_bias` ([`ism_bias`]): that, or for a
/// narrow glossy lobe (GGX alpha under 0.25) that times 4 alpha, at least
/// a quarter of it, and the lifted test. A tolerance of 0.16 x the
/// distance (the default before 2026-11-29) let an occluder near the
/// receiver through (a plinth 0.5 m in front of a floor point 3 m from the
/// VPL), and the slope term let through the plinth's foot; a diffuse
/// receiver blurs such a leak over its hemisphere, a narrow lobe shows it
/// as a bright reflection where the occluder should be (measured:
/// docs/accuracy.md, "Tuned constants" and "The lifted ISM test").
/// `shaders/include/vpl_gather.glsl` is the twin.
pub fn ism_test_for(brdf: &crate::cpu::brdf::Brdf, relative_bias: f32) -> IsmTest {
    if brdf.is_lambertian() {
        IsmTest {
            relative_bias,
            lifted: false,
        }
    } else {
        IsmTest {
            relative_bias: relative_bias * (4.0 * brdf.alpha()).clamp(0.25, 1.0),
            lifted: brdf.alpha() < 0.25,
        }
    }
}

/// Surface tests of the reconstruction filter: a neighbour is on the
/// pixel's surface if it lies within `FILTER_PLANE_SLOPE` x its distance of
/// the pixel's tangent plane and its normal within acos(`FILTER_NORMAL_COS`)
/// of the pixel's: against the pixel's own normal, since irradiance
/// follows the normal on a curved surface (measured: docs/accuracy.md, "Tuned constants").
pub const FILTER_PLANE_SLOPE: f32 = 0.1;
/// See [`FILTER_PLANE_SLOPE`].
pub const FILTER_NORMAL_COS: f32 = 0.9;
/// A pixel is beside a crease or contact, and evaluates every VPL itself,
/// if one of its 8 neighbours is on another surface within this many of
/// its footprints in space (its distance to its nearest neighbour on its
/// own surface, per pixel of offset). Far behind (a silhouette) does not
/// count: there the filter's box turns to the pixel's own side.
pub const CREASE_FOOTPRINTS: f32 = 4.0;

/// A glossy receiver whose lobe's axis (the view's mirror direction) turns
/// across the filter's window by more than this many times its GGX alpha
/// evaluates every VPL in the interleaved gather (the crease kernel), as
/// pixels beside creases do: averaging neighbours whose lobes point
/// elsewhere smeared VPL highlights over the box.
pub const GLOSSY_FILTER_TURN: f32 = 4.0;

/// Dispatches with a kernel's ISM or exact twin: the same bindings but for
/// what visibility reads (the twins' `ism` atlas, or `scene_tlas`); the
/// exact kernel is looked up only when used. Kernels that read the atlas
/// have a third twin for atlases with back-face maps (`back`: whether it
/// has them, the kernel, made on first use).
macro_rules! with_visibility {
    ($visibility:expr, (ism: $atlas:expr, $ism:expr, $ism_mod:ident),
     (back: $back_on:expr, $back:expr, $back_mod:ident), ($exact:expr, $exact_mod:ident),
     { $($field:ident $(: $value:expr)?),* $(,)? }, |$kernel:ident, $bindings:ident| $dispatch:expr) => {
        match $visibility {
            VplVisibility::Ism if $back_on => {
                let ($kernel, $bindings) = ($back, $back_mod::Bindings { ism: $atlas, $($field $(: $value)?),* });
                $dispatch
            }
            VplVisibility::Ism => {
                let ($kernel, $bindings) = (&$ism, $ism_mod::Bindings { ism: $atlas, $($field $(: $value)?),* });
                $dispatch
            }
            VplVisibility::Exact(scene_tlas) => {
                let ($kernel, $bindings) = ($exact, $exact_mod::Bindings { scene_tlas, $($field $(: $value)?),* });
                $dispatch
            }
        }
    };
    ($visibility:expr, ($ism:expr, $ism_mod:ident), ($exact:expr, $exact_mod:ident),
     { $($field:ident $(: $value:expr)?),* $(,)? }, |$kernel:ident, $bindings:ident| $dispatch:expr) => {
        match $visibility {
            VplVisibility::Ism => {
                let ($kernel, $bindings) = (&$ism, $ism_mod::Bindings { $($field $(: $value)?),* });
                $dispatch
            }
            VplVisibility::Exact(scene_tlas) => {
                let ($kernel, $bindings) = ($exact, $exact_mod::Bindings { scene_tlas, $($field $(: $value)?),* });
                $dispatch
            }
        }
    };
}

/// What the gathers read: the G-buffer, the direct light, the VPLs (with
/// their ISM atlas) and how visibility is tested.
pub type Reads<'a> = (&'a GBuffer, &'a DirectLight, &'a Ism, VplVisibility<'a>);

/// A list's header: `VkDispatchIndirectCommand` and the item count.
const LIST_HEADER: [u32; 4] = [0, 1, 1, 0];

/// What the pass writes.
pub struct BoundedLighting {
    /// `S0 = T Le + T_b L^`, what the SSBC steps start from (and sum
    /// their residuals into: the final image), in an image of its own
    /// where the direct light's is not S0 ([`DirectLight::is_s0`]).
    pub own_s0: Option<Image>,
    /// The interleaved gather's intermediate images (None: full gather).
    pub interleaved: Option<Interleaved>,
}

impl BoundedLighting {
    /// S0: its own image, or the direct light's (summed in place).
    pub fn s0<'a>(&'a self, direct: &'a DirectLight) -> &'a Image {
        self.own_s0.as_ref().unwrap_or(&direct.radiance)
    }

    /// The layer as SSBC gathers from it, with `gbuffer` and the direct
    /// light's sources, to which the pass added its own (their w holds the
    /// geometric normals, read only if the scene has `normal_maps`).
    pub fn ssbc_layer<'a>(
        &'a self,
        gbuffer: &'a GBuffer,
        direct: &'a DirectLight,
        normal_maps: bool,
    ) -> SsbcLayer<'a> {
        let mut gbuffer: SsbcGBuffer<'a> = gbuffer.into();
        gbuffer.geometric = normal_maps.then_some(&direct.sources);
        SsbcLayer {
            gbuffer,
            s0: self.s0(direct),
            sources: &direct.sources,
        }
    }
}

/// What the interleaved gather hands its filter.
pub struct Interleaved {
    /// N² x each pixel's own subset's sum, packed (`pack_sums` in
    /// interleaved_sums.glsl): its diffuse part per unit diffuse colour, the glossy
    /// rest (zero on Lambertian receivers) and its lobe's widening.
    pub sums: Image,
    /// The pixels beside a crease or contact (dispatch header, count, then
    /// one `x | y << 16` per pixel), which evaluate every VPL.
    pub creases: Buffer,
}

impl Interleaved {
    /// The intermediates at `extent`, named by `name`: in `region` of the
    /// slot's transient memory (as [`transient_resources`] plans them), or
    /// each in memory of its own.
    fn new(
        device: &Arc<Device>,
        extent: (u32, u32),
        name: &dyn Fn(&str) -> String,
        mut region: Option<AliasRegion>,
    ) -> Result<Self> {
        let mut image = |base: &str, desc: ImageDesc| match region.as_mut() {
            Some(r) => Image::new_aliased(device, &name(base), desc, r),
            None => Image::new(device, &name(base), desc),
        };
        let sums = image("lighting.interleaved", packed_desc(extent))?;
        let (bytes, creases) = (creases_bytes(extent), name("lighting.creases"));
        let creases = match region.as_mut() {
            Some(r) => Buffer::new_aliased(device, &creases, bytes, CREASES_USAGE, r)?,
            None => Buffer::new(device, &creases, bytes, CREASES_USAGE, MemoryLocation::GpuOnly)?,
        };
        Ok(Self { sums, creases })
    }
}

/// The gathers, the reconstruction filter and the crease kernel, for one
/// G-buffer layer.
pub struct IndirectBoundedPass {
    full: ComputeKernel<indirect_bounded_comp::Interface>,
    interleaved: ComputeKernel<indirect_interleaved_comp::Interface>,
    filter: ComputeKernel<indirect_filter_comp::Interface>,
    creases: ComputeKernel<indirect_creases_comp::Interface>,
    /// The gathers with exact visibility, where the device has ray queries.
    exact: Option<ExactGathers>,
    /// The gathers for ISMs with back-face maps, made on first use (most
    /// renderers never ask for them).
    back: std::sync::OnceLock<BackFaceGathers>,
    layer: u32,
}

/// The gathers' twins that also test an atlas's back-face maps
/// ([`RenderSettings::ism_back_faces`](crate::RenderSettings::ism_back_faces));
/// the filter is the ISM one. Their bindings are the ISM twins', whose
/// layouts size the frame's descriptor pool.
struct BackFaceGathers {
    full: ComputeKernel<indirect_bounded_back_comp::Interface>,
    interleaved: ComputeKernel<indirect_interleaved_back_comp::Interface>,
    creases: ComputeKernel<indirect_creases_back_comp::Interface>,
}

/// The gathers' twins that test visibility with ray queries.
struct ExactGathers {
    full: ComputeKernel<indirect_bounded_exact_comp::Interface>,
    interleaved: ComputeKernel<indirect_interleaved_exact_comp::Interface>,
    /// The filter, which also checks that nothing separates a pixel from
    /// the neighbours it averages (a wall thinner than its surface tests).
    filter: ComputeKernel<indirect_filter_exact_comp::Interface>,
    creases: ComputeKernel<indirect_creases_exact_comp::Interface>,
}

/// How the gathers test whether a VPL sees a receiver: its imperfect
/// shadow map, or a ray query against the frame slot's top-level
/// acceleration structure.
#[derive(Clone, Copy)]
pub enum VplVisibility<'a> {
    /// The ISM atlas.
    Ism,
    /// Ray queries against this structure.
    Exact(&'a AccelerationStructure),
}

/// The gathers' push block (`count`: the VPL count, or the pattern side N
/// for the interleaved gather).
fn gather_push(gbuffer: &GBuffer, ism: &Ism, view: &FrameView, count: u32) -> GatherPush {
        let (w, h) = gbuffer.extent();
        GatherPush {
            size: [w, h],
            count,
            tile: ism.tile,
            tiles_per_row: ism.tiles_per_row,
            far: ism.far,
            bound: view.bound,
            ism_bias: ism.relative_bias,
            point_radius: ism.point_radius,
            camera_position: view.camera.position.extend(length_floor(view.diagonal)).into(),
            ..Default::default()
        }
}

impl IndirectBoundedPass {
    /// Creates the kernels for G-buffer layer `layer` (0: the visible
    /// surfaces; 1: the deep G-buffer's second layer).
    pub fn new(device: &Arc<Device>, layer: u32) -> Result<Self> {
        Ok(Self {
            full: ComputeKernel::new(device)?,
            interleaved: ComputeKernel::new(device)?,
            filter: ComputeKernel::new(device)?,
            creases: ComputeKernel::new(device)?,
            exact: match device.ray_queries() {
                Some(_) => Some(ExactGathers {
                    full: ComputeKernel::new(device)?,
                    interleaved: ComputeKernel::new(device)?,
                    filter: ComputeKernel::new(device)?,
                    creases: ComputeKernel::new(device)?,
                }),
                None => None,
            },
            back: std::sync::OnceLock::new(),
            layer,
        })
    }

    /// The gathers for atlases with back-face maps, made the first time a
    /// frame asks for them.
    fn back(&self, device: &Arc<Device>) -> Result<&BackFaceGathers> {
        if let Some(back) = self.back.get() {
            return Ok(back);
        }
        let made = BackFaceGathers {
            full: ComputeKernel::new(device)?,
            interleaved: ComputeKernel::new(device)?,
            creases: ComputeKernel::new(device)?,
        };
        Ok(self.back.get_or_init(|| made))
    }

    /// The exact gathers, or an error naming why there are none.
    fn exact(&self) -> Result<&ExactGathers> {
        self.exact.as_ref().ok_or_else(|| {
            crate::Error::InvalidParameter(
                "exact visibility needs ray queries, which this device lacks".into(),
            )
        })
    }

    /// The full gather: every VPL at every pixel, writing the layers.
    fn record_full(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, direct, ism, visibility): Reads<'_>,
        out: &BoundedLighting,
    ) -> Result<()> {
        let Recording { rec, view, .. } = cx;
        let push = gather_push(gbuffer, ism, view, ism.vpl_count);
        let pixels = Work::pixels(gbuffer.extent());
        with_visibility!(
            visibility,
            (ism: &ism.atlas, self.full, indirect_bounded_comp),
            (back: ism.back_faces, &self.back(rec.device)?.full, indirect_bounded_back_comp),
            (&self.exact()?.full, indirect_bounded_exact_comp),
            {
                g_position: &gbuffer.position,
                g_normal: &gbuffer.normal,
                g_albedo: &gbuffer.albedo,
                direct: &direct.radiance,
                direct_sources: &direct.sources,
                s0: out.s0(direct),
                s0_sources: &direct.sources,
                vpl_texels: &ism.vpls,
                g_emission: &gbuffer.emission,
            },
            |kernel, bindings| kernel.dispatch(rec, pool, &bindings, &push, pixels)
        )
    }

    /// Each pixel's own subset's sum.
    fn record_interleaved(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, ism, visibility): (&GBuffer, &Ism, VplVisibility<'_>),
        interleaved: &Interleaved,
    ) -> Result<()> {
        let Recording { rec, view, .. } = cx;
        let side = ism.subset_count.isqrt();
        let push = gather_push(gbuffer, ism, view, side);
        // One work group: pixels of one subset (z), N pixels apart.
        let (w, h) = gbuffer.extent();
        let subsets = Work::Threads([w.div_ceil(side), h.div_ceil(side), side * side]);
        with_visibility!(
            visibility,
            (ism: &ism.atlas, self.interleaved, indirect_interleaved_comp),
            (back: ism.back_faces, &self.back(rec.device)?.interleaved, indirect_interleaved_back_comp),
            (&self.exact()?.interleaved, indirect_interleaved_exact_comp),
            {
                g_position: &gbuffer.position,
                g_normal: &gbuffer.normal,
                g_albedo: &gbuffer.albedo,
                vpl_texels: &ism.vpls,
                subsets: &ism.subsets,
                interleaved: &interleaved.sums,
                g_emission: &gbuffer.emission,
            },
            |kernel, bindings| kernel.dispatch(rec, pool, &bindings, &push, subsets)
        )
    }

    /// Sums the subsets back on each surface, then the albedo and S0; lists
    /// the pixels beside creases.
    fn record_filter(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, direct, side, visibility): (&GBuffer, &DirectLight, u32, VplVisibility<'_>),
        interleaved: &Interleaved,
        out: &BoundedLighting,
    ) -> Result<()> {
        let rec = &mut *cx.rec;
        rec.update_buffer(&interleaved.creases, 0, bytemuck::bytes_of(&LIST_HEADER));
        let (w, h) = gbuffer.extent();
        let push = FilterPush {
            size: [w, h],
            side: side as i32,
            min_normal_cos: FILTER_NORMAL_COS,
            max_plane_slope: FILTER_PLANE_SLOPE,
            crease_footprints: CREASE_FOOTPRINTS,
            lobe_turn: GLOSSY_FILTER_TURN,
            camera_position: cx.view.camera.position.extend(length_floor(cx.view.diagonal)).into(),
            ..Default::default()
        };
        with_visibility!(
            visibility,
            (self.filter, indirect_filter_comp),
            (&self.exact()?.filter, indirect_filter_exact_comp),
            {
                g_position: &gbuffer.position,
                g_albedo: &gbuffer.albedo,
                direct: &direct.radiance,
                direct_sources: &direct.sources,
                direct_lights: &direct.lights,
                interleaved: &interleaved.sums,
                s0: out.s0(direct),
                s0_sources: &direct.sources,
                creases: &interleaved.creases,
                g_normal: &gbuffer.normal,
                g_emission: &gbuffer.emission,
            },
            |kernel, bindings| kernel.dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))
        )
    }

    /// Every VPL at the pixels the filter listed beside creases.
    fn record_creases(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        reads: Reads<'_>,
        creases: &Buffer,
        out: &BoundedLighting,
    ) -> Result<()> {
        let Recording { rec, view, .. } = cx;
        let (gbuffer, direct, ism, visibility) = reads;
        let push = gather_push(gbuffer, ism, view, ism.vpl_count);
        with_visibility!(
            visibility,
            (ism: &ism.atlas, self.creases, indirect_creases_comp),
            (back: ism.back_faces, &self.back(rec.device)?.creases, indirect_creases_back_comp),
            (&self.exact()?.creases, indirect_creases_exact_comp),
            {
                g_position: &gbuffer.position,
                g_normal: &gbuffer.normal,
                g_albedo: &gbuffer.albedo,
                direct: &direct.radiance,
                direct_sources: &direct.sources,
                s0: out.s0(direct),
                s0_sources: &direct.sources,
                vpl_texels: &ism.vpls,
                creases,
                g_emission: &gbuffer.emission,
            },
            |kernel, bindings| kernel.dispatch(rec, pool, &bindings, &push, Work::Indirect(creases, 0))
        )
    }
}

impl Pass for IndirectBoundedPass {
    const NAME: &'static str = "indirect_bounded";
    fn layer(&self) -> u32 {
        self.layer
    }
    /// Width, height and the side of the interleaved pattern (1: full gather).
    type Key = (u32, u32, u32);
    type Resources = BoundedLighting;
    /// The G-buffer, the direct light, the ISM atlas and its VPLs, and how
    /// visibility is tested.
    type Reads<'a> = Reads<'a>;

    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key {
        let (w, h) = setup.layer_extent(self.layer);
        (w, h, setup.settings.pattern_side())
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<BoundedLighting> {
        let (device, extent) = (setup.device, setup.layer_extent(self.layer));
        let name = |base: &str| super::layer_name(base, self.layer);
        let region = setup.region(super::transient::Tenancy::Gather(self.layer));
        let interleaved = match setup.settings.gather {
            Gather::Full => None,
            Gather::Interleaved => Some(Interleaved::new(device, extent, &name, region)?),
        };
        let traits = setup.traits();
        let own_s0 = match super::transient::s0_in_direct(setup.settings, traits) {
            true => None,
            false => Some(super::radiance_image(device, &name("ssbc.s0"), extent)?),
        };
        Ok(BoundedLighting {
            own_s0,
            interleaved,
        })
    }

    /// The ISM gathers' sets, and the exact ones' where the device has
    /// them (a frame uses one kind or the other).
    /// Layer 0's `S0` is the final image of a frame without SSBC steps
    /// (the direct light's pass offers it where it is that image).
    fn layers<'r>(&self, lighting: &'r BoundedLighting) -> Vec<(Layer, &'r Image)> {
        match (self.layer(), &lighting.own_s0) {
            (0, Some(s0)) => vec![(Layer::Final, s0)],
            _ => Vec::new(),
        }
    }

    fn set_layouts(&self, out: &BoundedLighting) -> Vec<&DescriptorSetLayout> {
        let mut layouts = match out.interleaved {
            None => vec![self.full.set_layout()],
            Some(_) => vec![
                self.interleaved.set_layout(),
                self.filter.set_layout(),
                self.creases.set_layout(),
            ],
        };
        if let Some(exact) = &self.exact {
            match out.interleaved {
                None => layouts.push(exact.full.set_layout()),
                Some(_) => {
                    layouts.push(exact.interleaved.set_layout());
                    layouts.push(exact.filter.set_layout());
                    layouts.push(exact.creases.set_layout());
                }
            }
        }
        layouts
    }

    /// Writes `indirect_bounded` and `s0 = direct + indirect_bounded`.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        reads: Reads<'_>,
        out: &BoundedLighting,
    ) -> Result<()> {
        let name = super::layer_name("indirect_bounded", self.layer);
        let scope = cx.profiler.begin(cx.rec.cmd, &name);
        let (gbuffer, direct, ism, visibility) = reads;
        match &out.interleaved {
            None => self.record_full(cx, pool, reads, out)?,
            Some(interleaved) => {
                let part = cx.profiler.begin(cx.rec.cmd, &format!("{name}/gather"));
                self.record_interleaved(cx, pool, (gbuffer, ism, visibility), interleaved)?;
                cx.profiler.end(cx.rec.cmd, part);
                let part = cx.profiler.begin(cx.rec.cmd, &format!("{name}/filter"));
                let side = ism.subset_count.isqrt();
                let filter_reads = (gbuffer, direct, side, visibility);
                self.record_filter(cx, pool, filter_reads, interleaved, out)?;
                cx.profiler.end(cx.rec.cmd, part);
                let part = cx.profiler.begin(cx.rec.cmd, &format!("{name}/creases"));
                self.record_creases(cx, pool, reads, &interleaved.creases, out)?;
                cx.profiler.end(cx.rec.cmd, part);
            }
        }
        cx.profiler.end(cx.rec.cmd, scope);
        Ok(())
    }
}
