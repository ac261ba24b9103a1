//! The frame: which passes run in which order, and what comes back.
//!
//! ```text
//!  CPU: BVH ─▶ VPLs (light tracing) ─▶ ISM rays, ISM points (scene_cache)
//!  GPU: shadow_maps ─▶ ism_splat (ray layer + points) ─▶ gbuffer ─▶ direct_lighting
//!        ─▶ indirect_bounded (S0 = T Le + T_b L^) ─▶ ssbc_geometry_mips
//!        ─▶ ssbc_step_1 … ssbc_step_K (S_k = T_r S_{k-1}, final += S_k)
//!        ─▶ temporal (resident frames: the indirect light's running mean)
//!       ─▶ read-back / kept on the GPU / copied into the host's image
//! ```
//!
//! `Passes::record` is the list of passes in frame order; each pass owns
//! its per-slot resources (`src/passes/`).

mod accumulate;
mod guard_band;
mod history;
mod limits;
mod readback;

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::gpu_scene::SlotScene;
use crate::passes::direct_lighting::{DirectLight, DirectLightingPass};
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::indirect_bounded::{BoundedLighting, IndirectBoundedPass, VplVisibility};
use crate::passes::ism::{Ism, IsmPass};
use crate::passes::shadow_maps::{ShadowMapPass, ShadowMaps};
use crate::passes::ssbc::{SsbcCamera, SsbcPass};
use crate::passes::temporal::{HistoryStep, TemporalPass, TemporalReads};
use crate::passes::{FrameView, Recording, SlotSetup, Stage};
use crate::resident::{ResidentScene, SceneVersions};
use crate::scene::Scene;
use crate::scene_cache::SceneCache;
use crate::settings::Visibility;
pub use crate::settings::{Bound, RenderSettings, RendererConfig};
use crate::timings::{monotonic_ns, CpuSpan};
pub use crate::timings::{CpuTimings, SsbcStepTiming, Timings};
use crate::vk::HostImage;
use crate::vk::{
    Access, CommandPool, Device, GpuFrameTimes, GpuProfiler, Image, Instance, Recorder, Validation,
    ValidationLog,
};
use guard_band::GuardBand;
use history::{History, HistoryPlan, Motion};
use readback::{hand_off_to_host, FrameImages, FrameRecord, ReadbackBuffers};
pub use readback::{Frame, IsmReadback, Layer, LayerImage};

/// Bytes of device memory one frame slot's resources take for `scene` at
/// `settings` (an estimate from the sizes the passes allocate, within a few
/// percent); a frame that would not fit in the device's largest
/// device-local heap is refused before anything is allocated. Frames in
/// flight at once ([`Renderer::render_to_gpu`], [`FRAME_SLOTS`]) each take
/// a slot. With `history.enabled` it counts the temporal history's images
/// (48 bytes per pixel), which only resident frames allocate.
///
/// ```
/// let scene = ssbc::scene::load("cornell").unwrap();
/// let hd = ssbc::renderer::frame_memory(&scene, &ssbc::RenderSettings::new(1920, 1080));
/// assert!(hd > 1 << 30);
/// ```
pub fn frame_memory(scene: &Scene, settings: &RenderSettings) -> u64 {
    limits::frame_memory(settings, scene.lights.len())
}

/// The passes that run once per G-buffer layer: its G-buffer and its
/// clamped lighting `S0`.
struct LayerStages {
    gbuffer: Stage<GBufferPass>,
    direct_lighting: Stage<DirectLightingPass>,
    indirect_bounded: Stage<IndirectBoundedPass>,
}

/// What one layer's stages wrote in a slot.
type LayerImages<'a> = (&'a GBuffer, &'a DirectLight, &'a BoundedLighting);

impl LayerStages {
    fn new(device: &Arc<Device>, layer: u32) -> Result<Self> {
        Ok(Self {
            gbuffer: Stage::new(GBufferPass::new(device, layer)?, FRAME_SLOTS),
            direct_lighting: Stage::new(DirectLightingPass::new(device, layer)?, FRAME_SLOTS),
            indirect_bounded: Stage::new(IndirectBoundedPass::new(device, layer)?, FRAME_SLOTS),
        })
    }

