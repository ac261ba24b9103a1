//! `ssbc view`: an interactive window (winit, X11 or Wayland) showing the
//! renderer live, with a fly camera and keys for the technique's parameters.
//!
//! Each frame renders synchronously at the window's size (the renderer reads
//! its layers back so any of them can be shown), converts the chosen layer to
//! 8-bit sRGB on the CPU, and copies it into the acquired swapchain image.
//! Timings therefore come from the frame just finished: no extra stall.

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

use crate::error::{Error, Result, VkResultExt};
use crate::renderer::{Bound, Frame, RenderSettings, Renderer};
use crate::scene::{Camera, Scene};
use crate::vk::{
    Access, Buffer, CommandPool, Device, DeviceSelector, Instance, Swapchain, ValidationLog,
};

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
}

const HELP: &str =
    "keys: WASD/QE move, drag to look, Space SSBC on/off, +/- steps, [ ] bound /2 x2, \
L layer, arrows/PgUp/PgDn move the light, P screenshot, H help, Esc quit";

/// The GPU side: device, renderer, swapchain and the copy to the window.
struct Gpu {
    // Drop order: these before the window (the surface needs it).
    staging: Option<Buffer>,
    commands: CommandPool,
    swapchain: Swapchain,
    renderer: Renderer,
    device: Arc<Device>,
}

struct Viewer {
    options: ViewOptions,
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
    screenshots: u32,
    last: Option<Frame>,
    result: Result<()>,
    log: Option<Arc<ValidationLog>>,
    gpu: Option<Gpu>,
    window: Option<Window>,
}

