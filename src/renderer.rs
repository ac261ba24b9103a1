//! The frame: which passes run in which order, and what comes back.
//!
//! ```text
//!  CPU: BVH ─▶ VPLs (light tracing) ─▶ ISM points
//!  GPU: shadow_maps ─▶ ism_splat ─▶ ism_pullpush ─▶ gbuffer ─▶ direct_lighting
//!        ─▶ indirect_bounded (S0 = T Le + T_b L^) ─▶ ssbc_geometry_mips
//!        ─▶ ssbc_step_1 … ssbc_step_K (S_k = T_r S_{k-1}, final += S_k)
//! ```
//!
//! A pass is added by giving it a file in `passes/`, creating it in
//! [`Renderer::new`], and recording it in [`Renderer::render`] between the
//! passes whose outputs it reads and whose inputs it writes.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use serde::Serialize;

use crate::cpu::bvh::SceneBvh;
use crate::cpu::points::sample_points;
use crate::cpu::vpl::{self, Vpl, VplSettings};
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuVpl;
use crate::passes::direct_lighting::DirectLightingPass;
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::indirect_bounded::IndirectBoundedPass;
use crate::passes::ism::IsmPass;
use crate::passes::shadow_maps::ShadowMapPass;
use crate::passes::ssbc::{Integration, SsbcCamera, SsbcInputs, SsbcPass, SsbcSettings};
use crate::profile::{monotonic_ns, CpuSpan, FrameStats};
use crate::scene::Scene;
use crate::vk::{
    Access, Buffer, CommandPool, DescriptorPool, DescriptorSetLayout, Device, DeviceSelector,
    GpuFrameTimes, GpuProfiler, Image, Instance, PassTiming, Validation, ValidationLog,
};

/// How to create the renderer.
#[derive(Clone, Debug, Default)]
pub struct RendererConfig {
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Enable it with GPU-assisted validation instead (out-of-bounds
    /// accesses in shaders; slow).
    pub gpu_assisted_validation: bool,
    /// Which device to use.
    pub device: DeviceSelector,
    /// Do not time passes with timestamp queries (timings are then absent,
    /// as on a queue without timestamps; labels and names stay).
    pub no_gpu_timestamps: bool,
}

/// The clamping bound b of the geometry term (1/m²).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Bound {
    /// Derived from the scene: b = (10 / diagonal)², i.e. clamping starts at a
    /// tenth of the scene's bounding-box diagonal.
    #[default]
    Auto,
    /// A fixed value (`f32::INFINITY`: no clamping).
    Value(f32),
}

impl Bound {
    /// The value for a scene whose bounding-box diagonal is `diagonal`.
    pub fn resolve(self, diagonal: f32) -> f32 {
        match self {
            Bound::Auto => (10.0 / diagonal.max(1e-6)).powi(2),
            Bound::Value(b) => b,
        }
    }
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
    /// VPL distribution (count 0 switches indirect light off).
    pub vpl: VplSettings,
    /// ISM tile side in texels (power of two).
    pub ism_tile: u32,
    /// Scene points each VPL splats into its ISM.
    pub points_per_vpl: u32,
    /// Clamping bound b.
    pub bound: Bound,
    /// Bias compensation.
    pub ssbc: SsbcSettings,
    /// Also read back the G-buffer and the ISM atlas (for tests and tools).
    pub debug_readback: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        Self {
            width: 1024,
            height: 768,
            camera: None,
            shadow_map_size: 1024,
            vpl: VplSettings::default(),
            ism_tile: 64,
            points_per_vpl: 1024,
            bound: Bound::Auto,
            ssbc: SsbcSettings::default(),
            debug_readback: false,
        }
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

/// CPU time of the frame's CPU stages.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CpuTimings {
    /// BVH build.
    pub bvh_build: f64,
    /// VPL generation by light tracing.
    pub vpl_generation: f64,
    /// ISM point sampling.
    pub point_sampling: f64,
}

