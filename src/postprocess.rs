//! SSBC as a post-process on a host engine's own images, recorded into the
//! host's own command buffer: the paper's use of the technique.
//!
//! The host draws its G-buffer (world position, normal, diffuse albedo) and
//! its clamped lighting `S0 = T Le + T_b L^` with its own pipelines, then
//! calls [`SsbcPostProcess::record`], which records the geometry pyramid and
//! K residual steps `S_k = T_r S_{k-1}` and copies the compensated image
//! `S0 + S_1 + ... + S_K` (or one step's residual) into the host's output
//! image. The host ends, submits and synchronises the command buffer with
//! its own semaphores or fences.
//!
//! Images (all 2D, one mip, one layer, the same size):
//!
//! | image | format | usage | layout on entry | layout on exit |
//! |---|---|---|---|---|
//! | position (xyz world, w = 0 off geometry), normal (xyz), albedo (rgb), S0 (rgb) | `R32G32B32A32_SFLOAT` | `STORAGE` | any (declared) | `GENERAL`, last read by compute shaders |
//! | output | `R32G32B32A32_SFLOAT` | `TRANSFER_DST` | any (declared) | `TRANSFER_DST_OPTIMAL`, last written by a copy |
//! | optional second layer ([`PostProcessInputs::hidden`]): position, normal, albedo, S0, all four **the same size as the others or half of it** (rounded up) | `R32G32B32A32_SFLOAT` | `STORAGE` | any (declared) | `GENERAL`, last read by compute shaders |
//!
//! With [`SsbcPostProcess::set_restore_layouts`], every image instead ends
//! in the layout it was declared in, ssbc's last access to it made
//! visible to all later commands.
//!
//! The second layer is a deep G-buffer's (Mara et al., HPG 2016): per
//! pixel `p` (at half resolution covering pixels `2p .. 2p + 1`), the nearest
//! surface at least a minimum separation farther from the camera than the
//! visible ones under it, back faces included, with the normal of its own
//! outward side (not turned to the camera), and its own clamped lighting
//! `S0`; w = 0 in position where there is none. SSBC then also gathers from
//! these hidden surfaces (receivers stay the visible pixels); with more
//! than one step it computes their residual too, as the next step's
//! sources. ssbc's own G-buffer pass draws it by depth peeling. At full
//! resolution its pixels are split at creases like the first layer's, and
//! it gives back more of what clamping removed; at half resolution it costs
//! a quarter (docs/ssbc-implementation.md has the figures).
//!
//! Barriers: ssbc's first barrier on each host image waits for all prior
//! commands' writes (`ALL_COMMANDS` / `MEMORY_WRITE`) and moves it from the
//! declared layout; on exit the host must make the output's transfer write
//! visible to whatever reads it next (and move the layouts back if it
//! needs to). Internal resources (the pyramids) belong to one of `slots`
//! frame slots: the host passes the slot of the frame being recorded and
//! guarantees the GPU has finished the slot's previous frame, as it does for
//! its own per-frame resources.
//!
//! Memory is the host's to budget before anything exists:
//! [`SsbcPostProcess::memory`] says what a [`PostProcessShape`] (size,
//! steps, second layer) holds per slot, [`SsbcPostProcess::prepare`] creates
//! it for every slot (at start-up and at a resize, outside any recording),
//! and [`SsbcPostProcess::record`] allocates nothing: inputs or settings of
//! another shape are an error that names both. Before `prepare` with a new
//! shape, or dropping an [`SsbcPostProcess`], the host waits for the command
//! buffers it recorded into (ssbc cannot see the host's submissions).

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::passes::ssbc::{
    SsbcCamera, SsbcFrame, SsbcGBuffer, SsbcInputs, SsbcLayer, SsbcPass, SsbcSettings,
};
use crate::passes::PassSlot;
use crate::settings::LayerResolution;
use crate::vk::{DescriptorPool, Device, GpuFrameTimes, GpuProfiler, Image, ImageDesc, Recorder};

/// What a post-process's frame slots are made for: the image size, SSBC's
/// steps and coarsest evaluation level, and the second layer's resolution
/// (`None`: one layer). [`SsbcPostProcess::prepare`] creates the resources
/// for one; [`SsbcPostProcess::record`] needs inputs and settings of that
/// shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PostProcessShape {
    /// Width and height of the host's images (the first layer's).
    pub extent: (u32, u32),
    /// Residual steps K ([`SsbcSettings::steps`]).
    pub steps: u32,
    /// [`SsbcSettings::max_eval_level`].
    pub max_eval_level: u32,
    /// The second layer's resolution, if the host gives one
    /// ([`PostProcessInputs::hidden`]).
    pub layer1: Option<LayerResolution>,
}

