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
use crate::cpu::points::IsmPoints;
use crate::cpu::vpl::VplSet;
use crate::cpu::vpl::{self, Vpl, VplSettings};
use crate::error::{Error, Result};
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuVpl;
use crate::passes::direct_lighting::DirectLightingPass;
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::indirect_bounded::IndirectBoundedPass;
use crate::passes::ism::Ism;
use crate::passes::ism::IsmPass;
use crate::passes::shadow_maps::ShadowMapPass;
use crate::passes::shadow_maps::ShadowMaps;
use crate::passes::ssbc::SsbcFrame;
use crate::passes::ssbc::{Integration, SsbcCamera, SsbcInputs, SsbcPass, SsbcSettings};
use crate::postprocess::HostImage;
use crate::profile::{monotonic_ns, CpuSpan, FrameStats};
use crate::resident::{next_version, ResidentScene, SceneVersions};
use crate::scene::Bounds;
use crate::scene::Scene;
use crate::vk::{
    Access, Buffer, CommandPool, DescriptorPool, DescriptorSetLayout, Device, DeviceSelector,
    GpuFrameTimes, GpuProfiler, Image, Instance, PassTiming, Recorder, Validation, ValidationLog,
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
    /// Do not count shader invocations per pass (pipeline-statistics
    /// queries, used by default where the device supports them; a driver
    /// may count at a cost, which this switch rules out of a measurement).
    pub no_pipeline_statistics: bool,
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
    /// Each frame slot's resources, reused while they fit.
    slots: Vec<FrameSlot>,
    /// The scene's CPU products and GPU copy, kept while it is unchanged.
    scene_cache: Option<SceneCache>,
    /// One command pool per frame slot.
    commands: Vec<CommandPool>,
    /// Timeline value of each slot's last submission.
    slot_done: [u64; FRAME_SLOTS],
    /// Frames started so far (picks the slot).
    frame_index: u64,
    /// Which image of which slot the last frame handed over, and the
    /// timeline value that finished it.
    output: Option<FrameOutput>,
    /// A pass after which the next frame fails (tests of recovery).
    fault: Option<String>,
    device: Arc<Device>,
    validation_log: Arc<ValidationLog>,
}

/// The image a frame handed over.
struct FrameOutput {
    slot: usize,
    layer: String,
    done: u64,
}

/// VPLs traced for one version of the lights and one set of settings.
struct VplCache {
    key: (u64, VplSettings),
    set: VplSet,
    gpu: Vec<GpuVpl>,
    /// Changes whenever the VPLs do (slots compare it with what they hold).
    version: u64,
}

/// ISM points for one VPL count, points per VPL and seed.
struct PointsCache {
    key: (usize, u32, u64),
    points: IsmPoints,
    version: u64,
}

/// What is kept while the scene's surfaces do not change.
struct SceneCache {
    /// The versions the cache was built from (geometry and materials) and
    /// last used with (lights, camera).
    versions: SceneVersions,
    bounds: Bounds,
    bvh: SceneBvh,
    gpu_scene: GpuScene,
    vpls: Option<VplCache>,
    points: Option<PointsCache>,
}

/// Screen-size images of a slot: the G-buffer, the lighting layers and SSBC's.
struct Targets {
    key: (u32, u32, u32),
    gbuffer: GBuffer,
    direct: Image,
    indirect: Image,
    s0: Image,
    ssbc: SsbcFrame,
}

/// (width, height, steps, deepest evaluation level, ISM tile): what a
/// slot's descriptor pool is sized for.
type PoolKey = (u32, u32, u32, u32, u32);

/// One frame slot's resources, each with the key of what it was made for.
#[derive(Default)]
struct FrameSlot {
    /// Keyed by the (lights, geometry) versions written into them.
    shadows: Option<((u64, u64), ShadowMaps)>,
    /// Keyed by (VPL version, points version, far plane bits, tile).
    ism: Option<((u64, u64, u32, u32), Ism)>,
    targets: Option<Targets>,
    /// Keyed by (width, height, steps, deepest eval level, ISM tile).
    pool: Option<(PoolKey, DescriptorPool)>,
    /// One host-visible buffer per image read back, named as the layer.
    readback: Option<Vec<(String, Buffer)>>,
}