/// Per-step SSBC figures.
#[derive(Clone, Debug, Serialize)]
pub struct SsbcStepTiming {
    /// GPU time of the step (radiance mips, residual, accumulation; None
    /// without timestamps).
    pub gpu_ms: Option<f64>,
    /// Texels read per geometry pixel, on average: every texel read by an
    /// evaluation point (shared among the pixels under it) or by a pixel
    /// evaluated alone, divided by the geometry pixels.
    pub samples_per_pixel_avg: f64,
    /// The most texels any one pixel accounts for.
    pub samples_per_pixel_max: f64,
    /// Level of the pyramid whose texels were the evaluation points (0: every
    /// pixel was evaluated alone).
    pub eval_level: u32,
    /// Fraction of geometry pixels evaluated alone rather than interpolated.
    pub fallback_fraction: f64,
}

/// GPU timings of one frame, and the figures that explain them.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    /// Device name.
    pub device: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Per-pass GPU time, in recording order. A name `pass/part` is a part of
    /// the pass `pass` (timed inside it; not to be added to it). None (JSON
    /// `null`) when the device's queue has no timestamps.
    pub passes: Option<Vec<PassTiming>>,
    /// First to last timestamp of the frame (None without timestamps).
    pub frame_gpu_ms: Option<f64>,
    /// Statistics over several frames ([`crate::profile::render_frames`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stats: Option<FrameStats>,
    /// CPU stages (ms).
    pub cpu_ms: CpuTimings,
    /// CPU stages of the frame on CLOCK_MONOTONIC (for traces).
    #[serde(skip)]
    pub cpu_spans: Vec<CpuSpan>,
    /// When the frame was submitted (ns, CLOCK_MONOTONIC).
    #[serde(skip)]
    pub submit_ns: u64,
    /// The frame's first GPU timestamp on CLOCK_MONOTONIC, when calibrated.
    #[serde(skip)]
    pub gpu_start_ns: Option<u64>,
    /// VPLs used.
    pub vpl_count: usize,
    /// Light paths traced to make them.
    pub light_paths: u64,
    /// ISM tile side.
    pub ism_tile: u32,
    /// Points per VPL.
    pub points_per_vpl: u32,
    /// Clamping bound b (1/m²) (a number, or the string "inf").
    pub bound: serde_json::Value,
    /// SSBC integration method.
    pub integration: Integration,
    /// Per-step SSBC figures.
    pub ssbc_steps: Vec<SsbcStepTiming>,
}

impl Timings {
    /// The timed passes (empty without timestamps).
    pub fn timed_passes(&self) -> &[PassTiming] {
        self.passes.as_deref().unwrap_or(&[])
    }

    /// GPU milliseconds of the pass `name`, if it ran and was timed.
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        self.timed_passes()
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.gpu_ms)
    }
}

/// The ISM atlas, read back for diagnostics.
#[derive(Clone, Debug)]
pub struct IsmReadback {
    /// Atlas width.
    pub width: u32,
    /// Atlas height.
    pub height: u32,
    /// Tile side.
    pub tile: u32,
    /// Tiles per row.
    pub tiles_per_row: u32,
    /// Distances are stored divided by this.
    pub far: f32,
    /// Level 0 after pull-push (negative: hole).
    pub depth: Vec<f32>,
    /// World radius of one splatted point.
    pub point_radius: f32,
}