impl PostProcessShape {
    /// The shape for images of `extent` with `settings`, and a second layer
    /// at `layer1`'s resolution if any.
    pub fn new(
        extent: (u32, u32),
        settings: &SsbcSettings,
        layer1: Option<LayerResolution>,
    ) -> Self {
        Self {
            extent,
            steps: settings.steps,
            max_eval_level: settings.max_eval_level,
            layer1,
        }
    }
}

/// Device memory a post-process holds ([`SsbcPostProcess::memory`]), in
/// bytes. Nothing carries over from one frame to the next (no history): the
/// pyramids, evaluation points, work lists and residuals are all rewritten
/// every frame, so a host may count them as per-frame scratch, though ssbc
/// owns them from `prepare` until the next `prepare` or the drop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PostProcessMemory {
    /// One frame slot's resources.
    pub per_slot: u64,
    /// Every slot's.
    pub total: u64,
    /// Of `total`, what must survive between frames: none.
    pub persistent: u64,
    /// Of `total`, what each frame rewrites before reading: all of it.
    pub transient: u64,
}

pub use crate::vk::HostImage;

/// What the host wants in its output image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PostOutput {
    /// `S0 + S_1 + ... + S_K`.
    Compensated,
    /// One step's residual `S_k` (1-based).
    Residual(u32),
}

/// How SSBC reads the receivers' BRDF from the host's images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReceiverBrdf {
    /// Lambertian of the albedo image's rgb; the w channels of the albedo
    /// and normal images are not read (what every host got before there
    /// was a choice, bit for bit).
    #[default]
    Lambertian,
    /// glTF 2.0 metallic-roughness (ssbc's G-buffer encoding): the albedo
    /// image's rgb is the base colour and w the metallic, the normal image's
    /// w the perceptual roughness (negative: that pixel is Lambertian).
    /// Such receivers reflect the residual towards the camera with their
    /// BRDF, each evaluated alone.
    MetallicRoughnessInW,
}

/// The host's inputs for one frame.
#[derive(Clone, Copy, Debug)]
pub struct PostProcessInputs {
    /// World-space position (xyz; w = 0 where there is no geometry).
    pub position: HostImage,
    /// Shading normal (xyz, unit length).
    pub normal: HostImage,
    /// Diffuse albedo (rgb).
    pub albedo: HostImage,
    /// The clamped lighting `S0` (rgb radiance towards the camera).
    pub s0: HostImage,
    /// What each pixel sends as a source of the first step, made
    /// view-independent (None: `s0` itself, right for Lambertian surfaces).
    /// ssbc's renderer sends each surface's reflected light spread evenly
    /// by its hemispherical albedo, specular lobe included
    /// (docs/ssbc-implementation.md); later steps do the same with
    /// `receivers`.
    pub sources: Option<HostImage>,
    /// How the receivers reflect.
    pub receivers: ReceiverBrdf,
    /// Where the result goes.
    pub output: HostImage,
    /// Camera position (world).
    pub camera_position: glam::Vec3,
    /// Unit optical axis.
    pub camera_forward: glam::Vec3,
    /// The image's up direction (row 0 is the top; made orthogonal to the
    /// optical axis). With the axis, it places each pixel's square in the
    /// world, which SSBC needs to split pixels at creases.
    pub camera_up: glam::Vec3,
    /// Vertical field of view (radians).
    pub yfov: f32,
    /// The clamping bound b (1/m²) the host's `S0` was clamped with.
    pub bound: f32,
    /// Distance along the optical axis where most of the image lies (e.g.
    /// to the scene's centre): picks the coarsest evaluation level.
    pub typical_depth: f32,
    /// An optional second G-buffer layer of hidden surfaces (see the module
    /// documentation), whose surfaces SSBC gathers from as well.
    pub hidden: Option<PostProcessLayer>,
}

/// The host's second G-buffer layer, at full or half resolution (rounded
/// up): the position image's size says which.
#[derive(Clone, Copy, Debug)]
pub struct PostProcessLayer {
    /// World-space position (xyz; w = 0 where there is no hidden surface).
    pub position: HostImage,
    /// The normal of the surface's own (outward) side, unit length.
    pub normal: HostImage,
    /// Diffuse albedo (rgb).
    pub albedo: HostImage,
    /// Its clamped lighting `S0` (rgb radiance).
    pub s0: HostImage,
}