    /// The layer's G-buffer (peeled behind `front` on layer 1), direct
    /// lighting and bounded indirect lighting: its G-buffer and `S0` (and
    /// what it sends as SSBC sources).
    fn run(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        (scene, front): (SlotScene<'_>, Option<&GBuffer>),
        (shadows, ism): (&ShadowMaps, &Ism),
    ) -> Result<(&GBuffer, &BoundedLighting)> {
        let gbuffer = self.gbuffer.run(cx, setup, (scene, front))?;
        let direct = self.direct_lighting.run(cx, setup, (gbuffer, shadows))?;
        let visibility = match scene.top_level {
            Some(tlas) => VplVisibility::Exact(tlas),
            None => VplVisibility::Ism,
        };
        let bounded = self
            .indirect_bounded
            .run(cx, setup, (gbuffer, direct, ism, visibility))?;
        Ok((gbuffer, bounded))
    }

    fn images(&self, slot: usize) -> Option<LayerImages<'_>> {
        Some((
            self.gbuffer.resources(slot)?,
            self.direct_lighting.resources(slot)?,
            self.indirect_bounded.resources(slot)?,
        ))
    }

    fn forget(&mut self, slot: usize) {
        self.gbuffer.forget(slot);
        self.direct_lighting.forget(slot);
        self.indirect_bounded.forget(slot);
    }
}

/// The technique passes, each with its resources in every frame slot.
struct Passes {
    shadow_maps: Stage<ShadowMapPass>,
    ism: Stage<IsmPass>,
    /// Layer 0, the visible surfaces; layer 1, the deep G-buffer's second
    /// layer (`ssbc.layers` 2).
    layers: [LayerStages; 2],
    ssbc: Stage<SsbcPass>,
    /// Temporal history (resident frames).
    temporal: Stage<TemporalPass>,
    /// Whether each slot's last frame ran `temporal` (its output is then
    /// the final image).
    temporal_ran: [bool; FRAME_SLOTS],
}

/// How a frame uses temporal history: its fold, and the slot it reads.
#[derive(Clone, Copy)]
struct HistoryFrame {
    step: HistoryStep,
    previous_slot: Option<usize>,
}