impl FrameSlot {
    /// The images a read-back frame copies to the host, with their layer
    /// names: the final image first, then the layers, the per-step sample
    /// counts and (for diagnostics) the G-buffer and the ISM atlas.
    fn readback_images(&self, debug: bool) -> Vec<(String, &Image)> {
        let (Some(t), Some((_, ism))) = (&self.targets, &self.ism) else {
            return Vec::new();
        };
        let mut v = t.layers();
        if debug {
            v.push(("gbuffer_position".into(), &t.gbuffer.position));
            v.push(("gbuffer_normal".into(), &t.gbuffer.normal));
            v.push(("gbuffer_albedo".into(), &t.gbuffer.albedo));
            v.push(("gbuffer_emission".into(), &t.gbuffer.emission));
        }
        for (k, img) in t.ssbc.samples.iter().enumerate() {
            v.push((format!("samples_{}", k + 1), img));
        }
        if debug {
            v.push(("ism_atlas".into(), &ism.pyramid));
        }
        v
    }
}

impl Targets {
    /// The final image: SSBC's sum, or S0 without steps.
    fn final_image(&self) -> &Image {
        if self.key.2 > 0 {
            &self.ssbc.final_image
        } else {
            &self.s0
        }
    }

    /// Every layer with its name ([`layer_names`] order).
    fn layers(&self) -> Vec<(String, &Image)> {
        let images = [self.final_image(), &self.direct, &self.indirect]
            .into_iter()
            .chain(&self.ssbc.residuals);
        layer_names(self.key.2).into_iter().zip(images).collect()
    }

    /// The image of a layer name (`final`, `direct`, ...).
    fn layer(&self, layer: &str) -> Option<&Image> {
        self.layers()
            .into_iter()
            .find(|(name, _)| name == layer)
            .map(|(_, image)| image)
    }
}

/// The names of a frame's layers with `steps` SSBC steps: `final`,
/// `direct`, `indirect_bounded`, `residual_1` ... `residual_K` (the one
/// definition the renderer, the CLI's `--output-layer` and the viewer use).
pub fn layer_names(steps: u32) -> Vec<String> {
    ["final", "direct", "indirect_bounded"]
        .into_iter()
        .map(String::from)
        .chain((1..=steps).map(|k| format!("residual_{k}")))
        .collect()
}

/// Bytes of a tightly packed host copy of `image`'s first level.
fn readback_size(image: &Image) -> u64 {
    let texel = if image.desc.format == vk::Format::R32G32B32A32_SFLOAT {
        16
    } else {
        4
    };
    image.desc.width as u64 * image.desc.height as u64 * texel
}

