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

mod frame;
mod layout;
mod push;
mod pyramids;
mod step;

use std::sync::Arc;

use super::gbuffer::GBuffer;
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
use crate::layer::Layer;
pub use crate::settings::{Integration, LayerResolution, ReceiverDispatch, SsbcSettings};
use crate::shaders::{
    ssbc_eval_comp, ssbc_eval_glossy_comp, ssbc_fallback_comp, ssbc_fallback_glossy_comp, ssbc_geometry_base_comp, ssbc_geometry_mips_comp,
    ssbc_layer_residual_comp, ssbc_list_points_comp, ssbc_radiance_mips_comp, ssbc_resolve_comp,
    ssbc_samples_comp,
};
use crate::vk::{ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image};
pub use frame::SsbcFrame;
pub use layout::{
    check_size, frame_bytes, frame_memory, pyramid_levels, transient_resources, SsbcMemory, FinalImage, Kept,
};
pub use push::GLOSSY_RECEIVERS;

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
    /// Where the optical axis meets the image, from the image's centre, in
    /// pixels (x right, y down): zero for a symmetric frustum, the jitter
    /// or the frustum's offset otherwise.
    pub principal: glam::Vec2,
}

/// The SSBC pipelines, one per kernel.
pub struct SsbcPass {
    geometry_base: ComputeKernel<ssbc_geometry_base_comp::Interface>,
    geometry: ComputeKernel<ssbc_geometry_mips_comp::Interface>,
    radiance: ComputeKernel<ssbc_radiance_mips_comp::Interface>,
    /// The coarsest level's points as a list, in frames with glossy receivers.
    list_points: ComputeKernel<ssbc_list_points_comp::Interface>,
    eval: ComputeKernel<ssbc_eval_comp::Interface>,
    /// The evaluation points at glossy receivers (with `one_dispatch`, all).
    eval_glossy: ComputeKernel<ssbc_eval_glossy_comp::Interface>,
    resolve: ComputeKernel<ssbc_resolve_comp::Interface>,
    /// The kernels that sum the residual pixel by pixel, with the walk.
    walk: PixelIntegrals,
    /// The same with the brute-force reference ([`Integration::Brute`]).
    brute: PixelIntegrals,
    samples: ComputeKernel<ssbc_samples_comp::Interface>,
    /// Whether [`ReceiverDispatch::Auto`] means one dispatch: on GPUs, not
    /// on CPU devices.
    one_dispatch_by_default: bool,
}

/// The kernels that sum the residual at pixels evaluated alone, built for
/// one [`Integration`]: the specialization constant `BRUTE_FORCE`
/// (shaders/include/ssbc_residual.glsl) leaves the other's code out.
/// (The evaluation points only ever walk: brute force evaluates every
/// pixel alone, [`SsbcPass::eval_level`].)
pub(crate) struct PixelIntegrals {
    pub(crate) fallback: ComputeKernel<ssbc_fallback_comp::Interface>,
    /// The fallback pixels at glossy receivers (with `one_dispatch`, all).
    pub(crate) fallback_glossy: ComputeKernel<ssbc_fallback_glossy_comp::Interface>,
    pub(crate) layer_residual: ComputeKernel<ssbc_layer_residual_comp::Interface>,
}

impl PixelIntegrals {
    fn new(device: &Arc<Device>, integration: Integration) -> Result<Self> {
        let brute = (0, (integration == Integration::Brute) as u32);
        let named = |name: &str| match integration {
            Integration::Hierarchical => name.to_string(),
            Integration::Brute => format!("{name}_brute"),
        };
        Ok(Self {
            fallback: ComputeKernel::specialized(device, &[brute])?.named(&named("ssbc_fallback")),
            fallback_glossy: ComputeKernel::specialized(device, &[brute])?
                .named(&named("ssbc_fallback_glossy")),
            layer_residual: ComputeKernel::specialized(device, &[brute])?
                .named(&named("ssbc_layer_residual")),
        })
    }
}

/// A texels-read count at least this (`CUT_SHORT` in ssbc.glsl) marks a
/// residual sum whose loops the device cut short (lavapipe runs 65535 loop
/// iterations per shader invocation, then stops them silently).
pub(crate) const CUT_SHORT: u32 = 1 << 30;

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
    /// Whether receivers may be glossy ([`GLOSSY_RECEIVERS`]).
    pub glossy_receivers: bool,
}

