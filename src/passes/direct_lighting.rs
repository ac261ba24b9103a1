//! Deferred direct lighting `T Le`: every light, shadowed by its shadow maps.

use std::sync::Arc;

use ash::vk;

use super::gbuffer::GBuffer;
use super::shadow_maps::ShadowMaps;
use crate::error::Result;
use crate::shaders;
use crate::vk::{
    Access, Binding, DescriptorPool, DescriptorSetLayout, Device, GpuProfiler, Image, Pipeline,
    Recorder, Sampler,
};

/// The direct-lighting compute pipeline.
pub struct DirectLightingPass {
    layout: DescriptorSetLayout,
    pipeline: Pipeline,
    shadow_sampler: Sampler,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    size: [u32; 2],
    light_count: u32,
}

impl DirectLightingPass {
    /// Creates the pipeline.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        use vk::DescriptorType as T;
        let layout = DescriptorSetLayout::new(
            device,
            &[
                T::STORAGE_IMAGE,
                T::STORAGE_IMAGE,
                T::STORAGE_IMAGE,
                T::STORAGE_IMAGE,
                T::STORAGE_BUFFER,
                T::STORAGE_BUFFER,
                T::COMBINED_IMAGE_SAMPLER,
            ],
            vk::ShaderStageFlags::COMPUTE,
        )?;
        let pipeline = Pipeline::compute(
            device,
            shaders::DIRECT_LIGHTING_COMP,
            &[&layout],
            std::mem::size_of::<Push>() as u32,
        )?;
        let shadow_sampler = Sampler::new(
            device,
            vk::Filter::NEAREST,
            vk::SamplerAddressMode::CLAMP_TO_EDGE,
        )?;
        Ok(Self {
            layout,
            pipeline,
            shadow_sampler,
        })
    }

    /// The descriptor layout (for sizing pools).
    pub fn set_layout(&self) -> &DescriptorSetLayout {
        &self.layout
    }

    /// Writes the direct radiance of every G-buffer pixel into `direct`.
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        gbuffer: &GBuffer,
        shadows: &ShadowMaps,
        direct: &Image,
    ) -> Result<()> {
        let set = pool.allocate(
            &self.layout,
            &[
                Binding::storage(&gbuffer.position),
                Binding::storage(&gbuffer.normal),
                Binding::storage(&gbuffer.albedo),
                Binding::storage(direct),
                Binding::StorageBuffer(&shadows.lights),
                Binding::StorageBuffer(&shadows.views),
                Binding::sampled(&shadows.depth, &self.shadow_sampler),
            ],
        )?;
        let scope = profiler.begin(rec.cmd, "direct_lighting");
        for input in [&gbuffer.position, &gbuffer.normal, &gbuffer.albedo] {
            rec.use_image(input, Access::ComputeRead);
        }
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
        self.pipeline.bind(rec.cmd, set, bytemuck::bytes_of(&push));
        self.pipeline.dispatch_2d(rec.cmd, w, h, 1);
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