/// Passes timed per frame slot: the post-process's query pools hold
/// 2 x this + 2 timestamps (and this many pipeline-statistics queries where
/// the device has them) per slot.
pub const PROFILED_PASSES: u32 = 1024;

/// One slot's pyramids and images, for the shape they were made for.
type SsbcSlot = PassSlot<PostProcessShape, SsbcFrame>;

/// SSBC on the host's images (see the module documentation). Command
/// buffers must be submitted in the order they were recorded.
///
/// `examples/postprocess.rs` is a whole host; the call itself:
///
/// ```no_run
/// use ash::vk;
/// use ssbc::postprocess::{
///     HostImage, PostOutput, PostProcessInputs, PostProcessShape, ReceiverBrdf, SsbcPostProcess,
/// };
///
/// /// At start-up and at a resize (the GPU idle): the budget, then the
/// /// resources of every frame slot.
/// fn resize(post: &mut SsbcPostProcess, slots: usize, size: (u32, u32)) -> ssbc::Result<()> {
///     let settings = ssbc::SsbcSettings { steps: 2, ..Default::default() };
///     let shape = PostProcessShape::new(size, &settings, None);
///     println!("SSBC: {} MiB", SsbcPostProcess::memory(&shape, slots).total >> 20);
///     post.prepare(shape)
/// }
///
/// /// Records SSBC after the host's G-buffer and clamped-lighting passes.
/// fn compensate(
///     post: &mut SsbcPostProcess, // SsbcPostProcess::new(&device, frames_in_flight)
///     cmd: vk::CommandBuffer,     // the host's, recording
///     frame_slot: usize,
///     [position, normal, albedo, s0, output]: [HostImage; 5],
///     camera: &ssbc::scene::Camera,
///     bound: f32,
/// ) -> ssbc::Result<()> {
///     let inputs = PostProcessInputs {
///         position,
///         normal,
///         albedo,
///         s0,
///         sources: None,
///         receivers: ReceiverBrdf::Lambertian,
///         output,
///         camera_position: camera.position,
///         camera_forward: camera.forward,
///         camera_up: camera.up,
///         yfov: camera.yfov,
///         bound,
///         typical_depth: 5.0,
///         hidden: None,
///     };
///     let settings = ssbc::SsbcSettings { steps: 2, ..Default::default() };
///     post.record(cmd, frame_slot, &inputs, &settings, PostOutput::Compensated)
/// }
/// ```
pub struct SsbcPostProcess {
    // Field order is drop order: resources before the device.
    slots: Vec<Option<SsbcSlot>>,
    pass: SsbcPass,
    /// Timestamps per slot, reset and written in the host's command buffer.
    profiler: GpuProfiler,
    /// Move the host's images back to their declared layouts on exit.
    restore_layouts: bool,
    device: Arc<Device>,
}

/// The host's images of one frame, wrapped for barriers.
struct WrappedInputs {
    position: Image,
    normal: Image,
    albedo: Image,
    s0: Image,
    sources: Option<Image>,
    out: Image,
    hidden: Option<[Image; 4]>,
}

impl WrappedInputs {
    fn new(device: &Arc<Device>, inputs: &PostProcessInputs) -> Self {
        let wrap = |image: &HostImage, usage| {
            let (w, h) = image.extent;
            Image::from_host(
                device,
                image.image,
                image.view,
                ImageDesc::new_2d(image.format, w, h, usage),
                image.layout,
            )
        };
        let storage = vk::ImageUsageFlags::STORAGE;
        Self {
            position: wrap(&inputs.position, storage),
            normal: wrap(&inputs.normal, storage),
            albedo: wrap(&inputs.albedo, storage),
            s0: wrap(&inputs.s0, storage),
            sources: inputs.sources.map(|image| wrap(&image, storage)),
            out: wrap(&inputs.output, vk::ImageUsageFlags::TRANSFER_DST),
            hidden: inputs
                .hidden
                .map(|l| [l.position, l.normal, l.albedo, l.s0].map(|image| wrap(&image, storage))),
        }
    }