/// Runs the viewer until the window closes (or `frames` are done). Returns
/// the number of validation messages.
pub fn run(options: ViewOptions) -> Result<u32> {
    let event_loop =
        EventLoop::new().map_err(|e| Error::NoDevice(format!("no window system: {e}")))?;
    let mut scene = options.scene.clone();
    scene.ensure_light();
    let camera = scene.camera(options.settings.camera)?;
    let saved_steps = options.settings.ssbc.steps.max(1);
    let mut viewer = Viewer {
        options: ViewOptions { scene, ..options },
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
        screenshots: 0,
        last: None,
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
        self.gpu = Some(Gpu {
            staging: None,
            commands: CommandPool::new(&device)?,
            swapchain,
            renderer: Renderer::with_device(device.clone())?,
            device,
        });
        self.window = Some(window);
        Ok(())
    }

    /// Names of the layers that can be shown.
    fn layer_names(&self) -> Vec<String> {
        let mut names = vec![
            "final".to_string(),
            "direct".into(),
            "indirect_bounded".into(),
        ];
        for k in 1..=self.options.settings.ssbc.steps {
            names.push(format!("residual_{k}"));
        }
        if self.options.settings.ssbc.steps > 0 {
            names.push("samples_1".into());
        }
        names
    }

    /// The shown layer as linear RGBA (the samples heat map as false colour).
    fn shown(&self, frame: &Frame) -> Vec<f32> {
        let names = self.layer_names();
        let name = &names[self.layer % names.len()];
        if name == "samples_1" {
            let counts = &frame.samples[0];
            let max = counts.iter().copied().max().unwrap_or(1).max(1) as f32;
            return counts
                .iter()
                .flat_map(|&c| {
                    let t = c as f32 / max;
                    [t, 1.0 - (2.0 * t - 1.0).abs(), 1.0 - t, 1.0]
                })
                .collect();
        }
        frame
            .layer(name)
            .map(|l| l.rgba.clone())
            .unwrap_or_else(|| frame.image.rgba.clone())
    }

    fn draw(&mut self) -> Result<()> {
        let Some(window) = &self.window else {
            return Ok(());
        };
        let size = window.inner_size();
        if size.width == 0 || size.height == 0 {
            return Ok(()); // minimised
        }
        let dt = self.last_frame.elapsed().as_secs_f32().min(0.5);
        self.last_frame = Instant::now();
        self.fly(dt);
        let wanted = vk::Extent2D {
            width: size.width,
            height: size.height,
        };
        let gpu = self.gpu.as_mut().expect("initialised with the window");
        if gpu.swapchain.extent != wanted {
            gpu.swapchain.recreate(wanted)?;
        }
        let extent = gpu.swapchain.extent;
        let bgra = gpu.swapchain.format == vk::Format::B8G8R8A8_UNORM;
        self.options.settings.width = extent.width;
        self.options.settings.height = extent.height;
        let mut scene = self.options.scene.clone();
        scene.cameras.insert(0, self.camera.clone());
        self.options.settings.camera = Some(0);
        let frame = gpu.renderer.render(&scene, &self.options.settings)?;

        // Linear radiance -> exposure -> sRGB 8-bit in the swapchain's channel order.
        let exposure = self.options.exposure;
        let shown = self.shown(&frame);
        let gpu = self.gpu.as_mut().expect("initialised with the window");
        let bytes: Vec<u8> = shown
            .chunks_exact(4)
            .flat_map(|p| {
                let q = |v: f32| {
                    (crate::output::srgb_encode((v * exposure).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8
                };
                if bgra {
                    [q(p[2]), q(p[1]), q(p[0]), 255]
                } else {
                    [q(p[0]), q(p[1]), q(p[2]), 255]
                }
            })
            .collect();
        let needed = bytes.len() as u64;
        if gpu.staging.as_ref().is_none_or(|b| b.size < needed) {
            gpu.staging = Some(Buffer::new(
                &gpu.device,
                "present_staging",
                needed,
                vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::CpuToGpu,
            )?);
        }
        let staging = gpu.staging.as_ref().expect("allocated above");
        staging.write(0, &bytes)?;

        let Some(index) = gpu.swapchain.acquire()? else {
            gpu.swapchain.recreate(wanted)?;
            return Ok(());
        };
        let image = &gpu.swapchain.images[index];
        let mut rec = gpu.commands.begin()?;
        rec.copy_buffer_to_image(staging, image, (extent.width, extent.height), 1);
        rec.use_image(image, Access::Present);
        rec.flush_barriers();
        let done = rec.submit_with(
            &[(gpu.swapchain.acquired, vk::PipelineStageFlags2::TRANSFER)],
            &[image.render_done],
        )?;
        gpu.device.wait(done)?;
        if !gpu.swapchain.present(index)? {
            gpu.swapchain.recreate(wanted)?;
        }

        for p in &frame.timings.passes {
            let e = self.timings.entry(p.name.clone()).or_insert(p.gpu_ms);
            *e = 0.8 * *e + 0.2 * p.gpu_ms;
        }
        let f = self
            .timings
            .entry("frame".into())
            .or_insert(frame.timings.frame_gpu_ms);
        *f = 0.8 * *f + 0.2 * frame.timings.frame_gpu_ms;
        if self.last_title.elapsed().as_secs_f32() >= 1.0 {
            self.last_title = Instant::now();
            let names = self.layer_names();
            let title = format!(
                "ssbc | {} | {} steps | b {} | GPU frame {:.1} ms",
                names[self.layer % names.len()],
                self.options.settings.ssbc.steps,
                frame.timings.bound,
                self.timings["frame"]
            );
            if let Some(w) = &self.window {
                w.set_title(&title);
            }
        }
        self.last = Some(frame);
        self.frames_done += 1;
        Ok(())
    }

    /// Moves the camera by the held keys.
    fn fly(&mut self, dt: f32) {
        let speed = self.options.scene.bounds().radius() * 0.5 * dt;
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

    fn screenshot(&mut self, path: &Path) -> Result<()> {
        let Some(frame) = &self.last else {
            return Ok(());
        };
        let rgba = self.shown(frame);
        let layer = crate::renderer::Layer {
            name: "shown".into(),
            rgba,
        };
        let exr = path.with_extension("exr");
        let png = path.with_extension("png");
        crate::output::write_exr(&exr, frame.width, frame.height, &layer, &[])?;
        crate::output::write_png(
            &png,
            frame.width,
            frame.height,
            &layer.rgba,
            self.options.exposure,
        )?;
        eprintln!("screenshot: {} and {}", exr.display(), png.display());
        Ok(())
    }

    fn key(&mut self, key: Key, event_loop: &ActiveEventLoop) -> Result<()> {
        let s = &mut self.options.settings;
        let radius = self.options.scene.bounds().radius();
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

    fn move_light(&mut self, delta: Vec3) {
        // The VPLs follow: the renderer traces them anew every frame.
        if let Some(light) = self.options.scene.lights.first_mut() {
            light.position += delta;
        }
    }

    fn print_timings(&self) {
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