impl Passes {
    fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            shadow_maps: Stage::new(ShadowMapPass::new(device)?, FRAME_SLOTS),
            ism: Stage::new(IsmPass::new(device)?, FRAME_SLOTS),
            layers: [LayerStages::new(device, 0)?, LayerStages::new(device, 1)?],
            ssbc: Stage::new(SsbcPass::new(device)?, FRAME_SLOTS),
            temporal: Stage::new(TemporalPass::new(device)?, FRAME_SLOTS),
            temporal_ran: [false; FRAME_SLOTS],
        })
    }

    /// The frame: every pass in order, each given what it reads from the
    /// passes before it (its resources are brought up to `setup` first).
    fn record(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        scene: SlotScene<'_>,
        history: Option<HistoryFrame>,
    ) -> Result<()> {
        self.temporal_ran[setup.slot] = false;
        let shadows = self.shadow_maps.run(cx, setup, scene)?;
        let objects = (scene.objects, setup.cache.versions.objects);
        let ism = self.ism.run(cx, setup, objects)?;
        let [layer0, layer1] = &mut self.layers;
        let (front, bounded) = layer0.run(cx, setup, (scene, None), (shadows, ism))?;
        let normal_maps = cx.view.normal_maps;
        let visible = bounded.ssbc_layer(front, normal_maps);
        let ssbc = &setup.settings.ssbc;
        let hidden = if ssbc.layers == 2 && ssbc.steps > 0 {
            let (gbuffer, bounded) = layer1.run(cx, setup, (scene, Some(front)), (shadows, ism))?;
            Some(bounded.ssbc_layer(gbuffer, normal_maps))
        } else {
            // Not drawn this frame: free what an earlier frame held.
            layer1.forget(setup.slot);
            None
        };
        self.ssbc.run(cx, setup, (visible, hidden))?;
        if let Some(history) = history {
            self.temporal(cx, setup, history)?;
        }
        Ok(())
    }

    /// Folds the frame into the history the previous frame left in its
    /// slot (taken out of its stage while this slot's pass records).
    fn temporal(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        history: HistoryFrame,
    ) -> Result<()> {
        let slot = setup.slot;
        let (gbuffer, direct, bounded) = self.layers[0].images(slot).expect("recorded above");
        let ssbc = self.ssbc.resources(slot).expect("recorded above");
        let final_image = readback::frame_final(ssbc, bounded);
        let previous_slot = history.previous_slot.filter(|&s| s != slot);
        let previous = previous_slot.and_then(|s| self.temporal.take(s));
        let previous_gbuffer = previous_slot.and_then(|s| self.layers[0].gbuffer.resources(s));
        let reads = TemporalReads {
            gbuffer,
            final_image,
            direct: &direct.radiance,
            previous: previous_gbuffer.zip(previous.as_ref().map(|p| &p.resources)),
            step: history.step,
        };
        let result = self.temporal.run(cx, setup, reads).map(|_| ());
        if let Some(s) = previous_slot {
            self.temporal.restore(s, previous);
        }
        self.temporal_ran[slot] = result.is_ok();
        result
    }

    /// The images the slot's last recorded frame wrote.
    fn images(&self, slot: usize) -> Option<FrameImages<'_>> {
        let ssbc = self.ssbc.resources(slot)?;
        let (gbuffer, direct, bounded) = self.layers[0].images(slot)?;
        // Stale resources of an earlier two-layer frame are not this frame's.
        let layer1 = ssbc
            .layer1()
            .and_then(|_| self.layers[1].images(slot))
            .map(|(gbuffer, _, bounded)| (gbuffer, bounded));
        let temporal = self.temporal_ran[slot]
            .then(|| self.temporal.resources(slot))
            .flatten();
        Some(FrameImages {
            gbuffer,
            direct,
            bounded,
            ssbc,
            ism: self.ism.resources(slot)?,
            layer1,
            temporal,
        })
    }

    /// Drops the slot's resources (after a frame that was not submitted).
    fn forget(&mut self, slot: usize) {
        self.shadow_maps.forget(slot);
        self.ism.forget(slot);
        for layer in &mut self.layers {
            layer.forget(slot);
        }
        self.ssbc.forget(slot);
        self.temporal.forget(slot);
        self.temporal_ran[slot] = false;
    }

    /// Device memory the temporal history's images take in every slot.
    fn history_bytes(&self) -> u64 {
        (0..FRAME_SLOTS)
            .filter_map(|slot| self.temporal.resources(slot))
            .map(|t| {
                let (w, h) = (t.output.desc.width, t.output.desc.height);
                crate::passes::temporal::slot_bytes((w, h))
            })
            .sum()
    }
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

/// The image a frame handed over.
struct FrameOutput {
    slot: usize,
    layer: Layer,
    done: u64,
    /// The guard band's margin around the image.
    margin: u32,
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

pub use crate::gpu_scene::FRAME_SLOTS;

/// A frame submitted by [`Renderer::render_to_gpu`].
#[derive(Clone, Debug)]
pub struct GpuSubmission {
    /// Timeline value that signals the frame is done (see [`Renderer::output_image`]).
    pub value: u64,
    /// GPU times of the previous frame that used this frame slot, read
    /// without waiting (None for a slot's first frame or without timestamps).
    pub previous_timings: Option<GpuFrameTimes>,
}

/// Where a frame goes, and what it returns: read back ([`ReadBack`]),
/// kept on the GPU ([`KeepOnGpu`]), or recorded into a host's command
/// buffer ([`IntoHost`]). Each mode has its own way out of
/// [`Renderer::frame`].
trait FrameSink {
    /// What the frame returns.
    type Output;
    /// The host's command buffer to record into (None: ssbc's own, timed).
    fn host_command_buffer(&self) -> Option<vk::CommandBuffer> {
        None
    }
    /// Sends the frame recorded in `rec` on.
    fn finish(self, rec: Recorder<'_>, frame: Finish<'_>) -> Result<Self::Output>;
}

/// Read back to the host; the frame is waited for.
struct ReadBack;

/// Kept on the GPU as this layer; ssbc submits.
struct KeepOnGpu(Layer);

/// Recorded into the host's command buffer; the layer is copied into the
/// host's image.
struct IntoHost<'a> {
    cmd: vk::CommandBuffer,
    output: &'a HostImage,
    layer: Layer,
}