/// Milliseconds of the CPU stage `name` (0 if it did not run this frame).
fn span_ms(spans: &[CpuSpan], name: &str) -> f64 {
    spans
        .iter()
        .find(|s| s.name == name)
        .map_or(0.0, CpuSpan::ms)
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

/// What a frame returns: everything read back, a GPU submission, or
/// nothing (recorded into the host's command buffer).
enum Outcome {
    Frame(Box<Frame>),
    Gpu(GpuSubmission),
    Host,
}

/// Where a frame's result goes.
#[derive(Clone, Copy)]
enum Sink<'a> {
    /// Read back to the host (the frame is waited for).
    Readback,
    /// Kept on the GPU as this layer; ssbc submits.
    Gpu(&'a str),
    /// Recorded into the host's command buffer; this layer is copied into
    /// the host's image.
    Host {
        cmd: vk::CommandBuffer,
        slot: usize,
        output: &'a HostImage,
        layer: &'a str,
    },
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
        Self::with_device_and_profiling(
            device,
            !config.no_gpu_timestamps,
            !config.no_pipeline_statistics,
        )
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
        Self::with_device_and_profiling(device, true, false)
    }

    /// As [`Renderer::with_device`]; `timestamps` false leaves passes
    /// untimed (labelled only); `statistics` counts shader invocations per
    /// pass where the device can.
    pub fn with_device_and_profiling(
        device: Arc<Device>,
        timestamps: bool,
        statistics: bool,
    ) -> Result<Self> {
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
            profiler: GpuProfiler::new(&device, 1024, FRAME_SLOTS, timestamps, statistics)?,
            commands: (0..FRAME_SLOTS)
                .map(|slot| {
                    let pool = CommandPool::new(&device)?;
                    pool.name(&format!("frame slot {slot}"));
                    Ok(pool)
                })
                .collect::<Result<_>>()?,
            slot_done: [0; FRAME_SLOTS],
            frame_index: 0,
            slots: (0..FRAME_SLOTS).map(|_| FrameSlot::default()).collect(),
            scene_cache: None,
            fault: None,
            device,
            validation_log,
            output: None,
        })
    }

    /// The last frame's final image, on the GPU, with its layout and the
    /// timeline semaphore value to wait for (None before the first frame).
    pub fn output_image(&self) -> Option<GpuImage> {
        let done = self.output.as_ref()?.done;
        self.output().map(|image| GpuImage {
            image: image.raw,
            view: image.view,
            format: image.desc.format,
            extent: (image.desc.width, image.desc.height),
            layout: image.state.get().layout,
            semaphore: self.device.timeline(),
            value: done,
        })
    }

    /// The last frame's output image as a tracked [`Image`] (for in-crate
    /// consumers that record their own commands on the same queue).
    pub(crate) fn output(&self) -> Option<&Image> {
        let out = self.output.as_ref()?;
        self.slots[out.slot].targets.as_ref()?.layer(&out.layer)
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
    /// Immediate mode: nothing about the scene is assumed to persist, so
    /// its BVH, VPLs, points and GPU copy are rebuilt (images, buffers and
    /// descriptor pools are still reused while the size and settings fit).
    /// See [`Renderer::render_resident`] for frames that redo only what changed.
    pub fn render(&mut self, scene: &Scene, settings: &RenderSettings) -> Result<Frame> {
        self.read_back(scene, SceneVersions::fresh(), settings)
    }

    /// Renders a [`ResidentScene`] and reads the result back, redoing only
    /// the work its changes since the last frame require.
    pub fn render_resident(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
    ) -> Result<Frame> {
        self.read_back(scene.scene(), scene.versions(), settings)
    }

    fn read_back(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
    ) -> Result<Frame> {
        match self.run(scene, versions, settings, Sink::Readback)? {
            Outcome::Frame(frame) => Ok(*frame),
            _ => unreachable!("a read-back frame returns a Frame"),
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
        self.submit_to_gpu(scene, SceneVersions::fresh(), settings, layer)
    }

    /// [`Renderer::render_to_gpu`] for a [`ResidentScene`]: only what changed
    /// is redone (a camera move: the screen-space passes only).
    pub fn render_resident_to_gpu(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
        layer: &str,
    ) -> Result<GpuSubmission> {
        self.submit_to_gpu(scene.scene(), scene.versions(), settings, layer)
    }

    fn submit_to_gpu(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        layer: &str,
    ) -> Result<GpuSubmission> {
        Self::check_layer(layer, settings)?;
        match self.run(scene, versions, settings, Sink::Gpu(layer))? {
            Outcome::Gpu(submission) => Ok(submission),
            _ => unreachable!("a GPU frame returns its submission"),
        }
    }

    fn check_layer(layer: &str, settings: &RenderSettings) -> Result<()> {
        let names = layer_names(settings.ssbc.steps);
        if names.iter().any(|n| n == layer) {
            Ok(())
        } else {
            Err(Error::InvalidParameter(format!(
                "no layer '{layer}' (have: {})",
                names.join(", ")
            )))
        }
    }

    /// Records a frame of `scene` into the host's command buffer `cmd`
    /// (recording, outside a render pass) and copies `layer` (`final`,
    /// `direct`, `indirect_bounded`, `residual_k`) into the host's `output`
    /// image (`R32G32B32A32_SFLOAT`, `TRANSFER_DST` usage, the frame's size;
    /// left in `TRANSFER_DST_OPTIMAL` after a transfer write). The host
    /// ends and submits `cmd` and synchronises with its own semaphores; it
    /// passes the frame slot (`0..FRAME_SLOTS`) and guarantees the slot's
    /// previous frame has finished on the GPU. Such frames are labelled but
    /// not timed, and must not be interleaved with ssbc's own submissions
    /// ([`Renderer::render_resident`], ...) while in flight. A change of
    /// geometry or materials uploads the scene with ssbc's own submission
    /// first (waited for).
    pub fn record_resident(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
        cmd: vk::CommandBuffer,
        slot: usize,
        output: &HostImage,
        layer: &str,
    ) -> Result<()> {
        Self::check_layer(layer, settings)?;
        let sink = Sink::Host {
            cmd,
            slot,
            output,
            layer,
        };
        self.run(scene.scene(), scene.versions(), settings, sink)
            .map(|_| ())
    }

    /// Makes the next frame fail after recording `pass` (`shadow_maps`,
    /// `ism`, `gbuffer`, `indirect_bounded` or `ssbc`), before submission:
    /// for tests that a failed frame leaves the renderer usable.
    #[doc(hidden)]
    pub fn inject_fault_after(&mut self, pass: &str) {
        self.fault = Some(pass.to_string());
    }

    fn run(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        sink: Sink<'_>,
    ) -> Result<Outcome> {
        self.check_settings(settings)?;
        let (slot, previous_timings) = match sink {
            Sink::Host { slot, output, .. } => {
                if slot >= FRAME_SLOTS {
                    return Err(Error::InvalidParameter(format!(
                        "frame slot {slot} of {FRAME_SLOTS}"
                    )));
                }
                if output.format != vk::Format::R32G32B32A32_SFLOAT
                    || output.extent != (settings.width, settings.height)
                {
                    return Err(Error::InvalidParameter(format!(
                        "the host's output image must be R32G32B32A32_SFLOAT of {}x{} (it is {:?} of {:?})",
                        settings.width, settings.height, output.format, output.extent
                    )));
                }
                // The host guarantees the slot's previous frame is done.
                (slot, None)
            }
            Sink::Readback | Sink::Gpu(_) => {
                // The frame slot: wait for (only) the frame that used it last.
                let slot = (self.frame_index % FRAME_SLOTS as u64) as usize;
                self.frame_index += 1;
                self.device.wait(self.slot_done[slot])?;
                let previous = if self.profiler.has_frame(slot) {
                    self.profiler.resolve(slot)?
                } else {
                    None
                };
                (slot, previous)
            }
        };
        let result = self.frame(scene, versions, settings, sink, slot, previous_timings);
        if result.is_err() {
            // Whatever was recorded was never submitted, but the resources'
            // tracked states say otherwise: forget them, and the scene's
            // GPU copy, so the next frame starts from known states.
            self.slots[slot] = FrameSlot::default();
            self.scene_cache = None;
            if self.output.as_ref().is_some_and(|o| o.slot == slot) {
                self.output = None;
            }
        }
        result
    }

    /// Brings the scene cache up to `versions`: BVH and GPU copy when
    /// geometry or materials changed, VPLs when lights did too, ISM points
    /// when geometry, materials or their count changed.
    fn update_scene(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        spans: &mut Vec<CpuSpan>,
    ) -> Result<()> {
        // Earlier frames that recorded texture copies have been submitted.
        if let Some(cache) = self.scene_cache.as_mut() {
            cache.gpu_scene.release_staging();
        }
        let same_surfaces = |c: &SceneCache| {
            c.versions.geometry == versions.geometry && c.versions.materials == versions.materials
        };
        if !self.scene_cache.as_ref().is_some_and(same_surfaces) {
            scene.validate()?;
            self.scene_cache = None;
            let bvh = CpuSpan::time(spans, "bvh_build", || SceneBvh::new(scene));
            let gpu_scene = CpuSpan::time(spans, "scene_upload", || {
                GpuScene::upload(&self.device, scene)
            })?;
            self.scene_cache = Some(SceneCache {
                versions,
                bounds: scene.bounds(),
                bvh,
                gpu_scene,
                vpls: None,
                points: None,
            });
        }
        let cache = self.scene_cache.as_mut().expect("built above");
        cache.versions.lights = versions.lights;
        cache.versions.camera = versions.camera;
        let vpl_key = (versions.lights, settings.vpl.clone());
        if !cache.vpls.as_ref().is_some_and(|v| v.key == vpl_key) {
            let set = CpuSpan::time(spans, "vpl_generation", || {
                vpl::generate(scene, &cache.bvh, &settings.vpl)
            })?;
            cache.vpls = Some(VplCache {
                gpu: set.vpls.iter().map(GpuVpl::new).collect(),
                set,
                key: vpl_key,
                version: next_version(),
            });
        }
        let vpl_count = cache.vpls.as_ref().expect("traced above").set.vpls.len();
        let points_key = (vpl_count, settings.points_per_vpl, settings.vpl.seed);
        if cache.points.as_ref().is_none_or(|p| p.key != points_key) {
            let points = CpuSpan::time(spans, "point_sampling", || {
                sample_points(
                    scene,
                    vpl_count,
                    settings.points_per_vpl as usize,
                    settings.vpl.seed,
                )
            });
            cache.points = Some(PointsCache {
                points,
                key: points_key,
                version: next_version(),
            });
        }
        Ok(())
    }

    /// Brings the slot's resources up to `settings` and the scene cache:
    /// allocates only what is missing or no longer fits, and rewrites the
    /// host-visible inputs (lights, shadow views, VPLs, points) only when
    /// they changed since the slot last used them.
    fn update_slot(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        slot: usize,
        readback: bool,
    ) -> Result<()> {
        let device = self.device.clone();
        let cache = self.scene_cache.as_ref().expect("scene cache built");
        let (w, h) = (settings.width, settings.height);
        let diagonal = 2.0 * cache.bounds.radius();
        let frame = &mut self.slots[slot];

        // Shadow maps: the lights' views depend on the lights and the bounds.
        let lights_key = (cache.versions.lights, cache.versions.geometry);
        let lights = &scene.lights;
        let current = frame.shadows.as_ref().is_some_and(|(key, maps)| {
            *key == lights_key && maps.depth.desc.width == settings.shadow_map_size
        });
        if !current {
            let updated = match frame.shadows.as_mut() {
                Some((_, maps)) => self.shadow_maps.update(
                    maps,
                    lights,
                    &cache.bounds,
                    settings.shadow_map_size,
                )?,
                None => false,
            };
            if updated {
                frame.shadows.as_mut().expect("updated").0 = lights_key;
            } else {
                let maps = self.shadow_maps.prepare(
                    &device,
                    lights,
                    &cache.bounds,
                    settings.shadow_map_size,
                )?;
                frame.shadows = Some((lights_key, maps));
            }
        }

        // ISM atlas and its inputs.
        let vpls = cache.vpls.as_ref().expect("VPLs traced");
        let points = cache.points.as_ref().expect("points sampled");
        let ism_key = (
            vpls.version,
            points.version,
            diagonal.to_bits(),
            settings.ism_tile,
        );
        if frame.ism.as_ref().is_none_or(|(key, _)| *key != ism_key) {
            let updated = match frame.ism.as_mut() {
                Some((_, ism)) => {
                    self.ism
                        .update(ism, &vpls.gpu, &points.points, settings.ism_tile, diagonal)?
                }
                None => false,
            };
            if updated {
                frame.ism.as_mut().expect("updated").0 = ism_key;
            } else {
                let ism = self.ism.prepare(
                    &device,
                    &vpls.gpu,
                    &points.points,
                    settings.ism_tile,
                    diagonal,
                )?;
                frame.ism = Some((ism_key, ism));
            }
        }

        // Screen-size targets.
        let steps = settings.ssbc.steps;
        let targets_key = (w, h, steps);
        if frame.targets.as_ref().is_none_or(|t| t.key != targets_key) {
            frame.targets = None; // free the old ones first
            let layer_image = |name: &str| {
                crate::passes::storage_image(
                    &device,
                    name,
                    vk::Format::R32G32B32A32_SFLOAT,
                    (w, h),
                    vk::ImageUsageFlags::empty(),
                )
            };
            frame.targets = Some(Targets {
                key: targets_key,
                gbuffer: GBuffer::new(&device, (w, h))?,
                direct: layer_image("lighting.direct")?,
                indirect: layer_image("lighting.indirect_bounded")?,
                s0: layer_image("ssbc.s0")?,
                ssbc: self.ssbc.prepare(&device, (w, h), steps)?,
            });
            frame.readback = None;
        }

        // The descriptor pool, sized for the deepest evaluation level the
        // settings allow (the level follows the camera).
        let targets = frame.targets.as_ref().expect("allocated above");
        let max_eval = settings
            .ssbc
            .max_eval_level
            .min(targets.ssbc.levels().saturating_sub(1));
        let pool_key = (w, h, steps, max_eval, settings.ism_tile);
        if frame.pool.as_ref().is_none_or(|(key, _)| *key != pool_key) {
            let mut layouts: Vec<&DescriptorSetLayout> = vec![
                self.shadow_maps.set_layout(),
                self.gbuffer.set_layout(),
                self.direct_lighting.set_layout(),
                self.indirect_bounded.set_layout(),
            ];
            layouts.extend(self.ism.set_layouts(settings.ism_tile));
            layouts.extend(self.ssbc.set_layouts((w, h), steps, max_eval));
            let pool = DescriptorPool::new(&device, &layouts)?;
            pool.name(&format!("frame slot {slot} descriptor pool"));
            frame.pool = Some((pool_key, pool));
        } else {
            frame.pool.as_ref().expect("checked").1.reset()?;
        }

        // Readback buffers (only for frames read back to the host).
        if readback {
            let images = frame.readback_images(settings.debug_readback);
            let sizes: Vec<u64> = images.iter().map(|(_, img)| readback_size(img)).collect();
            if frame
                .readback
                .as_ref()
                .is_none_or(|r| r.iter().map(|(_, b)| b.size).collect::<Vec<_>>() != sizes)
            {
                let buffers = images
                    .iter()
                    .map(|(name, img)| {
                        Buffer::new(
                            &device,
                            &format!("readback.{}", img.name()),
                            readback_size(img),
                            vk::BufferUsageFlags::TRANSFER_DST,
                            MemoryLocation::GpuToCpu,
                        )
                        .map(|b| (name.clone(), b))
                    })
                    .collect::<Result<Vec<_>>>()?;
                frame.readback = Some(buffers);
            }
        }
        Ok(())
    }

    fn frame(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        sink: Sink<'_>,
        slot: usize,
        previous_timings: Option<GpuFrameTimes>,
    ) -> Result<Outcome> {
        let (w, h) = (settings.width, settings.height);
        let camera = scene.camera(settings.camera)?;
        let device = self.device.clone();

        // CPU work and GPU resources that changed.
        let mut spans = Vec::new();
        self.update_scene(scene, versions, settings, &mut spans)?;
        let resources_start = monotonic_ns();
        self.update_slot(scene, settings, slot, matches!(sink, Sink::Readback))?;
        spans.push(CpuSpan {
            name: "slot_resources".into(),
            start_ns: resources_start,
            duration_ns: monotonic_ns().saturating_sub(resources_start),
        });
        let cpu_ms = CpuTimings {
            bvh_build: span_ms(&spans, "bvh_build"),
            vpl_generation: span_ms(&spans, "vpl_generation"),
            point_sampling: span_ms(&spans, "point_sampling"),
        };

        // Record the frame.
        let record_start = monotonic_ns();
        let gpu_scene = &mut self
            .scene_cache
            .as_mut()
            .expect("scene cache built")
            .gpu_scene;
        if matches!(sink, Sink::Host { .. }) && gpu_scene.has_pending_uploads() {
            // Texture copies go through ssbc's own submission here (ssbc's
            // timeline cannot see when the host's command buffer finishes,
            // so the staging buffers could not be freed safely).
            let mut upload = self.commands[slot].begin()?;
            gpu_scene.record_uploads(&mut upload);
            let done = upload.submit()?;
            self.device.wait(done)?;
            gpu_scene.release_staging();
        }
        let mut rec = match sink {
            Sink::Host { cmd, .. } => Recorder::for_host(&self.device, cmd),
            _ => self.commands[slot].begin()?,
        };
        // The first frame after an upload copies the scene's textures.
        gpu_scene.record_uploads(&mut rec);

        let cache = self.scene_cache.as_ref().expect("scene cache built");
        let frame = &self.slots[slot];
        let (shadows, ism) = (
            &frame.shadows.as_ref().expect("prepared").1,
            &frame.ism.as_ref().expect("prepared").1,
        );
        let t = frame.targets.as_ref().expect("prepared");
        let pool = &frame.pool.as_ref().expect("prepared").1;
        let bounds = cache.bounds;
        let bound = settings.bound.resolve(2.0 * bounds.radius());
        let steps = settings.ssbc.steps;
        let ssbc_camera = SsbcCamera {
            position: camera.position,
            forward: camera.forward,
            pixel_side: 2.0 * (camera.yfov * 0.5).tan() / h as f32,
        };
        let eval_level = SsbcPass::eval_level(
            &ssbc_camera,
            (bounds.center() - camera.position).dot(camera.forward),
            bound,
            t.ssbc.levels(),
            &settings.ssbc,
        );
        // Near and far planes enclose the scene's bounding sphere.
        let far = (camera.position - bounds.center()).length() + bounds.radius() * 1.05;
        let near = (far * 1e-4).max(1e-4);
        let view_proj = camera.projection(w as f32 / h as f32, near, far) * camera.view();

        let faults = &mut self.fault;
        let mut checkpoint = |pass: &str| match faults.take_if(|f| f == pass) {
            Some(f) => Err(Error::InvalidParameter(format!(
                "injected fault after {f} (a test of recovery)"
            ))),
            None => Ok(()),
        };
        // Frames in a host's command buffer are labelled, not timed (ssbc
        // cannot know when the host's submission finishes).
        let timed = !matches!(sink, Sink::Host { .. });
        self.profiler.begin_frame(rec.cmd, slot, timed);
        self.shadow_maps.record(
            &mut rec,
            &mut self.profiler,
            pool,
            &cache.gpu_scene,
            shadows,
        )?;
        checkpoint("shadow_maps")?;
        if ism.vpl_count > 0 {
            self.ism.record(&mut rec, &mut self.profiler, pool, ism)?;
        }
        checkpoint("ism")?;
        self.gbuffer.record(
            &mut rec,
            &mut self.profiler,
            pool,
            &cache.gpu_scene,
            &t.gbuffer,
            view_proj,
            camera.position,
        )?;
        checkpoint("gbuffer")?;
        self.direct_lighting.record(
            &mut rec,
            &mut self.profiler,
            pool,
            &t.gbuffer,
            shadows,
            &t.direct,
        )?;
        self.indirect_bounded.record(
            &mut rec,
            &mut self.profiler,
            pool,
            &t.gbuffer,
            &t.direct,
            ism,
            bound,
            &t.indirect,
            &t.s0,
        )?;
        checkpoint("indirect_bounded")?;
        if steps > 0 {
            self.ssbc.record(
                &mut rec,
                &mut self.profiler,
                pool,
                (&t.gbuffer).into(),
                &t.s0,
                &SsbcInputs {
                    camera: &ssbc_camera,
                    bound,
                    eval_level,
                    settings: &settings.ssbc,
                },
                &t.ssbc,
            )?;
        }
        checkpoint("ssbc")?;
        self.profiler.end_frame(rec.cmd);
        rec.use_buffer(&t.ssbc.stats, Access::HostRead);
        let images = frame.readback_images(settings.debug_readback);
        if let Sink::Host { output, layer, .. } = sink {
            let source = t
                .layer(layer)
                .ok_or_else(|| Error::InvalidParameter(format!("no layer '{layer}'")))?;
            let out = Image::from_host(
                &device,
                output.image,
                output.view,
                crate::vk::ImageDesc::new_2d(
                    output.format,
                    w,
                    h,
                    vk::ImageUsageFlags::TRANSFER_DST,
                ),
                output.layout,
            );
            rec.copy_image(source, &out, (w, h));
            rec.flush_barriers();
            return Ok(Outcome::Host);
        }
        if let Some(buffers) = frame
            .readback
            .as_ref()
            .filter(|_| matches!(sink, Sink::Readback))
        {
            for ((_, image), (_, buffer)) in images.iter().zip(buffers) {
                rec.copy_image_to_buffer(image, buffer);
                rec.use_buffer(buffer, Access::HostRead);
            }
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
        if let Sink::Gpu(layer) = sink {
            self.output = Some(FrameOutput {
                slot,
                layer: layer.to_string(),
                done,
            });
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
        let frame = &self.slots[slot];
        let t = frame.targets.as_ref().expect("prepared");
        let ism = &frame.ism.as_ref().expect("prepared").1;
        let cache = self.scene_cache.as_ref().expect("scene cache built");
        let buffers = frame.readback.as_ref().expect("allocated for readback");
        let mut layers = Vec::new();
        let mut samples = Vec::new();
        let mut ism_depth = None;
        for (name, buffer) in buffers {
            if let Some(k) = name.strip_prefix("samples_") {
                debug_assert_eq!(k.parse::<usize>().ok(), Some(samples.len() + 1));
                samples.push(buffer.read::<f32>()?);
            } else if name == "ism_atlas" {
                ism_depth = Some(buffer.read::<f32>()?);
            } else {
                layers.push(Layer {
                    name: name.clone(),
                    rgba: buffer.read::<f32>()?,
                });
            }
        }
        let image = layers.remove(0);
        let fallback_counts = t.ssbc.fallback_counts()?;
        let geometry: Vec<bool> = layers[0]
            .rgba
            .chunks_exact(4)
            .map(|p| p[3] != 0.0)
            .collect();
        let ssbc_steps = samples
            .iter()
            .enumerate()
            .map(|(k, counts)| {
                let on_geometry: Vec<f32> = counts
                    .iter()
                    .zip(&geometry)
                    .filter(|(_, g)| **g)
                    .map(|(c, _)| *c)
                    .collect();
                let name = format!("ssbc_step_{}", k + 1);
                SsbcStepTiming {
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
                }
            })
            .collect();
        let ism_readback = ism_depth.map(|depth| IsmReadback {
            width: ism.pyramid.desc.width,
            height: ism.pyramid.desc.height,
            tile: ism.tile,
            tiles_per_row: ism.tiles_per_row,
            far: ism.far,
            depth,
            point_radius: ism.point_radius,
        });
        let vpl_set = &cache.vpls.as_ref().expect("VPLs traced").set;
        // Keep the final image for the host (see `output_image`).
        self.output = Some(FrameOutput {
            slot,
            layer: "final".into(),
            done,
        });
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
            vpls: vpl_set.vpls.clone(),
            bound,
            ism: ism_readback,
            samples,
        })))
    }
}