    /// The visible layer and the optional hidden one, as SSBC reads them
    /// (the host's G-buffer has no separate geometric normals).
    fn layers(&self) -> (SsbcLayer<'_>, Option<SsbcLayer<'_>>) {
        let visible = SsbcLayer {
            gbuffer: SsbcGBuffer {
                position: &self.position,
                normal: &self.normal,
                albedo: &self.albedo,
                geometric: None,
            },
            s0: &self.s0,
            sources: self.sources.as_ref().unwrap_or(&self.s0),
        };
        let hidden = self
            .hidden
            .as_ref()
            .map(|[position, normal, albedo, s0]| SsbcLayer {
                gbuffer: SsbcGBuffer {
                    position,
                    normal,
                    albedo,
                    geometric: None,
                },
                s0,
                sources: s0,
            });
        (visible, hidden)
    }

    /// Moves every image back to the layout `inputs` declared for it
    /// (those declared `UNDEFINED` stay as ssbc left them).
    fn hand_back(&self, rec: &mut Recorder<'_>, inputs: &PostProcessInputs) {
        let mut host = vec![
            (&self.position, inputs.position.layout),
            (&self.normal, inputs.normal.layout),
            (&self.albedo, inputs.albedo.layout),
            (&self.s0, inputs.s0.layout),
            (&self.out, inputs.output.layout),
        ];
        if let (Some(image), Some(declared)) = (&self.sources, &inputs.sources) {
            host.push((image, declared.layout));
        }
        if let (Some(images), Some(l)) = (&self.hidden, &inputs.hidden) {
            let declared = [l.position, l.normal, l.albedo, l.s0].map(|i| i.layout);
            host.extend(images.iter().zip(declared));
        }
        for (image, layout) in host {
            if layout != vk::ImageLayout::UNDEFINED {
                rec.hand_back(image, layout);
            }
        }
    }
}

impl PostProcessInputs {
    /// The SSBC camera of these inputs, for an image `height` pixels high.
    fn camera(&self, height: u32) -> SsbcCamera {
        SsbcCamera {
            position: self.camera_position,
            forward: self.camera_forward.normalize(),
            up: self.camera_up.reject_from(self.camera_forward).normalize(),
            pixel_side: 2.0 * (self.yfov * 0.5).tan() / height as f32,
        }
    }
}

impl SsbcPostProcess {
    /// Creates the pipelines for `slots` frames in flight.
    pub fn new(device: &Arc<Device>, slots: usize) -> Result<Self> {
        if slots == 0 {
            return Err(Error::InvalidParameter(
                "SsbcPostProcess needs at least one frame slot".into(),
            ));
        }
        Ok(Self {
            slots: (0..slots).map(|_| None).collect(),
            pass: SsbcPass::new(device)?,
            // Room for 16 steps of up to 31 scopes each (8 evaluation levels
            // of eval, eval/glossy and resolve; the step's own scopes).
            profiler: GpuProfiler::new(device, PROFILED_PASSES, slots, true, true)?
                .with_recorded_resets(),
            restore_layouts: false,
            device: device.clone(),
        })
    }

    /// With `on`, each later `record` ends by moving every host image back
    /// to the layout its [`HostImage::layout`] declared (its last use by
    /// ssbc made visible to all later commands); images declared
    /// `UNDEFINED` stay as ssbc left them. Off (the default): the layouts
    /// on exit are those of the module documentation's table.
    pub fn set_restore_layouts(&mut self, on: bool) {
        self.restore_layouts = on;
    }

    /// Device memory `slots` frame slots of `shape` hold, computed before
    /// anything is created: the bytes its resources ask for. A device adds
    /// alignment and padding to each ([`SsbcPostProcess::memory_on`]).
    pub fn memory(shape: &PostProcessShape, slots: usize) -> PostProcessMemory {
        let per_slot =
            crate::passes::ssbc::frame_bytes(None, shape.extent, shape.steps, shape.layer1);
        Self::memory_of(per_slot, slots)
    }

    /// [`SsbcPostProcess::memory`] on `device`, from each resource's memory
    /// requirements there (asked before anything exists): what the
    /// allocator takes (docs/performance.md).
    pub fn memory_on(device: &Device, shape: &PostProcessShape, slots: usize) -> PostProcessMemory {
        let per_slot =
            crate::passes::ssbc::frame_bytes(Some(device), shape.extent, shape.steps, shape.layer1);
        Self::memory_of(per_slot, slots)
    }

    fn memory_of(per_slot: u64, slots: usize) -> PostProcessMemory {
        let total = per_slot * slots as u64;
        PostProcessMemory {
            per_slot,
            total,
            persistent: 0,
            transient: total,
        }
    }