impl SsbcPass {
    /// Creates the pipelines.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            // Level 0 of the geometry pyramid, from the G-buffer position and
            // normal; its own kernel (ssbc_geometry_base.comp says why).
            geometry_base: ComputeKernel::new(device)?,
            geometry: ComputeKernel::new(device)?,
            radiance: ComputeKernel::new(device)?,
            list_points: ComputeKernel::new(device)?,
            eval: ComputeKernel::new(device)?,
            eval_glossy: ComputeKernel::new(device)?,
            resolve: ComputeKernel::new(device)?,
            walk: PixelIntegrals::new(device, Integration::Hierarchical)?,
            brute: PixelIntegrals::new(device, Integration::Brute)?,
            samples: ComputeKernel::new(device)?,
            one_dispatch_by_default: device.properties.device_type
                != ash::vk::PhysicalDeviceType::CPU,
        })
    }

    /// Whether receivers of both kinds run in one dispatch at `settings`.
    fn one_dispatch(&self, settings: &SsbcSettings) -> bool {
        match settings.receiver_dispatch {
            ReceiverDispatch::Auto => self.one_dispatch_by_default,
            ReceiverDispatch::One => true,
            ReceiverDispatch::Two => false,
        }
    }

    /// The pixel-by-pixel kernels of `integration`.
    pub(crate) fn pixel_integrals(&self, integration: Integration) -> &PixelIntegrals {
        match integration {
            Integration::Hierarchical => &self.walk,
            Integration::Brute => &self.brute,
        }
    }

    /// Layouts of every set one frame of `frame` allocates (the brute
    /// force's kernels have the walk's layouts).
    pub fn frame_layouts(&self, frame: &SsbcFrame) -> Vec<&DescriptorSetLayout> {
        let levels = frame.levels as usize;
        // Layer 0's pyramid levels, then layer 1's (one fewer at half resolution).
        let per_layer: Vec<usize> = std::iter::once(levels)
            .chain(frame.layer1.map(|r| levels - r.shift() as usize))
            .collect();
        let built: usize = per_layer.iter().sum();
        let mut v = vec![self.list_points.set_layout()];
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
                v.push(self.walk.layer_residual.set_layout());
            }
            for _ in 0..=frame.max_eval_level {
                v.push(self.eval.set_layout());
                v.push(self.eval_glossy.set_layout());
                v.push(self.resolve.set_layout());
            }
            v.push(self.walk.fallback.set_layout());
            v.push(self.walk.fallback_glossy.set_layout());
            v.push(self.samples.set_layout());
        }
        v
    }

    /// The extent a frame slot's resources are allocated for: without steps
    /// nothing is recorded, and a 1x1 frame holds the resources every slot
    /// has.
    pub(crate) fn allocated_extent(extent: (u32, u32), steps: u32) -> (u32, u32) {
        if steps == 0 {
            (1, 1)
        } else {
            extent
        }
    }

    /// What the renderer's frames keep: the final image summed into S0's,
    /// each step's residual only in frames that hand out every output, the
    /// evaluation points' glossy rests only in scenes with `glossy`
    /// materials.
    pub(crate) fn kept(settings: &crate::settings::RenderSettings, glossy: bool) -> Kept {
        Kept {
            final_image: FinalImage::InS0,
            residuals: settings.every_output(),
            glossy_rests: glossy,
        }
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

}

/// The G-buffer images SSBC reads, ssbc's own or a host's (packed by the
/// post-process): world-space position (xyz; w = 0 where there is no
/// geometry; `R32G32B32A32_SFLOAT`), unit normal (xyz) and diffuse albedo
/// (rgb) packed as [`crate::passes::gbuffer::GBUFFER_PACKED_FORMAT`], each
/// with storage usage.
#[derive(Clone, Copy)]
pub struct SsbcGBuffer<'a> {
    /// World-space position.
    pub position: &'a Image,
    /// Shading normal.
    pub normal: &'a Image,
    /// Diffuse albedo.
    pub albedo: &'a Image,
    /// An image whose w, where negative, holds the surface's geometric
    /// normal (shaders/include/geometric_normal.glsl) where normal maps
    /// turned the shading normal: ssbc's direct light's sources, which
    /// carry it on from the G-buffer's emission image (transient). None (a
    /// host's G-buffer): the shading normal is the surface's.
    pub geometric: Option<&'a Image>,
}

impl<'a> From<&'a GBuffer> for SsbcGBuffer<'a> {
    fn from(g: &'a GBuffer) -> Self {
        Self {
            position: &g.position,
            normal: &g.normal,
            albedo: &g.albedo,
            // The direct light's sources carry them on (`ssbc_layer`).
            geometric: None,
        }
    }
}

impl SsbcGBuffer<'_> {


    /// Width and height.
    pub fn extent(&self) -> (u32, u32) {
        (self.position.desc.width, self.position.desc.height)
    }
}

/// One G-buffer layer SSBC gathers from: its G-buffer and its `S0`.
#[derive(Clone, Copy)]
pub struct SsbcLayer<'a> {
    /// Position, normal, albedo (w metallic), normal.w roughness.
    pub gbuffer: SsbcGBuffer<'a>,
    /// `S0 = T Le + T_b L^` at its pixels, towards the camera.
    pub s0: &'a Image,
    /// What its pixels send as sources of the first step: `S0`'s diffuse,
    /// view-independent part (`S0` itself where surfaces are Lambertian).
    pub sources: &'a Image,
}

impl Pass for SsbcPass {
    const NAME: &'static str = "ssbc";
    /// (width, height, steps, coarsest evaluation level, second layer,
    /// what is kept).
    type Key = (u32, u32, u32, u32, Option<LayerResolution>, Kept);
    type Resources = SsbcFrame;
    /// The visible layer and, with `layers` 2, the hidden one.
    type Reads<'a> = (SsbcLayer<'a>, Option<SsbcLayer<'a>>);

    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key {
        let (w, h) = setup.extent();
        let ssbc = &setup.settings.ssbc;
        let kept = Self::kept(setup.settings, setup.scene.has_glossy_materials());
        (w, h, ssbc.steps, ssbc.max_eval_level, ssbc.second_layer(), kept)
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<SsbcFrame> {
        let ssbc = &setup.settings.ssbc;
        self.allocate(
            setup.device,
            Self::allocated_extent(setup.extent(), ssbc.steps),
            ssbc.steps,
            ssbc.max_eval_level,
            ssbc.second_layer(),
            Self::kept(setup.settings, setup.scene.has_glossy_materials()),
            setup.region(super::transient::Tenancy::Ssbc),
        )
    }

    /// Each step's residual where kept (the final image is S0's, summed in
    /// place).
    fn layers<'r>(&self, frame: &'r SsbcFrame) -> Vec<(Layer, &'r Image)> {
        let residuals = (1..).zip(&frame.residuals);
        residuals.map(|(k, r)| (Layer::Residual(k), r)).collect()
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
            glossy_receivers: view.glossy,
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