/// A recorded frame on its way out, with the renderer state it updates.
struct Finish<'r> {
    images: FrameImages<'r>,
    device: &'r Arc<Device>,
    slot: usize,
    /// The image's settings, and the guard band's wider frame's.
    inner: &'r RenderSettings,
    settings: &'r RenderSettings,
    band: Option<GuardBand>,
    view: &'r FrameView,
    cache: &'r SceneCache,
    spans: Vec<CpuSpan>,
    /// Passes that kept the slot's previous output.
    reused: Vec<String>,
    record_start: u64,
    /// When the frame was submitted (ns, CLOCK_MONOTONIC; set by `submit`).
    submit_ns: u64,
    previous_timings: Option<GpuFrameTimes>,
    readback: &'r mut Option<ReadbackBuffers>,
    profiler: &'r mut GpuProfiler,
    slot_done: &'r mut u64,
    output: &'r mut Option<FrameOutput>,
}

impl Finish<'_> {
    /// Submits the frame recorded in `rec`, keeping `layer` as the
    /// renderer's output image; returns the timeline value that signals it
    /// done.
    fn submit(&mut self, mut rec: Recorder<'_>, layer: Layer) -> Result<u64> {
        rec.flush_barriers();
        self.submit_ns = monotonic_ns();
        self.spans.push(CpuSpan::between(
            "record",
            self.record_start,
            self.submit_ns,
        ));
        let done = rec.submit()?;
        self.profiler.submitted(self.slot);
        *self.slot_done = done;
        *self.output = Some(FrameOutput {
            slot: self.slot,
            layer,
            done,
            margin: self.band.map_or(0, |b| b.margin),
        });
        Ok(done)
    }
}

impl FrameSink for ReadBack {
    type Output = Frame;
    fn finish(self, mut rec: Recorder<'_>, mut f: Finish<'_>) -> Result<Frame> {
        let wanted = f.images.readback(f.settings.debug_readback);
        readback::ensure_buffers(f.device, f.readback, &wanted)?;
        let buffers = f.readback.as_ref().expect("made above");
        for ((_, image), (_, buffer)) in wanted.iter().zip(buffers) {
            rec.copy_image_to_buffer(image, buffer);
            rec.use_buffer(buffer, Access::HostRead);
        }
        let done = f.submit(rec, Layer::Final)?;
        let wait_start = monotonic_ns();
        f.device.wait(done)?;
        f.spans
            .push(CpuSpan::between("wait_for_gpu", wait_start, monotonic_ns()));
        readback::read_frame(
            f.readback.as_ref().expect("made above"),
            FrameRecord {
                device: f.device,
                settings: f.inner,
                band: f.band,
                view: f.view,
                images: f.images,
                cache: f.cache,
                gpu_times: f.profiler.resolve(f.slot)?,
                spans: f.spans,
                reused: f.reused,
                submit_ns: f.submit_ns,
            },
        )
    }
}

impl FrameSink for KeepOnGpu {
    type Output = GpuSubmission;
    fn finish(self, rec: Recorder<'_>, mut f: Finish<'_>) -> Result<GpuSubmission> {
        let value = f.submit(rec, self.0)?;
        Ok(GpuSubmission {
            value,
            previous_timings: f.previous_timings,
        })
    }
}

impl FrameSink for IntoHost<'_> {
    type Output = ();
    fn host_command_buffer(&self) -> Option<vk::CommandBuffer> {
        Some(self.cmd)
    }
    fn finish(self, mut rec: Recorder<'_>, f: Finish<'_>) -> Result<()> {
        hand_off_to_host(&mut rec, &f.images, self.output, self.layer, f.band)
    }
}

