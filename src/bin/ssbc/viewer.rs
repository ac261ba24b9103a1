//! `ssbc view`: an interactive window (winit, X11 or Wayland) showing the
//! renderer live, with a fly camera and keys for the technique's parameters.
//!
//! Frames are in flight two at a time: each frame slot has its command
//! pool, acquire semaphore and 8-bit display image, and a frame waits only for
//! the previous use of its slot. The renderer keeps the shown layer on the GPU
//! (`Renderer::render_to_gpu`), `present.comp` encodes it to 8-bit sRGB, and a
//! copy puts it into the acquired swapchain image. Timings come from the
//! slot's previous frame, read without waiting. The samples heat map is the
//! exception: it is read back and uploaded.

use std::collections::BTreeMap;
use std::ffi::CStr;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;
use raw_window_handle::{HasDisplayHandle, HasWindowHandle};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

use crate::swapchain::{BinarySemaphore, Swapchain};
use ssbc::error::VkResultExt;
use ssbc::renderer::{Bound, Frame, Layer, RenderSettings, Renderer};
use ssbc::resident::ResidentScene;
use ssbc::scene::{Camera, Scene};
use ssbc::shaders::present_comp;
use ssbc::vk::{
    Access, Buffer, CommandPool, ComputeKernel, DescriptorPool, Device, DeviceSelector, Image,
    Instance, ValidationLog, Work,
};
use ssbc::{Error, Result};

/// What the window shows: a layer of the frame (kept on the GPU), or the
/// samples-per-pixel heat map of step 1 (read back and uploaded).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Shown {
    Layer(Layer),
    Samples,
}

impl std::fmt::Display for Shown {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Shown::Layer(layer) => layer.fmt(f),
            Shown::Samples => f.write_str("samples_1"),
        }
    }
}

/// What `ssbc view` was asked to do.
pub struct ViewOptions {
    /// The scene (its first camera is the start of the fly camera).
    pub scene: Scene,
    /// Render settings; width and height are the initial window size.
    pub settings: RenderSettings,
    /// Validation layer on.
    pub validation: bool,
    /// Device choice.
    pub device: DeviceSelector,
    /// PNG/window exposure.
    pub exposure: f32,
    /// Render this many frames, then exit.
    pub frames: Option<u64>,
    /// Where the screenshot goes (`.exr` and `.png` next to each other).
    pub screenshot: Option<PathBuf>,
    /// Move the camera and the light a little every frame (soak runs).
    pub animate: bool,
    /// Resize the window this many times, one per frame, then minimise and
    /// restore it (robustness runs).
    pub resize_storm: u32,
    /// The scene's file (or built-in name) and the animation time it was
    /// loaded at: the viewer plays the file's first animation from there.
    pub source: (String, f32),
}

/// Run-time figures of a viewer session (printed on exit).
#[derive(Default)]
struct SessionStats {
    /// Wall-clock ms between consecutive frames.
    wall_ms: Vec<f64>,
    /// GPU frame ms from timestamps (of the slot's previous frame).
    gpu_ms: Vec<f64>,
    /// (resident set kB, live ssbc resources) at frame 10 and at the end.
    first: Option<(Option<u64>, u64)>,
    last: Option<(Option<u64>, u64)>,
    resizes: u32,
}

/// The process's resident set size in kB (Linux).
fn resident_kb() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

