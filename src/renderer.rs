//! The frame: which passes run in which order, and what comes back.
//!
//! ```text
//!  CPU: BVH ─▶ VPLs (light tracing) ─▶ ISM rays, ISM points (scene_cache)
//!  GPU: shadow_maps ─▶ ism_splat (ray layer + points + fill) ─▶ gbuffer ─▶ direct_lighting
//!        ─▶ indirect_bounded (S0 = T Le + T_b L^) ─▶ ssbc_geometry_mips
//!        ─▶ ssbc_step_1 … ssbc_step_K (S_k = T_r S_{k-1}, final += S_k)
//!        ─▶ temporal (resident frames: the indirect light's running mean)
//!       ─▶ read-back / kept on the GPU / copied into the host's image
//! ```
//!
//! `Passes::record` is the list of passes in frame order; each pass owns
//! its per-slot resources (`src/passes/`).

mod accumulate;
mod frame;
mod frame_passes;
mod guard_band;
mod history;
mod limits;
mod readback;
mod sink;

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
pub use crate::gpu_scene::FRAME_SLOTS;
pub use crate::layer::Layer;
pub use crate::memory::{FrameMemory, MemoryReport};
use crate::resident::{ResidentScene, SceneVersions};
use crate::scene::Scene;
use crate::scene_cache::SceneCache;
pub use crate::settings::{Bound, RenderSettings, RendererConfig};
pub use crate::timings::{CpuTimings, SsbcStepTiming, Timings};
use crate::vk::HostImage;
use crate::vk::{
    CommandPool, Device, GpuFrameTimes, GpuProfiler, Image, Instance, Validation, ValidationLog,
};
use frame_passes::Passes;
use history::History;
use readback::ReadbackBuffers;
pub use readback::{Frame, IsmReadback, LayerImage};
pub use sink::GpuSubmission;
use sink::{FrameOutput, IntoHost, KeepOnGpu, ReadBack};

/// Device memory one frame slot's resources take for `scene` at
/// `settings`, by part: the bytes the passes ask for, before anything is
/// allocated ([`Renderer::frame_memory`] adds a device's alignment). A frame
/// that would not fit in the device's largest device-local heap is refused
/// before anything is allocated. Frames in flight at once
/// ([`Renderer::render_to_gpu`], [`FRAME_SLOTS`]) each take a slot. With
/// `history.enabled` it counts the temporal history's images, which only
/// resident frames allocate, and with `history.converging_isms` the larger
/// ISMs a still view's frames may take (without a device, as if visibility
/// could not be exact); the read-back part is that of
/// [`Renderer::render`]'s frames.
///
/// ```
/// let scene = ssbc::scene::load("cornell").unwrap();
/// let hd = ssbc::renderer::frame_memory(&scene, &ssbc::RenderSettings::new(1920, 1080));
/// println!("1080p: {}", hd.summary(1920 * 1080));
/// assert!(hd.ssbc_pyramids > 0 && hd.total() > hd.ssbc_pyramids);
/// // With history: what the slot keeps between frames, and what it rewrites.
/// assert_eq!(hd.persistent() + hd.transient(), hd.total());
/// assert!(hd.persistent() >= hd.history + hd.gbuffer);
/// ```
pub fn frame_memory(scene: &Scene, settings: &RenderSettings) -> FrameMemory {
    let uses = limits::FrameUse::ALL.with_scene(scene);
    limits::slot_memory(None, settings, scene.lights.len(), uses)
}

/// How a frame slot is used, for [`frame_memory_of`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SlotUse {
    /// [`Renderer::render`]'s frames: read back, no history.
    Immediate,
    /// Resident frames ([`Renderer::render_resident`], the viewer, a
    /// host's): the temporal history where `history.enabled`, nothing
    /// read back.
    Resident,
}

/// [`frame_memory`] of a slot used one way: what such a slot allocates
/// (an immediate slot's shadow maps and ISM atlas share memory with SSBC's
/// pyramids, and S0 is summed in the direct light's image where neither
/// history nor output layers read it later).
///
/// ```
/// use ssbc::renderer::{frame_memory_of, SlotUse};
/// let scene = ssbc::scene::load("cornell").unwrap();
/// let s = ssbc::RenderSettings::new(1920, 1080);
/// let immediate = frame_memory_of(&scene, &s, SlotUse::Immediate);
/// let resident = frame_memory_of(&scene, &s, SlotUse::Resident);
/// assert!(immediate.history == 0 && resident.readback == 0 && resident.history > 0);
/// ```
pub fn frame_memory_of(scene: &Scene, settings: &RenderSettings, slot: SlotUse) -> FrameMemory {
    let resident = slot == SlotUse::Resident;
    let uses = limits::FrameUse {
        history: resident && settings.history.enabled,
        readback: !resident,
        resident,
        ..limits::FrameUse::ALL
    }
    .with_scene(scene);
    limits::slot_memory(None, settings, scene.lights.len(), uses)
}

