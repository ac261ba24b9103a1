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
use crate::shaders;
use crate::vk::{
    Access, Binding, ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image, Sampler,
};

/// The direct-lighting compute kernel.
pub struct DirectLightingPass {
    kernel: ComputeKernel,
    shadow_sampler: Sampler,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    size: [u32; 2],
    light_count: u32,
}

impl DirectLightingPass {
    /// Creates the kernel.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        use vk::DescriptorType as T;
        let bindings = [
            T::STORAGE_IMAGE,          // g_position
            T::STORAGE_IMAGE,          // g_normal
            T::STORAGE_IMAGE,          // g_albedo
            T::STORAGE_IMAGE,          // direct (out)
            T::STORAGE_BUFFER,         // lights
            T::STORAGE_BUFFER,         // shadow views
            T::COMBINED_IMAGE_SAMPLER, // shadow maps
            T::STORAGE_IMAGE,          // g_emission
        ];
        Ok(Self {
            kernel: ComputeKernel::new(
                device,
                shaders::DIRECT_LIGHTING_COMP,
                &bindings,
                std::mem::size_of::<Push>(),
            )?
            .named("direct_lighting"),
            shadow_sampler: Sampler::new(
                device,
                vk::Filter::NEAREST,
                vk::SamplerAddressMode::CLAMP_TO_EDGE,
            )?
            .named("shadow_maps.sampler"),
        })
    }
}

impl Pass for DirectLightingPass {
    const NAME: &'static str = "direct_lighting";
    /// Width and height.
    type Key = (u32, u32);
    /// The `direct` layer.
    type Resources = Image;
    type Reads<'a> = (&'a GBuffer, &'a ShadowMaps);

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.extent()
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<Image> {
        super::radiance_image(setup.device, "lighting.direct", setup.extent())
    }

    fn set_layouts(&self, _: &Image) -> Vec<&DescriptorSetLayout> {
        vec![self.kernel.set_layout()]
    }

    /// Writes the direct radiance of every G-buffer pixel.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, shadows): (&GBuffer, &ShadowMaps),
        direct: &Image,
    ) -> Result<()> {
        let Recording { rec, profiler, .. } = cx;
        let scope = profiler.begin(rec.cmd, "direct_lighting");
        gbuffer.read_in_compute(rec);
        rec.use_image(&gbuffer.emission, Access::ComputeRead);
        rec.use_image(&shadows.depth, Access::ComputeSampled);
        rec.use_buffer(&shadows.lights, Access::ComputeRead);
        rec.use_buffer(&shadows.views, Access::ComputeRead);
        rec.use_image(direct, Access::ComputeWrite);
        rec.flush_barriers();
        let (w, h) = gbuffer.extent();
        let push = Push {
            size: [w, h],
            light_count: shadows.light_count,
        };
        let [position, normal, albedo] = gbuffer.storage_bindings();
        let bindings = [
            position,
            normal,
            albedo,
            Binding::storage(direct),
            Binding::StorageBuffer(&shadows.lights),
            Binding::StorageBuffer(&shadows.views),
            Binding::sampled(&shadows.depth, &self.shadow_sampler),
            Binding::storage(&gbuffer.emission),
        ];
        self.kernel
            .dispatch_2d(rec.cmd, pool, &bindings, bytemuck::bytes_of(&push), (w, h))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