impl IsmReadback {
    /// The GPU's ISM visibility test, replayed on the CPU: is `x` visible from
    /// VPL `index` (at `vpl`) according to its imperfect shadow map? `normal`
    /// is the receiver's.
    pub fn visible(&self, index: usize, vpl: &Vpl, x: glam::Vec3, normal: glam::Vec3) -> bool {
        let d = x - vpl.position;
        let dist = d.length();
        let w = d / dist;
        let (t, b) = crate::cpu::sampling::basis(vpl.normal);
        let l = glam::Vec3::new(w.dot(t), w.dot(b), w.dot(vpl.normal));
        let uv = glam::Vec2::new(l.x, l.y) / (1.0 + l.z) * 0.5 + glam::Vec2::splat(0.5);
        let tile = self.tile as i64;
        let origin = (
            (index as u32 % self.tiles_per_row) as i64 * tile,
            (index as u32 / self.tiles_per_row) as i64 * tile,
        );
        let local = ((uv.x * tile as f32) as i64).clamp(0, tile - 1);
        let local_y = ((uv.y * tile as f32) as i64).clamp(0, tile - 1);
        let texel = ((origin.1 + local_y) * self.width as i64 + origin.0 + local) as usize;
        let stored = self.depth[texel];
        // ism_tolerance() in shaders/include/ism.glsl.
        let footprint = (dist * 4.0 / self.tile as f32).max(self.point_radius);
        let c = (-normal.dot(w)).clamp(0.1, 1.0);
        let slope = (1.0 - c * c).sqrt() / c;
        let tolerance = crate::passes::indirect_bounded::ISM_BIAS * dist + footprint * slope + 1e-3;
        stored < 0.0 || dist <= stored * self.far + tolerance
    }
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
    /// Component layers (`direct`, `indirect_bounded`, `residual_k`, and with
    /// debug readback `gbuffer_position`, `gbuffer_normal`, `gbuffer_albedo`,
    /// `gbuffer_emission`).
    pub layers: Vec<Layer>,
    /// Per-pass GPU timings.
    pub timings: Timings,
    /// The VPLs used.
    pub vpls: Vec<Vpl>,
    /// The bound b used.
    pub bound: f32,
    /// The ISM atlas (with debug readback).
    pub ism: Option<IsmReadback>,
    /// Texels read per pixel of each SSBC step (see [`SsbcStepTiming`]).
    pub samples: Vec<Vec<f32>>,
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
    ism: IsmPass,
    gbuffer: GBufferPass,
    direct_lighting: DirectLightingPass,
    indirect_bounded: IndirectBoundedPass,
    ssbc: SsbcPass,
    profiler: GpuProfiler,
    /// One command pool per frame slot.
    commands: Vec<CommandPool>,
    /// Timeline value of each slot's last submission.
    slot_done: [u64; FRAME_SLOTS],
    /// Frames started so far (picks the slot).
    frame_index: u64,
    /// The last frame's final image and the timeline value that finished it.
    output: Option<(Image, u64)>,
    device: Arc<Device>,
    validation_log: Arc<ValidationLog>,
}

/// The last frame's final image, left on the GPU for a host engine. Valid
/// until the next [`Renderer::render`] or until the renderer is dropped.
#[derive(Clone, Copy, Debug)]
pub struct GpuImage {
    /// The image (RGBA32F, linear radiance; owned by ssbc).
    pub image: vk::Image,
    /// A 2D view of it.
    pub view: vk::ImageView,
    /// Its format.
    pub format: vk::Format,
    /// Width and height.
    pub extent: (u32, u32),
    /// The layout it is in.
    pub layout: vk::ImageLayout,
    /// Timeline semaphore to wait on before reading it...
    pub semaphore: vk::Semaphore,
    /// ...for this value.
    pub value: u64,
}

/// Validates an image size against the device.
fn check_size(device: &Device, width: u32, height: u32) -> Result<()> {
    let max = device.limits().max_image_dimension2_d;
    if width == 0 || height == 0 {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} is empty"
        )));
    }
    if width > max || height > max {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} exceeds the device limit of {max} pixels per side"
        )));
    }
    Ok(())
}

/// Frames that may be in flight at once (each has its command pool and
/// timestamp queries).
pub const FRAME_SLOTS: usize = 2;

/// A frame submitted by [`Renderer::render_to_gpu`].
#[derive(Clone, Debug)]
pub struct GpuSubmission {
    /// Timeline value that signals the frame is done (see [`Renderer::output_image`]).
    pub value: u64,
    /// GPU times of the previous frame that used this frame slot, read
    /// without waiting (None for a slot's first frame or without timestamps).
    pub previous_timings: Option<GpuFrameTimes>,
}

