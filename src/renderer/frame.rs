//! Recording one frame: its slot, settings, scene cache, view, the passes
//! and where it goes.

use std::sync::Arc;

use ash::vk;

use super::frame_passes::{HistoryFrame, Passes};
use super::guard_band::GuardBand;
use super::history::{HistoryPlan, Motion};
use super::limits::{self, FrameUse};
use super::sink::{Finish, FrameSink};
use super::{Renderer, FRAME_SLOTS};
use crate::error::{Error, Result};
use crate::gpu_scene::SlotScene;
use crate::layer::Layer;
use crate::passes::ssbc::SsbcCamera;
use crate::passes::{FrameView, Recording, SlotSetup};
use crate::resident::SceneVersions;
use crate::scene::Scene;
use crate::scene_cache::SceneCache;
use crate::settings::{RenderSettings, Visibility};
use crate::timings::monotonic_ns;
use crate::vk::{Access, CommandPool, Device, GpuFrameTimes, GpuProfiler, Recorder};

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
    if !camera.jitter.is_finite() {
        return Err(Error::InvalidParameter(format!(
            "camera jitter {} is not finite",
            camera.jitter
        )));
    }
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
            principal: camera.jitter,
        },
        view_proj: camera.jittered_projection(w, h, near, far) * camera.view(),
        centre_depth: (bounds.center() - camera.position).dot(camera.forward),
        bound: settings.bound.resolve(cache.diagonal()),
        diagonal: cache.diagonal(),
        glossy: scene.has_glossy_materials(),
        normal_maps: scene.has_normal_maps(),
    })
}

/// Whether the frame casts rays: exact visibility or traced ISM texels,
/// asked for and possible on this device and scene (an error naming why
/// not). [`Visibility::Auto`] is resolved before (accumulated frames).
fn casts_rays(settings: &RenderSettings, cache: &SceneCache) -> Result<bool> {
    match settings.visibility {
        Visibility::Auto | Visibility::Ism => Ok(false),
        Visibility::Exact | Visibility::Traced if cache.gpu_scene.rays.is_some() => Ok(true),
        asked @ (Visibility::Exact | Visibility::Traced) => Err(Error::InvalidParameter(format!(
            "{asked} visibility (ssbc.visibility) needs a device with ray queries \
             (VK_KHR_ray_query) and a scene without alpha-masked materials"
        ))),
    }
}

/// Records what the scene's GPU copy needs before the passes (the first
/// frame after an upload copies its textures and builds its meshes'
/// acceleration structures; exact visibility builds the slot's top level)
/// and returns the slot's view of it.
fn record_scene<'c>(
    rec: &mut Recorder<'_>,
    cache: &'c mut SceneCache,
    (scene, versions): (&Scene, SceneVersions),
    settings: &RenderSettings,
    slot: usize,
) -> Result<(&'c SceneCache, SlotScene<'c>)> {
    cache.gpu_scene.record_uploads(rec)?;
    let casts = casts_rays(settings, cache)?;
    if casts {
        let rays = cache.gpu_scene.rays.as_mut().expect("checked");
        rays.record_top_level(rec, slot, scene, versions.objects)?;
    }
    let cache = &*cache;
    let mut slot_scene = cache.gpu_scene.for_slot(slot);
    if casts {
        slot_scene.top_level = cache
            .gpu_scene
            .rays
            .as_ref()
            .and_then(|r| r.top_level(slot));
    }
    Ok((cache, slot_scene))
}