    /// Creates every frame slot's resources for `shape` (at start-up and when
    /// the host's images change size), outside any recording. Slots already
    /// of that shape are kept. The host has waited for every command buffer
    /// it recorded into before a new shape.
    pub fn prepare(&mut self, shape: PostProcessShape) -> Result<()> {
        let (w, h) = shape.extent;
        if shape.steps == 0 {
            return Err(Error::InvalidParameter(
                "SSBC post-process with 0 steps has nothing to do".into(),
            ));
        }
        crate::passes::ssbc::check_size(&self.device, w, h, shape.layer1)?;
        let needed = Self::memory_on(&self.device, &shape, self.slots.len()).total;
        let heap = self.device.device_local_heap();
        if needed > heap {
            return Err(Error::InvalidParameter(format!(
                "SSBC post-process: {w}x{h} with {} steps needs about {} MiB of device memory for {} frame slots; this device's largest heap has {} MiB",
                shape.steps,
                needed >> 20,
                self.slots.len(),
                heap >> 20
            )));
        }
        let (pass, device) = (&self.pass, &self.device);
        for (slot, entry) in self.slots.iter_mut().enumerate() {
            PassSlot::refresh(
                entry,
                shape,
                |_| Ok(false),
                || {
                    pass.allocate(
                        device,
                        shape.extent,
                        shape.steps,
                        shape.max_eval_level,
                        shape.layer1,
                    )
                },
                |frame| {
                    let pool = DescriptorPool::new(device, &pass.frame_layouts(frame))?;
                    pool.name(&format!("ssbc post-process slot {slot} descriptor pool"));
                    Ok(pool)
                },
            )?;
        }
        Ok(())
    }

    /// The image size and the second layer's resolution, if the inputs are
    /// valid.
    fn check(inputs: &PostProcessInputs) -> Result<((u32, u32), Option<LayerResolution>)> {
        let extent = inputs.position.extent;
        let same = format!("the size of the position image, {extent:?}");
        let mut named = vec![
            ("position", &inputs.position, extent, same.clone()),
            ("normal", &inputs.normal, extent, same.clone()),
            ("albedo", &inputs.albedo, extent, same.clone()),
            ("s0", &inputs.s0, extent, same.clone()),
            ("output", &inputs.output, extent, same.clone()),
        ];
        if let Some(sources) = &inputs.sources {
            named.push(("sources", sources, extent, same.clone()));
        }
        // The second layer's position image says its resolution; the other
        // three follow it.
        let mut layer1 = None;
        if let Some(hidden) = &inputs.hidden {
            let half = LayerResolution::Half.extent(extent);
            let r = if hidden.position.extent == half && half != extent {
                LayerResolution::Half
            } else {
                LayerResolution::Full
            };
            let layer1_extent = r.extent(extent);
            let either = format!(
                "the size of the position image ({extent:?}) or half of it, rounded up ({half:?})"
            );
            let like = format!("{layer1_extent:?}, the size of the second layer's position image");
            named.extend([
                (
                    "second layer's position",
                    &hidden.position,
                    layer1_extent,
                    either,
                ),
                (
                    "second layer's normal",
                    &hidden.normal,
                    layer1_extent,
                    like.clone(),
                ),
                (
                    "second layer's albedo",
                    &hidden.albedo,
                    layer1_extent,
                    like.clone(),
                ),
                ("second layer's s0", &hidden.s0, layer1_extent, like),
            ]);
            layer1 = Some(r);
        }
        for (name, image, wanted, what) in named {
            if image.format != vk::Format::R32G32B32A32_SFLOAT {
                return Err(Error::InvalidParameter(format!(
                    "SSBC post-process: the {name} image is {:?}; it must be R32G32B32A32_SFLOAT",
                    image.format
                )));
            }
            if image.extent != wanted {
                return Err(Error::InvalidParameter(format!(
                    "SSBC post-process: the {name} image is {:?}; it must be {what}",
                    image.extent
                )));
            }
        }
        let up = inputs.camera_up.reject_from(inputs.camera_forward);
        let finite = inputs.camera_position.is_finite()
            && inputs.camera_forward.is_finite()
            && up.is_finite()
            && up.length_squared() > 0.0
            && inputs.yfov.is_finite()
            && inputs.typical_depth.is_finite();
        if !finite || inputs.yfov <= 0.0 || inputs.bound.is_nan() || inputs.bound <= 0.0 {
            return Err(Error::InvalidParameter(
                "SSBC post-process: camera (with an up vector not along the optical axis), field of view, depth and bound must be finite and positive"
                    .into(),
            ));
        }
        Ok((extent, layer1))
    }