/// The renderer: a device, its passes, and a command pool per frame slot.
pub struct Renderer {
    // Field order is drop order: passes and pools before the device.
    passes: Passes,
    profiler: GpuProfiler,
    /// Each slot's read-back buffers (frames read back to the host).
    readback: Vec<Option<ReadbackBuffers>>,
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
    /// What the last resident frame left in temporal history.
    history: History,
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
    /// Where the frame starts in it: (0, 0), or the guard band's margin
    /// (`ssbc.guard_band`; the image is then larger than the frame).
    pub origin: (u32, u32),
    /// The frame's width and height.
    pub extent: (u32, u32),
    /// The layout it is in.
    pub layout: vk::ImageLayout,
    /// Timeline semaphore to wait on before reading it...
    pub semaphore: vk::Semaphore,
    /// ...for this value.
    pub value: u64,
}

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
        let missing = device.enabled_features().missing();
        if !missing.is_empty() {
            return Err(Error::NoDevice(format!(
                "the renderer needs features this device does not have enabled: {} (the SSBC post-process alone does not)",
                missing.join(", ")
            )));
        }
        if device.profiling().timestamp_valid_bits == 0 && timestamps {
            log::warn!("the device's queue has no timestamps: GPU timings will be absent (null)");
        }
        let validation_log = device.instance.validation_log();
        Ok(Self {
            passes: Passes::new(&device)?,
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
            readback: (0..FRAME_SLOTS).map(|_| None).collect(),
            scene_cache: None,
            fault: None,
            history: History::default(),
            device,
            validation_log,
            output: None,
        })
    }

    /// The last frame's final image, on the GPU, with its layout and the
    /// timeline semaphore value to wait for (None before the first frame).
    pub fn output_image(&self) -> Option<GpuImage> {
        let (done, m) = self.output.as_ref().map(|o| (o.done, o.margin))?;
        self.output().map(|image| GpuImage {
            image: image.raw,
            view: image.view,
            format: image.desc.format,
            origin: (m, m),
            extent: (image.desc.width - 2 * m, image.desc.height - 2 * m),
            layout: image.state.get().layout,
            semaphore: self.device.timeline(),
            value: done,
        })
    }

    unstable_pub! {
        /// The last frame's output image as a tracked [`Image`] (for
        /// consumers that record their own commands on the same queue, such
        /// as the viewer; unstable).
        fn output(&self) -> Option<&Image> {
            let out = self.output.as_ref()?;
            self.passes.images(out.slot)?.layer(out.layer)
        }
    }

    /// The device.
    pub fn device(&self) -> &Arc<Device> {
        &self.device
    }

    /// [`frame_memory`] on this renderer's device: each resource as the
    /// device's memory requirements say, alignment and padding included
    /// (what the allocator then takes), for settings the device accepts
    /// (an image beyond its limits is counted by its texels).
    pub fn frame_memory(&self, scene: &Scene, settings: &RenderSettings) -> FrameMemory {
        let uses = limits::FrameUse::ALL.with_scene(scene);
        let lights = scene.lights.len();
        if crate::ray_scene::exact_visibility_possible(&self.device, scene) {
            // (A still view's frames test visibility exactly: no finer ISMs.)
            return limits::frame_memory(Some(&self.device), settings, lights, uses);
        }
        limits::slot_memory(Some(&self.device), settings, lights, uses)
    }

    /// Validation messages so far (stays readable after the renderer is dropped).
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.validation_log.clone()
    }

    /// Renders `scene` and reads the result back (waits for the GPU).
    /// Immediate mode: nothing about the scene is assumed to persist, so
    /// its BVH, VPLs, points and GPU copy are rebuilt (images, buffers and
    /// descriptor pools are still reused while the size and settings fit).
    /// See [`Renderer::render_resident`] for frames that redo only what changed.
    pub fn render(&mut self, scene: &Scene, settings: &RenderSettings) -> Result<Frame> {
        self.run(
            scene,
            SceneVersions::fresh(),
            settings,
            ReadBack,
            None,
            false,
        )
    }

    /// Renders a [`ResidentScene`] and reads the result back, redoing only
    /// the work its changes since the last frame require.
    pub fn render_resident(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
    ) -> Result<Frame> {
        let mut frame = self.run(
            scene.scene(),
            scene.versions(),
            settings,
            ReadBack,
            None,
            true,
        )?;
        frame.accumulated = self.accumulated_frames().max(1);
        Ok(frame)
    }

    /// Frames of a still view the last resident frame's temporal history
    /// averages (1 after any change; 0 without history: before the first
    /// resident frame, after an immediate-mode frame or with
    /// `history.enabled` off).
    pub fn accumulated_frames(&self) -> u32 {
        self.history.accumulated()
    }

    /// Device memory the temporal history takes now (bytes, every frame
    /// slot: the history, its reprojection and the image made from it).
    pub fn history_memory(&self) -> u64 {
        self.passes.history_bytes()
    }

    /// Records and submits a frame without waiting for it or reading it
    /// back; `layer` (one of [`Layer::outputs`]) is kept on the GPU as
    /// [`Renderer::output_image`]. Up to [`FRAME_SLOTS`] frames are in
    /// flight: this waits only for the frame that last used the same slot,
    /// whose timings it returns.
    pub fn render_to_gpu(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        layer: Layer,
    ) -> Result<GpuSubmission> {
        Self::check_layer(layer, settings)?;
        let versions = SceneVersions::fresh();
        self.run(scene, versions, settings, KeepOnGpu(layer), None, false)
    }

    /// [`Renderer::render_to_gpu`] for a [`ResidentScene`]: only what changed
    /// is redone (a camera move: the screen-space passes only).
    pub fn render_resident_to_gpu(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
        layer: Layer,
    ) -> Result<GpuSubmission> {
        Self::check_layer(layer, settings)?;
        let (scene, versions) = (scene.scene(), scene.versions());
        self.run(scene, versions, settings, KeepOnGpu(layer), None, true)
    }

    fn check_layer(layer: Layer, settings: &RenderSettings) -> Result<()> {
        let outputs = Layer::outputs(settings.ssbc.steps);
        if outputs.contains(&layer) {
            return Ok(());
        }
        let names: Vec<String> = outputs.iter().map(Layer::to_string).collect();
        Err(Error::InvalidParameter(format!(
            "layer {layer} cannot be handed over (have: {})",
            names.join(", ")
        )))
    }

    /// Records a frame of `scene` into the host's command buffer `cmd`
    /// (recording, outside a render pass) and copies `layer` (one of
    /// [`Layer::outputs`]) into the host's `output` image
    /// (`R32G32B32A32_SFLOAT`, `TRANSFER_DST` usage, the frame's size;
    /// left in `TRANSFER_DST_OPTIMAL` after a transfer write). The host
    /// ends and submits `cmd` and synchronises with its own semaphores; it
    /// passes the frame slot (`0..FRAME_SLOTS`) and guarantees the slot's
    /// previous frame has finished on the GPU. Such frames are labelled and
    /// timed (the query resets recorded into `cmd`; read them with
    /// [`Renderer::host_timings`]) and keep temporal history as
    /// [`Renderer::render_resident`] does, reading the history of the
    /// previous frame's slot: a host that alternates the slots accumulates
    /// a still view ([`Renderer::accumulated_frames`]), one that records
    /// every frame into the same slot starts anew each frame. They must not
    /// be interleaved with ssbc's own submissions while in flight. A change
    /// of geometry or materials uploads the scene with ssbc's own
    /// submission first (waited for).
    pub fn record_resident(
        &mut self,
        scene: &ResidentScene,
        settings: &RenderSettings,
        cmd: vk::CommandBuffer,
        slot: usize,
        output: &HostImage,
        layer: Layer,
    ) -> Result<()> {
        Self::check_layer(layer, settings)?;
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
        let sink = IntoHost { cmd, output, layer };
        // The host guarantees the slot's previous frame is done.
        let (scene, versions) = (scene.scene(), scene.versions());
        self.run(scene, versions, settings, sink, Some(slot), true)
    }

    /// GPU times of the frame last recorded into a host's command buffer in
    /// `slot` ([`Renderer::record_resident`]), per pass with the same names
    /// as ssbc's own frames, read without waiting once the host knows that
    /// frame has finished (its fence), e.g. before recording the slot
    /// again. None: the slot has no recorded frame, the device has no
    /// timestamps, or the results are not all available yet.
    pub fn host_timings(&self, slot: usize) -> Result<Option<GpuFrameTimes>> {
        if slot >= FRAME_SLOTS {
            return Err(Error::InvalidParameter(format!(
                "frame slot {slot} of {FRAME_SLOTS}"
            )));
        }
        if !self.profiler.has_frame(slot) {
            return Ok(None);
        }
        self.profiler.try_resolve(slot)
    }

    unstable_pub! {
        /// Makes the next frame fail after recording `pass` (`shadow_maps`,
        /// `ism`, `gbuffer`, `indirect_bounded` or `ssbc`), before
        /// submission: for tests that a failed frame leaves the renderer
        /// usable (unstable).
        fn inject_fault_after(&mut self, pass: &str) {
            self.fault = Some(pass.to_string());
        }
    }
}