/// The camera and bound of a frame: near and far planes enclose the
/// scene's bounding sphere.
/// With a guard band, `settings` are the wider frame's.
fn frame_view(
    scene: &Scene,
    settings: &RenderSettings,
    cache: &SceneCache,
    band: Option<GuardBand>,
) -> Result<FrameView> {
    let mut camera = scene.camera(settings.camera)?;
    let (w, h) = (settings.width, settings.height);
    if let Some(band) = band {
        camera.yfov = band.widen_yfov(camera.yfov, h - 2 * band.margin);
    }
    let bounds = cache.bounds;
    let far = (camera.position - bounds.center()).length() + bounds.radius() * 1.05;
    let near = (far * 1e-4).max(1e-4);
    Ok(FrameView {
        camera: SsbcCamera {
            position: camera.position,
            forward: camera.forward,
            up: camera.up,
            pixel_side: 2.0 * (camera.yfov * 0.5).tan() / h as f32,
        },
        view_proj: camera.projection(w as f32 / h as f32, near, far) * camera.view(),
        centre_depth: (bounds.center() - camera.position).dot(camera.forward),
        bound: settings.bound.resolve(cache.diagonal()),
        diagonal: cache.diagonal(),
        glossy: scene
            .materials
            .iter()
            .any(|m| m.reflectance != crate::scene::Reflectance::Lambertian),
        normal_maps: scene.materials.iter().any(|m| m.normal_texture.is_some()),
    })
}

/// Whether the frame tests VPL visibility exactly (ray queries): asked
/// for, and possible on this device and scene (an error naming why not).
/// [`Visibility::Auto`] is resolved before (accumulated frames).
fn exact_visibility(settings: &RenderSettings, cache: &SceneCache) -> Result<bool> {
    match settings.visibility {
        Visibility::Auto | Visibility::Ism => Ok(false),
        Visibility::Exact if cache.gpu_scene.rays.is_some() => Ok(true),
        Visibility::Exact => Err(Error::InvalidParameter(
            "exact visibility (ssbc.visibility) needs a device with ray queries \
             (VK_KHR_ray_query) and a scene without alpha-masked materials"
                .into(),
        )),
    }
}