    fn check_settings(settings: &SsbcSettings, output: PostOutput) -> Result<()> {
        settings.validate()?;
        if settings.steps == 0 {
            return Err(Error::InvalidParameter(
                "SSBC post-process with 0 steps has nothing to do".into(),
            ));
        }
        if let PostOutput::Residual(k) = output {
            if k == 0 || k > settings.steps {
                return Err(Error::InvalidParameter(format!(
                    "residual {k} asked for, with {} steps",
                    settings.steps
                )));
            }
        }
        Ok(())
    }

    /// Records SSBC for the frame in `slot` into the host's command buffer
    /// `cmd` (recording, outside any render pass), in the resources
    /// [`SsbcPostProcess::prepare`] made for the shape of `inputs` and
    /// `settings`; allocates nothing. See the module documentation for
    /// layouts and synchronisation.
    pub fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        slot: usize,
        inputs: &PostProcessInputs,
        settings: &SsbcSettings,
        output: PostOutput,
    ) -> Result<()> {
        let ((w, h), layer1) = Self::check(inputs)?;
        Self::check_settings(settings, output)?;
        let slot_count = self.slots.len();
        let entry = self
            .slots
            .get_mut(slot)
            .ok_or_else(|| Error::InvalidParameter(format!("frame slot {slot} of {slot_count}")))?;
        let shape = PostProcessShape::new((w, h), settings, layer1);
        // The host finished this slot's previous frame (its promise).
        let prepared = entry.as_ref().map(|held| *held.key());
        let Some(held) = PassSlot::reuse(entry, &shape)? else {
            let prepared = prepared.map_or("nothing".to_string(), |p| format!("{p:?}"));
            return Err(Error::InvalidParameter(format!(
                "SSBC post-process: frame slot {slot} holds {prepared}, these inputs and settings need {shape:?}: call prepare() with it first (record() allocates nothing)"
            )));
        };
        let (frame, pool) = (&held.resources, &held.pool);

        let images = WrappedInputs::new(&self.device, inputs);
        let out = &images.out;
        let camera = inputs.camera(h);
        let eval_level = SsbcPass::eval_level(
            &camera,
            inputs.typical_depth,
            inputs.bound,
            frame.levels(),
            settings,
        );

        let mut rec = Recorder::for_host(&self.device, cmd);
        // The host finished the slot's previous frame: its queries are free.
        self.profiler.begin_frame(cmd, slot, true);
        let scope = self.profiler.begin(cmd, "ssbc_postprocess");
        let (visible, hidden) = images.layers();
        let recorded = self.pass.record_steps(
            &mut rec,
            &mut self.profiler,
            pool,
            visible,
            hidden,
            &SsbcInputs {
                camera: &camera,
                bound: inputs.bound,
                eval_level,
                settings,
                glossy_receivers: inputs.receivers == ReceiverBrdf::MetallicRoughnessInW,
            },
            frame,
        );
        if let Err(e) = recorded {
            // The slot's tracked states describe commands the host will
            // not submit as they are: start it afresh next time.
            self.slots[slot] = None;
            return Err(e);
        }
        let result = match output {
            PostOutput::Compensated => &frame.final_image,
            PostOutput::Residual(k) => &frame.residuals[k as usize - 1],
        };
        rec.copy_image(result, (0, 0), out, (w, h));
        if self.restore_layouts {
            images.hand_back(&mut rec, inputs);
        }
        rec.flush_barriers();
        self.profiler.end(cmd, scope);
        self.profiler.end_frame(cmd);
        // Recorded; the host submits it.
        self.profiler.submitted(slot);
        Ok(())
    }

    /// GPU times of the frame last recorded in `slot`, per pass (the same
    /// names and parts as ssbc's own frames' `ssbc_step_k`, under
    /// `ssbc_postprocess`), read without waiting once the host knows that
    /// frame has finished (its fence), e.g. before recording the slot again.
    /// None: the slot has no recorded frame, the device's queue has no
    /// timestamps, or the frame's results are not all available yet.
    pub fn timings(&self, slot: usize) -> Result<Option<GpuFrameTimes>> {
        if slot >= self.slots.len() {
            return Err(Error::InvalidParameter(format!(
                "frame slot {slot} of {}",
                self.slots.len()
            )));
        }
        if !self.profiler.has_frame(slot) {
            return Ok(None);
        }
        self.profiler.try_resolve(slot)
    }
}
