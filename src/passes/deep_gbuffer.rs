//! A deep G-buffer's second layer (Mara, McGuire, Nowrouzezahrai, Luebke,
//! "Deep G-Buffers for Stable Global Illumination Approximation", HPG 2016)
//! by depth peeling, at full or half resolution
//! ([`crate::settings::LayerResolution`]): per pixel the nearest surface at
//! least a separation farther from the camera than the visible one (layer
//! 0) under it, back faces included. SSBC gathers from its surfaces too:
//! the hidden faces of objects light the visible surfaces around them.

use std::sync::Arc;

use super::gbuffer::{self, GBuffer, Push};
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::shaders::gbuffer_peel_frag;
use crate::vk::{Access, DescriptorPool, DescriptorSetLayout, Device, Pipeline, ShaderBindings};

/// The peeling pipeline and its descriptor layout.
pub struct DeepGBufferPass {
    layout: DescriptorSetLayout,
    pipeline: Pipeline,
}

impl DeepGBufferPass {
    /// Creates the pipeline.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        let (layout, pipeline) =
            gbuffer::raster_pipeline::<gbuffer_peel_frag::Interface>(device, "gbuffer_layer1")?;
        Ok(Self { layout, pipeline })
    }
}

impl Pass for DeepGBufferPass {
    const NAME: &'static str = "gbuffer_layer1";
    /// Width and height of layer 1.
    type Key = (u32, u32);
    type Resources = GBuffer;
    /// The scene and layer 0.
    type Reads<'a> = (&'a GpuScene, &'a GBuffer);

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.layer_extent(1)
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<GBuffer> {
        GBuffer::new(setup.device, "gbuffer_layer1", setup.layer_extent(1))
    }

    fn set_layouts(&self, _: &GBuffer) -> Vec<&DescriptorSetLayout> {
        vec![&self.layout]
    }

    /// Rasterizes the scene again, keeping what lies behind layer 0.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (scene, layer0): (&GpuScene, &GBuffer),
        layer1: &GBuffer,
    ) -> Result<()> {
        let Recording {
            rec,
            profiler,
            view,
            settings,
            ..
        } = cx;
        let bindings = gbuffer_peel_frag::Bindings {
            materials: &scene.materials,
            color_textures: (&scene.color_textures, &scene.texture_sampler),
            linear_textures: (&scene.linear_textures, &scene.texture_sampler),
            layer0_position: &layer0.position,
        };
        let set = pool.allocate(&self.layout, &bindings.bindings())?;
        let scope = profiler.begin(rec.cmd, "gbuffer_layer1");
        rec.use_image(&layer0.position, Access::GraphicsStorageRead);
        let separation = settings.ssbc.layer_separation * view.diagonal;
        let push = Push {
            view_proj: view.view_proj.to_cols_array(),
            camera_position: view.camera.position.extend(separation).into(),
            layer1_shift: settings.ssbc.layer1_resolution.shift(),
        };
        layer1.draw(rec, scene, &self.pipeline, set, bytemuck::bytes_of(&push));
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
