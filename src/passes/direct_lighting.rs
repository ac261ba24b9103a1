//! Deferred direct lighting `T Le` from every punctual light, shadowed by its
//! shadow maps, plus the radiance emissive surfaces send to the camera
//! (`Le`, from the G-buffer). Light from emissive surfaces onto others comes
//! from the VPLs on them (bounce 0) and SSBC.

use std::sync::Arc;

use ash::vk;

use super::gbuffer::GBuffer;
use super::shadow_maps::ShadowMaps;
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
use crate::layer::Layer;
use crate::shaders::direct_lighting_comp;
use crate::vk::{
    ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image, ImageDesc, Planned, Sampler,
    Tenant, Work,
};

/// What the pass writes.
pub struct DirectLight {
    /// `T Le` towards the camera, the `direct` layer; where nothing reads
    /// it after the bounded lighting ([`DirectLight::is_s0`]), that pass
    /// adds its light in place: then `S0`.
    pub radiance: Image,
    /// Whether `radiance` becomes `S0` (`transient::s0_in_direct`: frames
    /// without history or output layers).
    pub is_s0: bool,
    /// What the pixel sends as an SSBC source, view-independent: emission
    /// plus brdf_source_color / pi x the irradiance (its reflection spread
    /// evenly by its hemispherical albedo). The same as `radiance` on
    /// Lambertian surfaces. The bounded lighting adds its own in place:
    /// then S0's sources, the `sources` layer.
    pub sources: Image,
    /// Which punctual lights reach each pixel (bit i mod 32 for light i).
    /// The interleaved filter keeps neighbours of another set apart where
    /// their bounded light differs from the pixel's side's by 2x: a wall
    /// thinner than its surface tests resolve still parts the pixels each
    /// light reaches (docs/accuracy.md, "The filter parts what different
    /// lights reach"). Written with the full gather too, where nothing
    /// reads it (a store a pixel, in transient memory).
    pub lights: Image,
}

/// [`DirectLight::lights`] at `extent`.
pub(crate) fn lights_desc(extent: (u32, u32)) -> ImageDesc {
    super::storage_desc(vk::Format::R32_UINT, extent, vk::ImageUsageFlags::empty())
}

/// What the direct light places in a frame slot's transient memory
/// (`passes::transient`): [`DirectLight::lights`], which the interleaved
/// filter reads last.
pub(crate) fn transient_resources(extent: (u32, u32)) -> Tenant {
    vec![Planned::Image(lights_desc(extent))]
}

/// The direct-lighting compute kernel, for one G-buffer layer.
pub struct DirectLightingPass {
    kernel: ComputeKernel<direct_lighting_comp::Interface>,
    shadow_sampler: Sampler,
    layer: u32,
}

impl DirectLightingPass {
    /// Creates the kernel for G-buffer layer `layer` (0: the visible
    /// surfaces; 1: the deep G-buffer's second layer).
    pub fn new(device: &Arc<Device>, layer: u32) -> Result<Self> {
        Ok(Self {
            kernel: ComputeKernel::new(device)?,
            shadow_sampler: Sampler::new(
                device,
                vk::Filter::NEAREST,
                vk::SamplerAddressMode::CLAMP_TO_EDGE,
            )?
            .named("shadow_maps.sampler"),
            layer,
        })
    }
}

impl Pass for DirectLightingPass {
    const NAME: &'static str = "direct_lighting";
    fn layer(&self) -> u32 {
        self.layer
    }
    /// Width and height.
    type Key = (u32, u32);
    type Resources = DirectLight;
    type Reads<'a> = (&'a GBuffer, &'a ShadowMaps);

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.layer_extent(self.layer)
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<DirectLight> {
        let (device, extent) = (setup.device, setup.layer_extent(self.layer));
        let name = |base: &str| super::layer_name(base, self.layer);
        let traits = setup.traits();
        let is_s0 = super::transient::s0_in_direct(setup.settings, traits);
        let direct = name(if is_s0 { "ssbc.s0" } else { "lighting.direct" });
        let lights = name("lighting.direct_lights");
        Ok(DirectLight {
            radiance: super::radiance_image(device, &direct, extent)?,
            is_s0,
            sources: super::radiance_image(device, &name("lighting.direct_sources"), extent)?,
            lights: match setup.region(super::transient::Tenancy::Direct(self.layer)) {
                Some(mut region) => Image::new_aliased(device, &lights, lights_desc(extent), &mut region)?,
                None => Image::new(device, &lights, lights_desc(extent))?,
            },
        })
    }

    /// The direct light where it outlives the frame's bounded lighting;
    /// else it is S0, the final image of a frame without SSBC steps.
    fn layers<'r>(&self, direct: &'r DirectLight) -> Vec<(Layer, &'r Image)> {
        match self.layer() {
            0 if !direct.is_s0 => vec![(Layer::Direct, &direct.radiance), (Layer::Sources, &direct.sources)],
            0 => vec![(Layer::Final, &direct.radiance), (Layer::Sources, &direct.sources)],
            _ => vec![(Layer::Layer1Sources, &direct.sources)],
        }
    }

    fn set_layouts(&self, _: &DirectLight) -> Vec<&DescriptorSetLayout> {
        vec![self.kernel.set_layout()]
    }

    /// Writes the direct radiance of every G-buffer pixel.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, shadows): (&GBuffer, &ShadowMaps),
        direct: &DirectLight,
    ) -> Result<()> {
        let Recording {
            rec, profiler, view, ..
        } = cx;
        let scope = profiler.begin(rec.cmd, &super::layer_name("direct_lighting", self.layer));
        let (w, h) = gbuffer.extent();
        let push = direct_lighting_comp::Push {
            size: [w, h],
            light_count: shadows.light_count,
            camera_position: view.camera.position.extend(1.0).into(),
            ..Default::default()
        };
        let bindings = direct_lighting_comp::Bindings {
            g_position: &gbuffer.position,
            g_normal: &gbuffer.normal,
            g_albedo: &gbuffer.albedo,
            direct: &direct.radiance,
            direct_sources: &direct.sources,
            direct_lights: &direct.lights,
            lights: &shadows.lights,
            shadow_views: &shadows.views,
            shadow_maps: (&shadows.depth, &self.shadow_sampler),
            g_emission: &gbuffer.emission,
        };
        self.kernel
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