/// What a frame returns: everything read back, or a GPU submission.
enum Outcome {
    Frame(Box<Frame>),
    Gpu(GpuSubmission),
}

/// Largest number of ISM points uploaded (VPLs x points per VPL).
const MAX_ISM_POINTS: u64 = 1 << 26;

impl Renderer {
    /// Creates the instance, device and every pipeline.
    pub fn new(config: &RendererConfig) -> Result<Self> {
        let mode = match (config.gpu_assisted_validation, config.validation) {
            (true, _) => Validation::GpuAssisted,
            (false, true) => Validation::Synchronization,
            (false, false) => Validation::Off,
        };
        let instance = Instance::with_validation(mode, &[])?;
        let device = Device::new(instance, &config.device, &[])?;
        Self::with_device_and_timing(device, !config.no_gpu_timestamps)
    }

    /// Creates every pipeline on an existing device: one ssbc made
    /// ([`Device::new`]) or a host engine's ([`Device::from_host`]).
    ///
    /// ```no_run
    /// # fn host() -> ssbc::Result<()> {
    /// # let (entry, instance, physical, device): (ash::Entry, ash::Instance, ash::vk::PhysicalDevice, ash::Device) = todo!();
    /// use ssbc::vk::{Device, HostDevice, Instance, RequiredFeatures};
    /// let instance = Instance::from_host(entry, instance);
    /// let device = Device::from_host(instance, HostDevice {
    ///     physical,
    ///     device,
    ///     queue_family: 0,
    ///     queue_index: 0,
    ///     enabled_features: RequiredFeatures::ALL,
    /// })?;
    /// let mut renderer = ssbc::Renderer::with_device(device)?;
    /// # Ok(()) }
    /// ```
    pub fn with_device(device: Arc<Device>) -> Result<Self> {
        Self::with_device_and_timing(device, true)
    }

    /// As [`Renderer::with_device`]; `timestamps` false leaves passes
    /// untimed (labelled only).
    pub fn with_device_and_timing(device: Arc<Device>, timestamps: bool) -> Result<Self> {
        if device.profiling().timestamp_valid_bits == 0 && timestamps {
            log::warn!("the device's queue has no timestamps: GPU timings will be absent (null)");
        }
        let validation_log = device.instance.validation_log();
        Ok(Self {
            shadow_maps: ShadowMapPass::new(&device)?,
            ism: IsmPass::new(&device)?,
            gbuffer: GBufferPass::new(&device)?,
            direct_lighting: DirectLightingPass::new(&device)?,
            indirect_bounded: IndirectBoundedPass::new(&device)?,
            ssbc: SsbcPass::new(&device)?,
            profiler: GpuProfiler::new(&device, 1024, FRAME_SLOTS, timestamps)?,
            commands: (0..FRAME_SLOTS)
                .map(|slot| {
                    let pool = CommandPool::new(&device)?;
                    pool.name(&format!("frame slot {slot}"));
                    Ok(pool)
                })
                .collect::<Result<_>>()?,
            slot_done: [0; FRAME_SLOTS],
            frame_index: 0,
            device,
            validation_log,
            output: None,
        })
    }

    /// The last frame's final image, on the GPU, with its layout and the
    /// timeline semaphore value to wait for (None before the first frame).
    pub fn output_image(&self) -> Option<GpuImage> {
        self.output.as_ref().map(|(image, value)| GpuImage {
            image: image.raw,
            view: image.view,
            format: image.desc.format,
            extent: (image.desc.width, image.desc.height),
            layout: image.state.get().layout,
            semaphore: self.device.timeline(),
            value: *value,
        })
    }

    /// The last frame's output image as a tracked [`Image`] (for in-crate
    /// consumers that record their own commands on the same queue).
    pub(crate) fn output(&self) -> Option<&Image> {
        self.output.as_ref().map(|(image, _)| image)
    }