fn median(values: &[f64]) -> f64 {
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

const HELP: &str =
    "keys: WASD/QE move, drag to look, Space SSBC on/off, +/- steps, [ ] bound /2 x2, \
L layer, arrows/PgUp/PgDn move the light, T play/pause the glTF animation, P screenshot, \
H help, Esc quit";

/// Per frame in flight: its commands, acquire semaphore and 8-bit image.
struct FrameSlot {
    commands: CommandPool,
    acquired: BinarySemaphore,
    display: Option<Image>,
    /// The present pass's descriptor set, reset every frame.
    present_pool: Option<DescriptorPool>,
    /// Timeline value of the slot's last submission.
    done: u64,
}

/// The GPU side: device, renderer, swapchain and the copy to the window.
struct Gpu {
    // Drop order: these before the window (the surface needs it).
    slots: Vec<FrameSlot>,
    present: ComputeKernel<present_comp::Interface>,
    staging: Option<Buffer>,
    swapchain: Swapchain,
    renderer: Renderer,
    device: Arc<Device>,
    frames: u64,
}

impl Gpu {
    /// Uploads `frame`'s samples heat map, encoded for the swapchain, into
    /// the staging buffer the present copies from.
    fn upload_heat_map(&mut self, frame: &Frame, exposure: f32, bgra: bool) -> Result<()> {
        let heat = Viewer::heat_map(frame);
        let bytes: Vec<u8> = heat
            .chunks_exact(4)
            .flat_map(|p| {
                let q = |v: f32| {
                    (ssbc::output::srgb_encode((v * exposure).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8
                };
                if bgra {
                    [q(p[2]), q(p[1]), q(p[0]), 255]
                } else {
                    [q(p[0]), q(p[1]), q(p[2]), 255]
                }
            })
            .collect();
        if self
            .staging
            .as_ref()
            .is_none_or(|b| b.size < bytes.len() as u64)
        {
            self.staging = Some(Buffer::new(
                &self.device,
                "present_staging",
                bytes.len() as u64,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        self.staging
            .as_ref()
            .expect("allocated above")
            .write(0, &bytes)
    }

    /// Acquires a swapchain image and submits the slot's copy of the shown
    /// layer into it (encoded by `present.comp`; the heat map from staging).
    /// The image's index, or None when none could be acquired (the
    /// swapchain is out of date).
    fn submit_display(
        &mut self,
        slot_index: usize,
        shown: Shown,
        push: present_comp::Push,
    ) -> Result<Option<usize>> {
        let [width, height] = push.size;
        let slot = &mut self.slots[slot_index];
        if slot
            .display
            .as_ref()
            .is_none_or(|d| (d.desc.width, d.desc.height) != (width, height))
        {
            slot.display = Some(Image::new(
                &self.device,
                "display",
                ssbc::vk::ImageDesc::new_2d(
                    vk::Format::R8G8B8A8_UNORM,
                    width,
                    height,
                    vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
                ),
            )?);
        }
        let Some(index) = self.swapchain.acquire(&slot.acquired)? else {
            return Ok(None);
        };
        let image = &self.swapchain.images[index];
        let display = slot.display.as_ref().expect("allocated above");
        // The slot's previous frame is done: its set can be reused.
        match &slot.present_pool {
            Some(pool) => pool.reset()?,
            None => {
                slot.present_pool = Some(DescriptorPool::new(
                    &self.device,
                    &[self.present.set_layout()],
                )?)
            }
        }
        let pool = slot.present_pool.as_ref().expect("created above");
        let mut rec = slot.commands.begin()?;
        match (shown, self.renderer.output()) {
            (Shown::Samples, _) | (_, None) => {
                let staging = self.staging.as_ref().expect("uploaded above");
                rec.copy_buffer_to_image(staging, image, (width, height), 1);
            }
            (_, Some(output)) => {
                let bindings = present_comp::Bindings {
                    radiance: output,
                    display,
                };
                let pixels = Work::pixels((width, height));
                self.present
                    .dispatch(&mut rec, pool, &bindings, &push, pixels)?;
                rec.copy_image(display, (0, 0), image, (width, height));
            }
        }
        rec.use_image(image, Access::Present);
        rec.flush_barriers();
        slot.done = rec.submit_with(
            &[(slot.acquired.raw, vk::PipelineStageFlags2::ALL_COMMANDS)],
            &[image.render_done],
        )?;
        Ok(Some(index))
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        // Semaphores and images below may still be in use by queued frames.
        let _ = self.device.wait_idle();
    }
}

struct Viewer {
    options: ViewOptions,
    stats: SessionStats,
    /// The camera and light the animation starts from.
    anim_start: Option<(Camera, Vec3)>,
    /// The scene kept between frames: camera and light moves only mark
    /// what changed (no clone, no BVH, no upload per frame).
    resident: ResidentScene,
    /// The scene's bounding-sphere radius (m).
    radius: f32,
    camera: Camera,
    layer: usize,
    saved_steps: u32,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    held: Vec<Key>,
    last_frame: Instant,
    timings: BTreeMap<String, f64>,
    last_title: Instant,
    frames_done: u64,
    /// Frame slot whose display image holds the last GPU-presented frame.
    last_gpu_slot: Option<usize>,
    screenshots: u32,
    /// The animation's time (s) and whether it plays (T toggles).
    anim_time: f32,
    playing: bool,
    result: Result<()>,
    log: Option<Arc<ValidationLog>>,
    gpu: Option<Gpu>,
    window: Option<Window>,
}

/// Run-time libraries winit loads for each window system, with the Debian
/// package that ships each (scripts/setup.sh installs them all).
const X11_LIBRARIES: [(&str, &str); 7] = [
    ("libX11.so.6", "libx11-6"),
    ("libX11-xcb.so.1", "libx11-xcb1"),
    ("libxcb.so.1", "libxcb1"),
    ("libXcursor.so.1", "libxcursor1"),
    ("libXi.so.6", "libxi6"),
    ("libxkbcommon.so.0", "libxkbcommon0"),
    ("libxkbcommon-x11.so.0", "libxkbcommon-x11-0"),
];
const WAYLAND_LIBRARIES: [(&str, &str); 3] = [
    ("libwayland-client.so.0", "libwayland-client0"),
    ("libwayland-cursor.so.0", "libwayland-cursor0"),
    ("libxkbcommon.so.0", "libxkbcommon0"),
];

/// Whether a shared library can be loaded.
fn loadable(name: &str) -> bool {
    // SAFETY: loading a system library runs its initialisers; these are the
    // window-system libraries winit itself would load.
    unsafe { libloading::Library::new(name) }.is_ok()
}

/// Why the event loop could not be created, in terms a user can act on.
fn window_system_error(cause: &str) -> Error {
    let var = |name: &str| std::env::var(name).ok().filter(|v| !v.is_empty());
    Error::WindowSystem(diagnose_window_system(
        var("WAYLAND_DISPLAY"),
        var("DISPLAY"),
        cause,
        loadable,
    ))
}

/// Which display was tried, and which libraries (with their Debian
/// packages) `loadable` cannot load.
fn diagnose_window_system(
    wayland: Option<String>,
    x11: Option<String>,
    cause: &str,
    loadable: impl Fn(&str) -> bool,
) -> String {
    if wayland.is_none() && x11.is_none() {
        return "no display: neither WAYLAND_DISPLAY nor DISPLAY is set (`ssbc render` needs none)"
            .into();
    }
    let mut missing = Vec::new();
    let mut tried = Vec::new();
    for (display, system, libraries) in [
        (&wayland, "Wayland", &WAYLAND_LIBRARIES[..]),
        (&x11, "X11", &X11_LIBRARIES[..]),
    ] {
        if let Some(display) = display {
            tried.push(format!("{system} ({display})"));
            missing.extend(libraries.iter().filter(|(lib, _)| !loadable(lib)));
        }
    }
    missing.sort();
    missing.dedup();
    if missing.is_empty() {
        return format!("{} failed: {cause}", tried.join(" and "));
    }
    let names: Vec<String> = missing
        .iter()
        .map(|(lib, package)| format!("{lib} (Debian package {package})"))
        .collect();
    let packages: Vec<&str> = missing.iter().map(|(_, package)| *package).collect();
    format!(
        "{} needs {}; install with `apt-get install {}` (or run scripts/setup.sh)",
        tried.join(" and "),
        names.join(", "),
        packages.join(" ")
    )
}

/// Runs the viewer until the window closes (or `frames` are done). Returns
/// the number of validation messages.
pub fn run(options: ViewOptions) -> Result<u32> {
    let event_loop = EventLoop::new().map_err(|e| window_system_error(&e.to_string()))?;
    let mut options = options;
    if std::mem::take(&mut options.settings.ssbc.guard_band) {
        // It presents the renderer's image whole (the band included).
        log::warn!("the viewer does not render a guard band; --guard-band ignored");
    }
    // The scene moves into the resident scene (the viewer keeps no copy).
    let mut scene = std::mem::replace(&mut options.scene, Scene::new("(resident)"));
    scene.ensure_light();
    let camera = scene.camera(options.settings.camera)?;
    let saved_steps = options.settings.ssbc.steps.max(1);
    let radius = scene.bounds().radius();
    let mut resident = ResidentScene::new(scene)?;
    resident.set_camera(camera.clone());
    options.settings.camera = Some(0);
    let start_time = options.source.1;
    let mut viewer = Viewer {
        options,
        stats: SessionStats::default(),
        anim_start: None,
        resident,
        radius,
        camera,
        layer: 0,
        saved_steps,
        dragging: false,
        cursor: None,
        held: Vec::new(),
        last_frame: Instant::now(),
        timings: BTreeMap::new(),
        last_title: Instant::now(),
        frames_done: 0,
        last_gpu_slot: None,
        screenshots: 0,
        anim_time: start_time,
        playing: true,
        result: Ok(()),
        log: None,
        gpu: None,
        window: None,
    };
    eprintln!("{HELP}");
    event_loop
        .run_app(&mut viewer)
        .map_err(|e| Error::NoDevice(format!("window event loop failed: {e}")))?;
    viewer.print_timings();
    let log = viewer.log.clone();
    let result = std::mem::replace(&mut viewer.result, Ok(()));
    drop(viewer);
    result?;
    Ok(log.map(|l| l.total()).unwrap_or(0))
}

impl Viewer {
    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let size = PhysicalSize::new(self.options.settings.width, self.options.settings.height);
        let window = event_loop
            .create_window(
                Window::default_attributes()
                    .with_title("ssbc")
                    .with_inner_size(size),
            )
            .map_err(|e| Error::NoDevice(format!("cannot open a window: {e}")))?;
        let display = window
            .display_handle()
            .map_err(|e| Error::NoDevice(e.to_string()))?
            .as_raw();
        let handle = window
            .window_handle()
            .map_err(|e| Error::NoDevice(e.to_string()))?
            .as_raw();
        let extensions: Vec<&CStr> = ash_window::enumerate_required_extensions(display)
            .vk("vkEnumerateInstanceExtensionProperties (surface)")?
            .iter()
            // SAFETY: ash-window returns pointers to static NUL-terminated names.
            .map(|&p| unsafe { CStr::from_ptr(p) })
            .collect();
        let instance = Instance::new(self.options.validation, &extensions)?;
        self.log = Some(instance.validation_log());
        // SAFETY: the window outlives the surface (Gpu drops before the window).
        let surface = unsafe {
            ash_window::create_surface(&instance.entry, &instance.raw, display, handle, None)
        }
        .vk("vkCreateSurfaceKHR")?;
        let device = match Device::new(
            instance.clone(),
            &self.options.device,
            &[ash::khr::swapchain::NAME],
        ) {
            Ok(d) => d,
            Err(e) => {
                // SAFETY: nothing uses the surface yet.
                unsafe {
                    ash::khr::surface::Instance::new(&instance.entry, &instance.raw)
                        .destroy_surface(surface, None)
                };
                return Err(e);
            }
        };
        let inner = window.inner_size();
        let swapchain = Swapchain::new(
            &device,
            surface,
            vk::Extent2D {
                width: inner.width,
                height: inner.height,
            },
        )?;
        let slots = (0..ssbc::renderer::FRAME_SLOTS)
            .map(|_| {
                Ok(FrameSlot {
                    commands: CommandPool::new(&device)?,
                    acquired: BinarySemaphore::new(&device)?,
                    display: None,
                    present_pool: None,
                    done: 0,
                })
            })
            .collect::<Result<_>>()?;
        let present = ComputeKernel::new(&device)?;
        self.gpu = Some(Gpu {
            slots,
            present,
            staging: None,
            swapchain,
            renderer: Renderer::with_device(device.clone())?,
            device,
            frames: 0,
        });
        self.window = Some(window);
        Ok(())
    }

    /// What `L` cycles through: the frame's layers, then step 1's samples.
    fn showable(&self) -> Vec<Shown> {
        let steps = self.options.settings.ssbc.steps;
        let mut shown: Vec<Shown> = Layer::outputs(steps)
            .into_iter()
            .map(Shown::Layer)
            .collect();
        if steps > 0 {
            shown.push(Shown::Samples);
        }
        shown
    }

    /// What is shown now.
    fn current(&self) -> Shown {
        let showable = self.showable();
        showable[self.layer % showable.len()]
    }

    /// The shown layer as linear RGBA (the samples heat map as false colour).
    fn shown(&self, frame: &Frame) -> Vec<f32> {
        match self.current() {
            Shown::Samples => Self::heat_map(frame),
            Shown::Layer(layer) => frame
                .layer(layer)
                .map(|l| l.rgba.clone())
                .unwrap_or_else(|| frame.image.rgba.clone()),
        }
    }

    /// Samples per pixel of step 1 as false colour (blue few, red most).
    fn heat_map(frame: &Frame) -> Vec<f32> {
        let Some(counts) = frame.samples.first() else {
            return vec![0.0; (frame.width * frame.height * 4) as usize];
        };
        let max = counts.iter().copied().fold(1.0f32, f32::max);
        counts
            .iter()
            .flat_map(|&c| {
                let t = c / max;
                [t, 1.0 - (2.0 * t - 1.0).abs(), 1.0 - t, 1.0]
            })
            .collect()
    }

    fn draw(&mut self) -> Result<()> {
        let Some(window) = &self.window else {
            return Ok(());
        };
        let size = window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // minimised
        }
        let elapsed = self.last_frame.elapsed();
        if self.frames_done > 0 {
            self.stats.wall_ms.push(elapsed.as_secs_f64() * 1e3);
        }
        let dt = elapsed.as_secs_f32().min(0.5);
        self.last_frame = Instant::now();
        self.fly(dt);
        self.play(dt)?;
        self.script(size);
        let wanted = vk::Extent2D {
            width: size.width,
            height: size.height,
        };
        let shown = self.current();
        let gpu = self.gpu.as_mut().expect("initialised with the window");
        if gpu.swapchain.extent != wanted {
            gpu.swapchain.recreate(wanted)?;
        }
        let extent = gpu.swapchain.extent;
        let bgra = gpu.swapchain.format == vk::Format::B8G8R8A8_UNORM;
        self.options.settings.width = extent.width;
        self.options.settings.height = extent.height;
        if self.resident.scene().cameras.first() != Some(&self.camera) {
            self.resident.set_camera(self.camera.clone());
        }
        // This frame slot's previous frame must be done before its commands,
        // semaphore and display image are reused; the other slot runs on.
        let slot_index = (gpu.frames % gpu.slots.len() as u64) as usize;
        gpu.frames += 1;
        gpu.device.wait(gpu.slots[slot_index].done)?;

        // Render: on the GPU, kept there (timings come from this slot's
        // previous frame, read without waiting), or, for the samples heat
        // map, read back and uploaded.
        let (settings, exposure) = (&self.options.settings, self.options.exposure);
        let timings = if let Shown::Layer(layer) = shown {
            gpu.renderer
                .render_resident_to_gpu(&self.resident, settings, layer)?
                .previous_timings
        } else {
            let frame = gpu.renderer.render_resident(&self.resident, settings)?;
            gpu.upload_heat_map(&frame, exposure, bgra)?;
            frame
                .timings
                .passes
                .clone()
                .zip(frame.timings.frame_gpu_ms)
                .map(|(passes, frame_ms)| ssbc::vk::GpuFrameTimes {
                    passes,
                    frame_ms,
                    start_monotonic_ns: frame.timings.gpu_start_ns,
                })
        };
        let push = present_comp::Push {
            size: [extent.width, extent.height],
            exposure,
            swap_red_blue: bgra as u32,
        };
        let Some(index) = gpu.submit_display(slot_index, shown, push)? else {
            gpu.swapchain.recreate(wanted)?;
            return Ok(());
        };
        self.last_gpu_slot = (shown != Shown::Samples).then_some(slot_index);
        if !gpu.swapchain.present(index)? {
            gpu.swapchain.recreate(wanted)?;
        }
        self.note_frame(timings);
        Ok(())
    }

    /// Smoothed per-pass timings, the window title once a second, and the
    /// session's figures.
    fn note_frame(&mut self, timings: Option<ssbc::vk::GpuFrameTimes>) {
        if let Some(ssbc::vk::GpuFrameTimes {
            passes, frame_ms, ..
        }) = timings
        {
            for p in &passes {
                let e = self.timings.entry(p.name.clone()).or_insert(p.gpu_ms);
                *e = 0.8 * *e + 0.2 * p.gpu_ms;
            }
            self.stats.gpu_ms.push(frame_ms);
            let f = self.timings.entry("frame".into()).or_insert(frame_ms);
            *f = 0.8 * *f + 0.2 * frame_ms;
        }
        if self.last_title.elapsed().as_secs_f32() >= 1.0 {
            self.last_title = Instant::now();
            // Frames the still view has averaged (temporal history).
            let accumulated = self
                .gpu
                .as_ref()
                .map_or(0, |g| g.renderer.accumulated_frames());
            let title = format!(
                "ssbc | {} | {} steps | b {} | GPU frame {:.1} ms | {} frames accumulated",
                self.current(),
                self.options.settings.ssbc.steps,
                self.options.settings.bound.resolve(2.0 * self.radius),
                self.timings.get("frame").copied().unwrap_or(0.0),
                accumulated
            );
            if let Some(w) = &self.window {
                w.set_title(&title);
            }
        }
        self.frames_done += 1;
        let live = self.gpu.as_ref().map_or(0, |g| g.device.live_resources());
        let sample = Some((resident_kb(), live));
        if self.frames_done == 10 {
            self.stats.first = sample;
        }
        self.stats.last = sample;
    }

    /// Moves the camera by the held keys.
    fn fly(&mut self, dt: f32) {
        let speed = self.radius * 0.5 * dt;
        let right = self.camera.forward.cross(self.camera.up).normalize();
        for key in &self.held {
            if let Key::Character(c) = key {
                match c.as_str() {
                    "w" => self.camera.position += self.camera.forward * speed,
                    "s" => self.camera.position -= self.camera.forward * speed,
                    "a" => self.camera.position -= right * speed,
                    "d" => self.camera.position += right * speed,
                    "q" => self.camera.position -= Vec3::Y * speed,
                    "e" => self.camera.position += Vec3::Y * speed,
                    _ => {}
                }
            }
        }
    }

    /// Renders the current view once more, read back, and saves the shown
    /// layer as EXR (linear) and PNG (as displayed).
    fn screenshot(&mut self, path: &Path) -> Result<()> {
        let Some(gpu) = self.gpu.as_mut() else {
            return Ok(());
        };
        if self.resident.scene().cameras.first() != Some(&self.camera) {
            self.resident.set_camera(self.camera.clone());
        }
        let frame = gpu
            .renderer
            .render_resident(&self.resident, &self.options.settings)?;
        let rgba = self.shown(&frame);
        let exr = path.with_extension("exr");
        let png = path.with_extension("png");
        ssbc::output::write_exr(&exr, frame.width, frame.height, &rgba, &[])?;
        ssbc::output::write_png(
            &png,
            frame.width,
            frame.height,
            &rgba,
            self.options.exposure,
        )?;
        eprintln!(
            "screenshot: {} and {} ({} frames accumulated)",
            exr.display(),
            png.display(),
            frame.accumulated
        );
        self.save_displayed(&path.with_file_name(format!(
            "{}-display.png",
            path.file_stem().map(|s| s.to_string_lossy()).unwrap_or_default()
        )))
    }

    /// Saves the 8-bit image the GPU path last put on screen (converted by
    /// `present.comp`), read back from its frame slot.
    fn save_displayed(&mut self, path: &Path) -> Result<()> {
        let (Some(gpu), Some(slot)) = (self.gpu.as_mut(), self.last_gpu_slot) else {
            return Ok(());
        };
        gpu.device.wait_idle()?;
        let bgra = gpu.swapchain.format == vk::Format::B8G8R8A8_UNORM;
        let slot = &mut gpu.slots[slot];
        let Some(display) = slot.display.as_ref() else {
            return Ok(());
        };
        let (w, h) = (display.desc.width, display.desc.height);
        let buffer = Buffer::new(
            &gpu.device,
            "display_readback",
            w as u64 * h as u64 * 4,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let mut rec = slot.commands.begin()?;
        rec.copy_image_to_buffer(display, &buffer);
        rec.use_buffer(&buffer, Access::HostRead);
        rec.flush_barriers();
        let done = rec.submit()?;
        slot.done = done;
        gpu.device.wait(done)?;
        let bytes: Vec<u8> = buffer.read::<u8>()?;
        let rgb: Vec<u8> = bytes
            .chunks_exact(4)
            .flat_map(|p| {
                if bgra {
                    [p[2], p[1], p[0]]
                } else {
                    [p[0], p[1], p[2]]
                }
            })
            .collect();
        image::save_buffer(path, &rgb, w, h, image::ExtendedColorType::Rgb8).map_err(|e| {
            Error::Output {
                path: path.display().to_string(),
                message: e.to_string(),
            }
        })?;
        eprintln!("displayed frame: {}", path.display());
        Ok(())
    }

    fn key(&mut self, key: Key, event_loop: &ActiveEventLoop) -> Result<()> {
        let s = &mut self.options.settings;
        let radius = self.radius;
        let light_step = radius * 0.05;
        match &key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::Space) => {
                if s.ssbc.steps > 0 {
                    self.saved_steps = s.ssbc.steps;
                    s.ssbc.steps = 0;
                } else {
                    s.ssbc.steps = self.saved_steps;
                }
            }
            Key::Named(NamedKey::ArrowLeft) => self.move_light(Vec3::new(-light_step, 0.0, 0.0)),
            Key::Named(NamedKey::ArrowRight) => self.move_light(Vec3::new(light_step, 0.0, 0.0)),
            Key::Named(NamedKey::ArrowUp) => self.move_light(Vec3::new(0.0, 0.0, -light_step)),
            Key::Named(NamedKey::ArrowDown) => self.move_light(Vec3::new(0.0, 0.0, light_step)),
            Key::Named(NamedKey::PageUp) => self.move_light(Vec3::new(0.0, light_step, 0.0)),
            Key::Named(NamedKey::PageDown) => self.move_light(Vec3::new(0.0, -light_step, 0.0)),
            Key::Character(c) => match c.as_str() {
                "+" | "=" => s.ssbc.steps = (s.ssbc.steps + 1).min(16),
                "-" => s.ssbc.steps = s.ssbc.steps.saturating_sub(1),
                "[" | "]" => {
                    let b = s.bound.resolve(2.0 * radius);
                    let factor = if c.as_str() == "[" { 0.5 } else { 2.0 };
                    s.bound = Bound::Value(if b.is_finite() { b * factor } else { 1.0 });
                }
                "l" => self.layer += 1,
                "t" if self.resident.scene().animation_end.is_some() => {
                    self.playing = !self.playing;
                }
                "h" => eprintln!("{HELP}"),
                "p" => {
                    self.screenshots += 1;
                    let path = PathBuf::from(format!("ssbc-screenshot-{}", self.screenshots));
                    self.screenshot(&path)?;
                }
                _ => {}
            },
            _ => {}
        }
        Ok(())
    }

    /// Plays the file's first animation (looping over its keyframes): the
    /// scene's meshes are reloaded at the new time each frame.
    fn play(&mut self, dt: f32) -> Result<()> {
        let Some(end) = self.resident.scene().animation_end.filter(|_| self.playing) else {
            return Ok(());
        };
        self.anim_time = if end > 0.0 {
            (self.anim_time + dt) % end
        } else {
            0.0
        };
        crate::show_pose(&mut self.resident, self.anim_time)
    }

    fn move_light(&mut self, delta: Vec3) {
        // The VPLs follow: the renderer traces them again for the new light.
        if let Some(mut light) = self.resident.scene().lights.first().cloned() {
            light.position += delta;
            if let Err(e) = self.resident.set_light(0, light) {
                log::warn!("light not moved: {e}");
            }
        }
    }

    /// Scripted changes for soak and robustness runs: `--animate` moves the
    /// camera and the light on small circles; `--resize-storm N` resizes
    /// the window every frame N times, then minimises and restores it.
    fn script(&mut self, size: PhysicalSize<u32>) {
        let frame = self.frames_done as f32;
        if self.options.animate {
            let light = self
                .resident
                .scene()
                .lights
                .first()
                .map_or(Vec3::ZERO, |l| l.position);
            let (camera, light_start) = self
                .anim_start
                .get_or_insert_with(|| (self.camera.clone(), light))
                .clone();
            let r = self.radius * 0.02;
            let a = frame * 0.05;
            self.camera = Camera::look_at(
                camera.position + r * Vec3::new(a.cos() - 1.0, 0.0, a.sin()),
                camera.position + r * Vec3::new(a.cos() - 1.0, 0.0, a.sin()) + camera.forward,
                camera.yfov,
            );
            let target = light_start + r * Vec3::new(a.sin(), 0.0, a.cos() - 1.0);
            self.move_light(target - light);
        }
        let Some(window) = &self.window else {
            return;
        };
        let storm = self.options.resize_storm;
        if storm > 0 && self.stats.resizes < storm {
            let base = (
                self.options.settings.width.max(64),
                self.options.settings.height.max(48),
            );
            let k = self.stats.resizes % 5;
            let wanted = PhysicalSize::new(base.0 * (4 + k) / 6, base.1 * (6 - k) / 5);
            let _ = window.request_inner_size(wanted);
            self.stats.resizes += 1;
            if self.stats.resizes == storm {
                window.set_minimized(true);
            }
        } else if storm > 0 && self.stats.resizes == storm {
            window.set_minimized(false);
            let _ = window.request_inner_size(size);
            self.stats.resizes += 1;
        }
    }

    fn print_session(&self) {
        let Some(gpu) = &self.gpu else {
            return;
        };
        let (wall, gpu_ms) = (median(&self.stats.wall_ms), median(&self.stats.gpu_ms));
        let show = |s: &Option<(Option<u64>, u64)>| match s {
            Some((Some(kb), live)) => format!("{} MiB RSS, {live} live resources", kb / 1024),
            Some((None, live)) => format!("{live} live resources"),
            None => "-".into(),
        };
        eprintln!(
            "viewer session: {} frames; wall-clock {wall:.1} ms/frame (median), GPU frame {gpu_ms:.1} ms (median), ratio {:.2}; at frame 10: {}; at the end: {}; {} objects awaiting destruction; {} resizes",
            self.frames_done,
            wall / gpu_ms,
            show(&self.stats.first),
            show(&self.stats.last),
            gpu.device.pending_destruction(),
            self.stats.resizes
        );
    }

    fn print_timings(&self) {
        self.print_session();
        if self.timings.is_empty() {
            return;
        }
        eprintln!("smoothed GPU timings over {} frames:", self.frames_done);
        for (name, ms) in &self.timings {
            eprintln!("  {name:<24} {ms:>10.3} ms");
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: Error) {
        if self.result.is_ok() {
            self.result = Err(e);
        }
        event_loop.exit();
    }
}

impl ApplicationHandler for Viewer {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_none() {
            if let Err(e) = self.init(event_loop) {
                self.fail(event_loop, e);
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::RedrawRequested => {
                let r = self.draw();
                if r.is_ok() && self.options.frames.is_some_and(|n| self.frames_done >= n) {
                    let shot = self.options.screenshot.clone();
                    let r = shot.map(|p| self.screenshot(&p)).unwrap_or(Ok(()));
                    event_loop.exit();
                    r
                } else {
                    r
                }
            }
            WindowEvent::KeyboardInput { event, .. } => match event.state {
                ElementState::Pressed => {
                    if !self.held.contains(&event.logical_key) {
                        self.held.push(event.logical_key.clone());
                    }
                    self.key(event.logical_key, event_loop)
                }
                ElementState::Released => {
                    self.held.retain(|k| *k != event.logical_key);
                    Ok(())
                }
            },
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => {
                self.dragging = state == ElementState::Pressed;
                Ok(())
            }
            WindowEvent::CursorMoved { position, .. } => {
                if let (true, Some((x, y))) = (self.dragging, self.cursor) {
                    let (dx, dy) = (
                        (position.x - x) as f32 * 0.005,
                        (position.y - y) as f32 * 0.005,
                    );
                    let right = self.camera.forward.cross(Vec3::Y).normalize_or_zero();
                    let f = glam::Quat::from_axis_angle(Vec3::Y, -dx)
                        * glam::Quat::from_axis_angle(right, -dy)
                        * self.camera.forward;
                    if f.cross(Vec3::Y).length() > 0.05 {
                        self.camera = Camera::look_at(
                            self.camera.position,
                            self.camera.position + f,
                            self.camera.yfov,
                        );
                    }
                }
                self.cursor = Some((position.x, position.y));
                Ok(())
            }
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.fail(event_loop, e);
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(w) = &self.window {
            w.request_redraw();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_library_is_named_with_its_package() {
        let message = diagnose_window_system(None, Some(":95".into()), "os error", |lib| {
            !matches!(lib, "libXcursor.so.1" | "libxkbcommon-x11.so.0")
        });
        assert!(
            message.contains("libXcursor.so.1 (Debian package libxcursor1)")
                && message.contains("libxkbcommon-x11.so.0 (Debian package libxkbcommon-x11-0)")
                && message.contains("apt-get install libxcursor1 libxkbcommon-x11-0")
                && message.contains("X11 (:95)"),
            "{message}"
        );
        let error = Error::WindowSystem(message).to_string();
        assert!(!error.contains("Vulkan"), "{error}");
    }

    #[test]
    fn no_display_and_other_failures_say_so() {
        let none = diagnose_window_system(None, None, "", |_| true);
        assert!(
            none.contains("neither WAYLAND_DISPLAY nor DISPLAY"),
            "{none}"
        );
        let other = diagnose_window_system(Some("wayland-0".into()), None, "refused", |_| true);
        assert_eq!(other, "Wayland (wayland-0) failed: refused");
    }

    #[test]
    fn every_window_system_library_is_installed_here() {
        // The machines the suite runs on went through scripts/setup.sh.
        let missing: Vec<_> = X11_LIBRARIES
            .iter()
            .chain(&WAYLAND_LIBRARIES)
            .filter(|(lib, _)| !loadable(lib))
            .collect();
        assert!(missing.is_empty(), "not loadable: {missing:?}");
    }
}
