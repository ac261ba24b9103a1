//! The frame: which passes run in which order, and what comes back.
//!
//! ```text
//! scene ──upload──▶ GpuScene
//!                      │
//!   shadow_maps ──▶ gbuffer ──▶ direct_lighting ──▶ (readback: layers + timings)
//! ```
//!
//! A pass is added by giving it a file in `passes/`, creating it in
//! [`Renderer::new`], and recording it in [`Renderer::render`] between the
//! passes whose outputs it reads and whose inputs it writes.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use serde::Serialize;

use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::passes::direct_lighting::DirectLightingPass;
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::shadow_maps::ShadowMapPass;
use crate::scene::Scene;
use crate::vk::{Access, Buffer, CommandPool, DescriptorPool, Device, DeviceSelector, GpuProfiler, Image, Instance, PassTiming, ValidationLog};

/// How to create the renderer.
#[derive(Clone, Debug, Default)]
pub struct RendererConfig {
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Which device to use.
    pub device: DeviceSelector,
}

/// What to render.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera index into `Scene::cameras` (None: the first, or a framing one).
    pub camera: Option<usize>,
    /// Shadow-map side in texels.
    pub shadow_map_size: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self { width: 1024, height: 768, camera: None, shadow_map_size: 1024 }
    }
}

/// One named image of linear radiance, RGBA f32 per pixel, rows top to bottom.
#[derive(Clone, Debug)]
pub struct Layer {
    /// Layer name (`direct`, ...).
    pub name: String,
    /// `width * height * 4` floats; alpha is 1 on geometry, 0 on background.
    pub rgba: Vec<f32>,
}

/// GPU timings of one frame.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    /// Device name.
    pub device: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Per-pass GPU time, in recording order.
    pub passes: Vec<PassTiming>,
    /// First to last timestamp of the frame.
    pub frame_gpu_ms: f64,
}

/// A rendered frame: the final image, its component layers and timings.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The final image (linear radiance).
    pub image: Layer,
    /// Component layers (`direct`, ...).
    pub layers: Vec<Layer>,
    /// Per-pass GPU timings.
    pub timings: Timings,
}

impl Frame {
    /// The layer called `name` (`final` is the final image).
    pub fn layer(&self, name: &str) -> Option<&Layer> {
        if name == "final" {
            return Some(&self.image);
        }
        self.layers.iter().find(|l| l.name == name)
    }
}

/// The renderer: a device, its pipelines, and a command pool.
pub struct Renderer {
    // Field order is drop order: passes and pools before the device.
    shadow_maps: ShadowMapPass,
    gbuffer: GBufferPass,
    direct_lighting: DirectLightingPass,
    profiler: GpuProfiler,
    commands: CommandPool,
    device: Arc<Device>,
    validation_log: Arc<ValidationLog>,
}

/// Validates an image size against the device.
fn check_size(device: &Device, width: u32, height: u32) -> Result<()> {
    let max = device.limits().max_image_dimension2_d;
    if width == 0 || height == 0 {
        return Err(Error::InvalidParameter(format!("image size {width}x{height} is empty")));
    }
    if width > max || height > max {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} exceeds the device limit of {max} pixels per side"
        )));
    }
    Ok(())
}

impl Renderer {
    /// Creates the instance, device and every pipeline.
    pub fn new(config: &RendererConfig) -> Result<Self> {
        let instance = Instance::new(config.validation, &[])?;
        let validation_log = instance.validation_log();
        let device = Device::new(instance, &config.device, &[])?;
        Ok(Self {
            shadow_maps: ShadowMapPass::new(&device)?,
            gbuffer: GBufferPass::new(&device)?,
            direct_lighting: DirectLightingPass::new(&device)?,
            profiler: GpuProfiler::new(&device, 64)?,
            commands: CommandPool::new(&device)?,
            device,
            validation_log,
        })
    }

    /// The device.
    pub fn device(&self) -> &Arc<Device> {
        &self.device
    }

    /// Validation messages so far (stays readable after the renderer is dropped).
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.validation_log.clone()
    }

    /// Renders `scene` and reads the result back.
    pub fn render(&mut self, scene: &Scene, settings: &RenderSettings) -> Result<Frame> {
        let (w, h) = (settings.width, settings.height);
        check_size(&self.device, w, h)?;
        let sm = settings.shadow_map_size;
        if sm < 16 || sm > self.device.limits().max_image_dimension2_d {
            return Err(Error::InvalidParameter(format!(
                "shadow map size {sm} outside 16..={}",
                self.device.limits().max_image_dimension2_d
            )));
        }
        scene.validate()?;
        let camera = scene.camera(settings.camera)?;
        let device = self.device.clone();

        let gpu_scene = GpuScene::upload(&device, &mut self.commands, scene)?;
        let shadows = self.shadow_maps.prepare(&device, &scene.lights, &gpu_scene.bounds, sm)?;
        let gbuffer = GBuffer::new(&device, (w, h))?;
        let direct = crate::passes::storage_image(&device, "direct", vk::Format::R32G32B32A32_SFLOAT, (w, h), vk::ImageUsageFlags::empty())?;
        let pool = DescriptorPool::new(&device, &[self.gbuffer.set_layout(), self.direct_lighting.set_layout()])?;

        // Near and far planes enclose the scene's bounding sphere.
        let b = gpu_scene.bounds;
        let far = (camera.position - b.center()).length() + b.radius() * 1.05;
        let near = (far * 1e-4).max(1e-4);
        let view_proj = camera.projection(w as f32 / h as f32, near, far) * camera.view();

        let outputs: [(&str, &Image); 1] = [("direct", &direct)];
        let readback: Vec<Buffer> = outputs
            .iter()
            .map(|(name, _)| {
                Buffer::new(&device, name, (w * h * 16) as u64, vk::BufferUsageFlags::TRANSFER_DST, MemoryLocation::GpuToCpu)
            })
            .collect::<Result<_>>()?;

        let mut rec = self.commands.begin()?;
        self.profiler.begin_frame(rec.cmd);
        self.shadow_maps.record(&mut rec, &mut self.profiler, &gpu_scene, &shadows);
        self.gbuffer.record(&mut rec, &mut self.profiler, &pool, &gpu_scene, &gbuffer, view_proj, camera.position)?;
        self.direct_lighting.record(&mut rec, &mut self.profiler, &pool, &gbuffer, &shadows, &direct)?;
        self.profiler.end_frame(rec.cmd);
        for ((_, image), buffer) in outputs.iter().zip(&readback) {
            rec.copy_image_to_buffer(image, buffer);
            rec.use_buffer(buffer, Access::HostRead);
        }
        rec.flush_barriers();
        let done = rec.submit()?;
        device.wait(done)?;

        let (passes, frame_gpu_ms) = self.profiler.resolve()?;
        let mut layers = Vec::new();
        for ((name, _), buffer) in outputs.iter().zip(&readback) {
            layers.push(Layer { name: name.to_string(), rgba: buffer.read::<f32>()? });
        }
        let image = Layer { name: "final".into(), rgba: layers[0].rgba.clone() };
        Ok(Frame {
            width: w,
            height: h,
            image,
            layers,
            timings: Timings { device: device.name().to_string(), width: w, height: h, passes, frame_gpu_ms },
        })
    }
}