/// Records the passes of the frame `setup` in `rec`, timed. Into a host's
/// command buffer (`host`) the query resets are recorded there too, and
/// nothing is kept for a later frame (ssbc cannot know whether the host's
/// submission runs). Returns the passes that kept the slot's previous
/// output.
fn record_passes(
    rec: &mut Recorder<'_>,
    (passes, profiler, fault): (&mut Passes, &mut GpuProfiler, &mut Option<String>),
    setup: &SlotSetup<'_>,
    (view, scene): (&FrameView, SlotScene<'_>),
    history: Option<HistoryFrame>,
    host: bool,
) -> Result<Vec<String>> {
    profiler.record_resets(host);
    profiler.begin_frame(rec.cmd, setup.slot, true);
    let mut reused = Vec::new();
    let mut cx = Recording {
        rec,
        profiler,
        view,
        settings: setup.settings,
        fault,
        reuse: setup.settings.reuse_unchanged && !host,
        reused: &mut reused,
    };
    passes.record(&mut cx, setup, scene, history)?;
    profiler.end_frame(rec.cmd);
    Ok(reused)
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
    /// Records a frame in `slot` (the host's, or the next of ssbc's own,
    /// waiting for the frame that used it last) and sends it where `sink`
    /// says; after a failure the slot's resources are dropped. `resident`
    /// frames (ssbc's own or recorded into a host's command buffer) keep
    /// temporal history; any other cuts it.
    pub(super) fn run<S: FrameSink>(
        &mut self,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        sink: S,
        host_slot: Option<usize>,
        resident: bool,
    ) -> Result<S::Output> {
        // A GPU frame that hands out a layer made on request makes it as a
        // frame that hands out every output does.
        let every_output;
        let on_request = sink.layer().is_some_and(Layer::on_request);
        let settings = if on_request && !settings.output_layers {
            every_output = RenderSettings {
                output_layers: true,
                ..settings.clone()
            };
            &every_output
        } else {
            settings
        };
        let with_history = resident && settings.history.enabled;
        let uses = FrameUse::of::<S>(with_history, resident, scene);
        limits::check_settings(&self.device, settings, scene.lights.len(), uses)?;
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
        let history = with_history.then(|| self.history.plan(slot, (scene, versions), settings));
        if history.is_none() {
            // A history that is off holds no memory either.
            self.history.reset();
            self.passes.forget_history();
        }
        let frame = FrameRequest {
            versions,
            slot,
            previous_timings,
            history,
            resident,
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

    /// The settings of a frame that uses temporal history, where they
    /// differ from the host's: a still view's frame continues the light
    /// paths after its history's (an independent VPL set), and by default
    /// it takes the visibility of an accumulation (exact where possible;
    /// else, with `history.converging_isms`, finer ISMs with back-face
    /// maps), to converge where [`Renderer::render_accumulated`] does.
    fn history_settings(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        history: Option<HistoryPlan>,
        uses: FrameUse,
    ) -> Option<RenderSettings> {
        let plan = history?;
        let still = plan.motion == Motion::Still;
        let still_auto = still && settings.visibility == Visibility::Auto;
        if plan.path_offset == 0 && !still_auto {
            return None;
        }
        let mut s = settings.clone();
        s.vpl.first_path = s.vpl.first_path.saturating_add(plan.path_offset);
        if still {
            // Beyond `max_frames` the running mean is exponential, of about
            // that many frames.
            let k = plan.accumulated.min(settings.history.max_frames);
            s.bound = settings.bound.converging(k, settings.vpl.count);
        }
        if still_auto {
            let isms = settings.history.converging_isms;
            super::accumulate::resolve_converging(&self.device, scene, &mut s, uses, isms);
        }
        Some(s)
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
            resident,
        } = request;
        let uses = FrameUse::of::<S>(history.is_some(), resident, scene);
        let host_settings = settings;
        let shifted = self.history_settings(scene, settings, history, uses);
        let settings = shifted.as_ref().unwrap_or(settings);
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
        let (band, wide) = GuardBand::widen_frame(&device, scene, settings, cache, uses)?;
        let (inner, settings) = (settings, wide.as_ref().unwrap_or(settings));
        let view = frame_view(scene, settings, cache, band)?;

        let record_start = monotonic_ns();
        let host = sink.host_command_buffer();
        let mut rec = begin_recording(&mut self.commands[slot], &device, host, cache)?;
        let (cache, slot_scene) = record_scene(&mut rec, cache, (scene, versions), settings, slot)?;
        let setup = SlotSetup {
            device: &device,
            slot,
            settings,
            scene,
            cache,
            transient: None,
            history: uses.history,
            resident: uses.resident,
        };
        let history_frame = history.map(|plan| HistoryFrame {
            step: self.history.step(&plan, settings, view.eye()),
            previous_slot: plan.previous_slot,
        });
        let renderer = (&mut self.passes, &mut self.profiler, &mut self.fault);
        let scene_view = (&view, slot_scene);
        let into_host = host.is_some();
        let reused = record_passes(
            &mut rec,
            renderer,
            &setup,
            scene_view,
            history_frame,
            into_host,
        )?;
        let light_paths = cache.vpls().set.paths;
        // The slot's estimated memory, and the slots holding resources.
        let estimated = limits::frame_memory(Some(&device), settings, scene.lights.len(), uses);
        let memory = (estimated, self.passes.slots_in_use());
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
                memory,
                readback: &mut self.readback[slot],
                profiler: &mut self.profiler,
                slot_done: &mut self.slot_done[slot],
                output: &mut self.output,
            },
        )?;
        if let Some(plan) = history {
            let frame = (scene, versions);
            let (eye, paths) = (view.eye(), light_paths);
            self.history
                .commit(&plan, slot, frame, host_settings, eye, paths);
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
    /// A resident scene's frame (its shadow maps and ISMs may be kept).
    resident: bool,
}