    /// The device.
    pub fn device(&self) -> &Arc<Device> {
        &self.device
    }

    /// Validation messages so far (stays readable after the renderer is dropped).
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.validation_log.clone()
    }

    fn check_settings(&self, settings: &RenderSettings) -> Result<()> {
        check_size(&self.device, settings.width, settings.height)?;
        let max = self.device.limits().max_image_dimension2_d;
        let sm = settings.shadow_map_size;
        if sm < 16 || sm > max {
            return Err(Error::InvalidParameter(format!(
                "shadow map size {sm} outside 16..={max}"
            )));
        }
        if let Bound::Value(b) = settings.bound {
            if b.is_nan() || b <= 0.0 {
                return Err(Error::InvalidParameter(format!(
                    "bound {b} must be positive (or inf)"
                )));
            }
        }
        if settings.vpl.count > 0 && settings.points_per_vpl == 0 {
            return Err(Error::InvalidParameter(
                "--points-per-vpl must be at least 1".into(),
            ));
        }
        // Every ISM point is 16 bytes in one storage buffer.
        let max_range = self.device.limits().max_storage_buffer_range as u64;
        let points = settings.vpl.count as u64 * settings.points_per_vpl as u64;
        if points * 16 > max_range {
            return Err(Error::InvalidParameter(format!(
                "{} VPLs x {} points per VPL need {} MiB of ISM points; this device's storage \
                 buffers hold at most {} MiB (maxStorageBufferRange): use fewer VPLs or points",
                settings.vpl.count,
                settings.points_per_vpl,
                (points * 16) >> 20,
                max_range >> 20
            )));
        }
        if settings.ssbc.steps > 0 {
            crate::passes::ssbc::check_size(&self.device, settings.width, settings.height)?;
        }
        if settings.vpl.count as u64 * settings.points_per_vpl as u64 > MAX_ISM_POINTS {
            return Err(Error::InvalidParameter(format!(
                "{} VPLs x {} points per VPL exceeds {MAX_ISM_POINTS} ISM points",
                settings.vpl.count, settings.points_per_vpl
            )));
        }
        settings.ssbc.validate()
    }

    /// Renders `scene` and reads the result back (waits for the GPU).
    pub fn render(&mut self, scene: &Scene, settings: &RenderSettings) -> Result<Frame> {
        match self.run(scene, settings, None)? {
            Outcome::Frame(frame) => Ok(*frame),
            Outcome::Gpu(_) => unreachable!("no GPU layer was asked for"),
        }
    }

    /// Records and submits a frame without waiting for it or reading it
    /// back; `layer` (`final`, `direct`, `indirect_bounded` or `residual_k`)
    /// is kept on the GPU as [`Renderer::output_image`]. Up to
    /// [`FRAME_SLOTS`] frames are in flight: this waits only for the frame
    /// that last used the same slot, whose timings it returns.
    pub fn render_to_gpu(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        layer: &str,
    ) -> Result<GpuSubmission> {
        let steps = settings.ssbc.steps as usize;
        let known = matches!(layer, "final" | "direct" | "indirect_bounded")
            || layer
                .strip_prefix("residual_")
                .and_then(|k| k.parse::<usize>().ok())
                .is_some_and(|k| k >= 1 && k <= steps);
        if !known {
            return Err(Error::InvalidParameter(format!("no GPU layer '{layer}'")));
        }
        match self.run(scene, settings, Some(layer))? {
            Outcome::Gpu(submission) => Ok(submission),
            Outcome::Frame(_) => unreachable!("a GPU layer was asked for"),
        }
    }

    fn run(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        gpu_layer: Option<&str>,
    ) -> Result<Outcome> {
        self.check_settings(settings)?;
        // The frame slot: wait for (only) the frame that used it last.
        let slot = (self.frame_index % FRAME_SLOTS as u64) as usize;
        self.frame_index += 1;
        self.device.wait(self.slot_done[slot])?;
        let previous_timings = if self.profiler.has_frame(slot) {
            self.profiler.resolve(slot)?
        } else {
            None
        };
        let (w, h) = (settings.width, settings.height);
        scene.validate()?;
        let camera = scene.camera(settings.camera)?;
        let device = self.device.clone();
        let bounds = scene.bounds();
        let diagonal = 2.0 * bounds.radius();
        let bound = settings.bound.resolve(diagonal);

        // CPU: light tracing and ISM points.
        let mut spans = Vec::new();
        let bvh = CpuSpan::time(&mut spans, "bvh_build", || SceneBvh::new(scene));
        let vpl_set = CpuSpan::time(&mut spans, "vpl_generation", || {
            vpl::generate(scene, &bvh, &settings.vpl)
        })?;
        let points = CpuSpan::time(&mut spans, "point_sampling", || {
            sample_points(
                scene,
                vpl_set.vpls.len(),
                settings.points_per_vpl as usize,
                settings.vpl.seed,
            )
        });
        let cpu_ms = CpuTimings {
            bvh_build: spans[0].ms(),
            vpl_generation: spans[1].ms(),
            point_sampling: spans[2].ms(),
        };
        let gpu_vpls: Vec<GpuVpl> = vpl_set.vpls.iter().map(GpuVpl::new).collect();

        // GPU resources of this frame.
        let resources_start = monotonic_ns();
        let gpu_scene = GpuScene::upload(&device, &mut self.commands[slot], scene)?;
        let shadows =
            self.shadow_maps
                .prepare(&device, &scene.lights, &bounds, settings.shadow_map_size)?;
        let ism = self
            .ism
            .prepare(&device, &gpu_vpls, &points, settings.ism_tile, diagonal)?;
        let gbuffer = GBuffer::new(&device, (w, h))?;
        let layer_image = |name: &str| {
            crate::passes::storage_image(
                &device,
                name,
                vk::Format::R32G32B32A32_SFLOAT,
                (w, h),
                vk::ImageUsageFlags::empty(),
            )
        };
        let direct = layer_image("lighting.direct")?;
        let indirect = layer_image("lighting.indirect_bounded")?;
        let s0 = layer_image("ssbc.s0")?;
        let steps = settings.ssbc.steps;
        let ssbc = self.ssbc.prepare(&device, (w, h), steps)?;
        let ssbc_camera = SsbcCamera {
            position: camera.position,
            forward: camera.forward,
            pixel_side: 2.0 * (camera.yfov * 0.5).tan() / h as f32,
        };
        let eval_level = SsbcPass::eval_level(
            &ssbc_camera,
            (bounds.center() - camera.position).dot(camera.forward),
            bound,
            ssbc.levels(),
            &settings.ssbc,
        );
        let mut layouts: Vec<&DescriptorSetLayout> = vec![
            self.shadow_maps.set_layout(),
            self.gbuffer.set_layout(),
            self.direct_lighting.set_layout(),
            self.indirect_bounded.set_layout(),
        ];
        layouts.extend(self.ism.set_layouts(settings.ism_tile));
        layouts.extend(self.ssbc.set_layouts((w, h), steps, eval_level));
        let pool = DescriptorPool::new(&device, &layouts)?;
        pool.name("frame descriptor pool");

        // Near and far planes enclose the scene's bounding sphere.
        let far = (camera.position - bounds.center()).length() + bounds.radius() * 1.05;
        let near = (far * 1e-4).max(1e-4);
        let view_proj = camera.projection(w as f32 / h as f32, near, far) * camera.view();

        // What to read back.
        let final_image = if steps > 0 { &ssbc.final_image } else { &s0 };
        let mut outputs: Vec<(String, &Image)> = vec![
            ("final".into(), final_image),
            ("direct".into(), &direct),
            ("indirect_bounded".into(), &indirect),
        ];
        for (k, r) in ssbc.residuals.iter().enumerate() {
            outputs.push((format!("residual_{}", k + 1), r));
        }
        if settings.debug_readback {
            outputs.push(("gbuffer_position".into(), &gbuffer.position));
            outputs.push(("gbuffer_normal".into(), &gbuffer.normal));
            outputs.push(("gbuffer_albedo".into(), &gbuffer.albedo));
            outputs.push(("gbuffer_emission".into(), &gbuffer.emission));
        }
        if gpu_layer.is_some() {
            outputs.clear(); // nothing is read back
        }
        let mut images: Vec<&Image> = outputs.iter().map(|o| o.1).collect();
        if gpu_layer.is_none() {
            images.extend(ssbc.samples.iter());
            if settings.debug_readback {
                images.push(&ism.pyramid);
            }
        }
        let readback: Vec<Buffer> = images
            .iter()
            .map(|img| {
                let name = format!("readback.{}", img.name());
                let texel = if img.desc.format == vk::Format::R32G32B32A32_SFLOAT {
                    16
                } else {
                    4
                };
                let size = img.desc.width as u64 * img.desc.height as u64 * texel;
                Buffer::new(
                    &device,
                    &name,
                    size,
                    vk::BufferUsageFlags::TRANSFER_DST,
                    MemoryLocation::GpuToCpu,
                )
            })
            .collect::<Result<_>>()?;

        spans.push(CpuSpan {
            name: "upload_and_resources".into(),
            start_ns: resources_start,
            duration_ns: monotonic_ns().saturating_sub(resources_start),
        });

        // Record the frame.
        let record_start = monotonic_ns();
        let mut rec = self.commands[slot].begin()?;
        self.profiler.begin_frame(rec.cmd, slot);
        self.shadow_maps
            .record(&mut rec, &mut self.profiler, &pool, &gpu_scene, &shadows)?;
        if ism.vpl_count > 0 {
            self.ism.record(&mut rec, &mut self.profiler, &pool, &ism)?;
        }
        self.gbuffer.record(
            &mut rec,
            &mut self.profiler,
            &pool,
            &gpu_scene,
            &gbuffer,
            view_proj,
            camera.position,
        )?;
        self.direct_lighting.record(
            &mut rec,
            &mut self.profiler,
            &pool,
            &gbuffer,
            &shadows,
            &direct,
        )?;
        self.indirect_bounded.record(
            &mut rec,
            &mut self.profiler,
            &pool,
            &gbuffer,
            &direct,
            &ism,
            bound,
            &indirect,
            &s0,
        )?;
        if steps > 0 {
            self.ssbc.record(
                &mut rec,
                &mut self.profiler,
                &pool,
                &gbuffer,
                &s0,
                &SsbcInputs {
                    camera: &ssbc_camera,
                    bound,
                    eval_level,
                    settings: &settings.ssbc,
                },
                &ssbc,
            )?;
        }
        self.profiler.end_frame(rec.cmd);
        rec.use_buffer(&ssbc.stats, Access::HostRead);
        for (image, buffer) in images.iter().zip(&readback) {
            rec.copy_image_to_buffer(image, buffer);
            rec.use_buffer(buffer, Access::HostRead);
        }
        rec.flush_barriers();
        let submit_ns = monotonic_ns();
        spans.push(CpuSpan {
            name: "record".into(),
            start_ns: record_start,
            duration_ns: submit_ns.saturating_sub(record_start),
        });
        let done = rec.submit()?;
        self.profiler.submitted(slot);
        self.slot_done[slot] = done;
        if let Some(layer) = gpu_layer {
            // Keep the asked-for image; everything else is dropped into the
            // device's deferred-destruction queue until `done` has passed.
            let mut residuals = ssbc.residuals;
            let image = match layer {
                "final" if steps > 0 => ssbc.final_image,
                "final" => s0,
                "direct" => direct,
                "indirect_bounded" => indirect,
                _ => {
                    let k: usize = layer["residual_".len()..]
                        .parse()
                        .expect("checked by render_to_gpu");
                    residuals.swap_remove(k - 1)
                }
            };
            self.output = Some((image, done));
            return Ok(Outcome::Gpu(GpuSubmission {
                value: done,
                previous_timings,
            }));
        }
        let wait_start = monotonic_ns();
        device.wait(done)?;
        spans.push(CpuSpan {
            name: "wait_for_gpu".into(),
            start_ns: wait_start,
            duration_ns: monotonic_ns().saturating_sub(wait_start),
        });

        // Read back.
        let gpu_times = self.profiler.resolve(slot)?;
        let mut layers = Vec::new();
        for ((name, _), buffer) in outputs.iter().zip(&readback) {
            layers.push(Layer {
                name: name.clone(),
                rgba: buffer.read::<f32>()?,
            });
        }
        let image = layers.remove(0);
        let mut ssbc_steps = Vec::new();
        let mut samples = Vec::new();
        let fallback_counts = ssbc.fallback_counts()?;
        let geometry: Vec<bool> = layers[0]
            .rgba
            .chunks_exact(4)
            .map(|p| p[3] != 0.0)
            .collect();
        for (k, buffer) in readback[outputs.len()..outputs.len() + steps as usize]
            .iter()
            .enumerate()
        {
            let counts: Vec<f32> = buffer.read()?;
            let on_geometry: Vec<f32> = counts
                .iter()
                .zip(&geometry)
                .filter(|(_, g)| **g)
                .map(|(c, _)| *c)
                .collect();

            let name = format!("ssbc_step_{}", k + 1);
            ssbc_steps.push(SsbcStepTiming {
                gpu_ms: gpu_times
                    .as_ref()
                    .and_then(|t| t.passes.iter().find(|p| p.name == name))
                    .map(|p| p.gpu_ms),
                samples_per_pixel_avg: on_geometry.iter().map(|&c| c as f64).sum::<f64>()
                    / on_geometry.len().max(1) as f64,
                samples_per_pixel_max: on_geometry.iter().fold(0.0, |m, &c| m.max(c as f64)),
                eval_level,
                fallback_fraction: fallback_counts.get(k).copied().unwrap_or(0) as f64
                    / on_geometry.len().max(1) as f64,
            });
            samples.push(counts);
        }
        let ism_readback = if settings.debug_readback {
            Some(IsmReadback {
                width: ism.pyramid.desc.width,
                height: ism.pyramid.desc.height,
                tile: ism.tile,
                tiles_per_row: ism.tiles_per_row,
                far: ism.far,
                depth: readback.last().expect("ism readback").read()?,
                point_radius: ism.point_radius,
            })
        } else {
            None
        };
        // Keep the final image for the host (see `output_image`).
        self.output = Some((if steps > 0 { ssbc.final_image } else { s0 }, done));
        Ok(Outcome::Frame(Box::new(Frame {
            width: w,
            height: h,
            image,
            layers,
            timings: Timings {
                device: device.name().to_string(),
                width: w,
                height: h,
                frame_gpu_ms: gpu_times.as_ref().map(|t| t.frame_ms),
                gpu_start_ns: gpu_times.as_ref().and_then(|t| t.start_monotonic_ns),
                passes: gpu_times.map(|t| t.passes),
                stats: None,
                cpu_ms,
                cpu_spans: spans,
                submit_ns,
                vpl_count: vpl_set.vpls.len(),
                light_paths: vpl_set.paths,
                ism_tile: settings.ism_tile,
                points_per_vpl: settings.points_per_vpl,
                bound: if bound.is_finite() {
                    serde_json::json!(bound)
                } else {
                    serde_json::json!("inf")
                },
                integration: settings.ssbc.integration,
                ssbc_steps,
            },
            vpls: vpl_set.vpls,
            bound,
            ism: ism_readback,
            samples,
        })))
    }
}