/// The frame's recorder: ssbc's command buffer, or the host's `host`.
fn begin_recording<'a>(
    commands: &'a mut CommandPool,
    device: &'a Arc<Device>,
    host: Option<vk::CommandBuffer>,
    cache: &mut SceneCache,
) -> Result<Recorder<'a>> {
    let Some(cmd) = host else {
        return commands.begin();
    };
    if cache.gpu_scene.has_pending_uploads() {
        // Texture copies go through ssbc's own submission here (ssbc's
        // timeline cannot see when the host's command buffer finishes, so
        // staging could not be freed safely).
        let mut upload = commands.begin()?;
        cache.gpu_scene.record_uploads(&mut upload)?;
        device.wait(upload.submit()?)?;
        cache.gpu_scene.release_staging();
    }
    Ok(Recorder::for_host(device, cmd))
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
        self.run(scene, versions, settings, sink, Some(slot), false)
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

    /// Records a frame in `slot` (the host's, or the next of ssbc's own,
    /// waiting for the frame that used it last) and sends it where `sink`
    /// says; after a failure the slot's resources are dropped. `resident`
    /// frames of ssbc's own keep temporal history; any other cuts it.
    fn run<S: FrameSink>(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        sink: S,
        host_slot: Option<usize>,
        resident: bool,
    ) -> Result<S::Output> {
        limits::check_settings(&self.device, settings, scene.lights.len())?;
        let (slot, previous_timings) = match host_slot {
            Some(slot) => (slot, None),
            None => {
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
        let history = (resident && host_slot.is_none() && settings.history.enabled)
            .then(|| self.history.plan(slot, (scene, versions), settings));
        if history.is_none() {
            self.history.reset();
        }
        let frame = FrameRequest {
            versions,
            slot,
            previous_timings,
            history,
        };
        let result = self.frame(scene, settings, sink, frame);
        if result.is_err() {
            self.history.reset();
            // Whatever was recorded was never submitted, but the resources'
            // tracked states say otherwise: forget them, and the scene's
            // GPU copy, so the next frame starts from known states.
            self.passes.forget(slot);
            self.readback[slot] = None;
            self.scene_cache = None;
            if self.output.as_ref().is_some_and(|o| o.slot == slot) {
                self.output = None;
            }
        }
        result
    }

    /// Records one frame and sends it where `sink` says.
    fn frame<S: FrameSink>(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        sink: S,
        request: FrameRequest,
    ) -> Result<S::Output> {
        let FrameRequest {
            versions,
            slot,
            previous_timings,
            history,
        } = request;
        let host_settings = settings;
        // A still view's frame continues the light paths after its
        // history's (an independent VPL set), and it converges to the
        // truth only with exact visibility (where possible, by default).
        let shifted;
        let still = history.is_some_and(|plan| plan.motion == Motion::Still);
        let exact_when_still = still
            && settings.visibility == Visibility::Auto
            && crate::ray_scene::exact_visibility_possible(&self.device, scene);
        let settings = match history {
            Some(plan) if plan.path_offset > 0 || exact_when_still => {
                let mut s = settings.clone();
                s.vpl.first_path = s.vpl.first_path.saturating_add(plan.path_offset);
                if exact_when_still {
                    s.visibility = Visibility::Exact;
                }
                shifted = s;
                &shifted
            }
            _ => settings,
        };
        let device = self.device.clone();
        let mut spans = Vec::new();
        let cache = SceneCache::update(
            &mut self.scene_cache,
            &device,
            scene,
            versions,
            settings,
            &mut spans,
        )?;
        // The slot's previous frame is done: its copy of the objects'
        // transforms can be rewritten.
        cache
            .gpu_scene
            .write_objects(slot, scene, versions.objects)?;
        // With a guard band every pass renders the wider frame (`settings`).
        let (band, wide) = GuardBand::widen_frame(&device, scene, settings, cache)?;
        let (inner, settings) = (settings, wide.as_ref().unwrap_or(settings));
        let view = frame_view(scene, settings, cache, band)?;

        let record_start = monotonic_ns();
        let host = sink.host_command_buffer();
        let mut rec = begin_recording(&mut self.commands[slot], &device, host, cache)?;
        // The first frame after an upload copies the scene's textures (and
        // builds its meshes' acceleration structures).
        cache.gpu_scene.record_uploads(&mut rec)?;
        let exact = exact_visibility(settings, cache)?;
        if exact {
            let rays = cache.gpu_scene.rays.as_mut().expect("checked");
            rays.record_top_level(&mut rec, slot, scene, versions.objects)?;
        }
        let cache = &*cache;
        // Frames in a host's command buffer are labelled, not timed (ssbc
        // cannot know when the host's submission finishes).
        self.profiler.begin_frame(rec.cmd, slot, host.is_none());
        let setup = SlotSetup {
            device: &device,
            slot,
            settings,
            scene,
            cache,
        };
        let mut reused = Vec::new();
        let mut cx = Recording {
            rec: &mut rec,
            profiler: &mut self.profiler,
            view: &view,
            settings,
            fault: &mut self.fault,
            // A host's command buffer may never run: nothing it records is
            // kept for a later frame.
            reuse: settings.reuse_unchanged && host.is_none(),
            reused: &mut reused,
        };
        let history_frame = history.map(|plan| HistoryFrame {
            step: self
                .history
                .step(&plan, settings, (view.view_proj, view.camera.position)),
            previous_slot: plan.previous_slot,
        });
        let mut slot_scene = cache.gpu_scene.for_slot(slot);
        if exact {
            slot_scene.top_level = cache
                .gpu_scene
                .rays
                .as_ref()
                .and_then(|r| r.top_level(slot));
        }
        self.passes
            .record(&mut cx, &setup, slot_scene, history_frame)?;
        self.profiler.end_frame(rec.cmd);
        let light_paths = cache.vpls().set.paths;

        let images = self.passes.images(slot).expect("recorded above");
        rec.use_buffer(&images.ssbc.stats, Access::HostRead);
        let output = sink.finish(
            rec,
            Finish {
                images,
                device: &device,
                slot,
                inner,
                settings,
                band,
                view: &view,
                cache,
                spans,
                reused,
                record_start,
                submit_ns: 0,
                previous_timings,
                readback: &mut self.readback[slot],
                profiler: &mut self.profiler,
                slot_done: &mut self.slot_done[slot],
                output: &mut self.output,
            },
        )?;
        if let Some(plan) = history {
            let eye = (view.view_proj, view.camera.position);
            self.history.commit(
                &plan,
                slot,
                (scene, versions),
                host_settings,
                eye,
                light_paths,
            );
        }
        Ok(output)
    }
}

/// A frame to record: the scene's versions, its slot, and how it uses
/// temporal history.
struct FrameRequest {
    versions: SceneVersions,
    slot: usize,
    previous_timings: Option<GpuFrameTimes>,
    history: Option<HistoryPlan>,
}
