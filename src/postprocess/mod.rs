//! SSBC as a post-process on a host engine's own images, recorded into the
//! host's own command buffer: the paper's use of the technique.
//!
//! The host draws its G-buffer (world position or depth, normal, diffuse
//! albedo) and its clamped lighting `S0 = T Le + T_b L^` with its own
//! pipelines, then calls [`SsbcPostProcess::record`], which records the
//! geometry pyramid and K residual steps `S_k = T_r S_{k-1}` and writes the
//! compensated image `S0 + S_1 + ... + S_K` (or one step's residual) into
//! the host's output image, or adds the compensation onto it. The host
//! ends, submits and synchronises the command buffer with its own
//! semaphores or fences.
//!
//! The camera ([`HostCamera`]) is a symmetric frustum or the host's view
//! and projection matrices (any perspective in Vulkan clip space: reversed
//! or infinite Z, off-centre, with a per-frame sub-pixel jitter); SSBC
//! splits pixels at creases where the jittered pixels really are.
//!
//! Images (all 2D, one mip, one layer, the same size). Where every input of
//! the first layer is `R32G32B32A32_SFLOAT`, with world positions and
//! signed normals, ssbc reads them in place as storage images
//! ([`Conversion::None`]). Otherwise it reads them all through sampling
//! (sRGB, UNORM, SNORM and packed formats decoded by the sampler; depth
//! turned into positions with the inverse of the jittered view-projection)
//! into copies of its own, which [`PostProcessShape`] counts
//! (48 bytes a pixel, 64 with sources). Either way SSBC's kernels read
//! normal and albedo packed as ssbc's own G-buffer holds them (four
//! 16-bit normalized values each, 16 bytes a pixel for both; the albedo
//! clamped to [0, 1]): copies of both layers' normal and albedo that
//! ssbc packs each frame from the images it reads in place.
//! [`FORMATS`] lists what each accepts; anything else is refused by name,
//! as is a format the device cannot sample or store.
//!
//! | image | formats | usage | layout on entry | layout on exit |
//! |---|---|---|---|---|
//! | geometry: position (xyz world, w = 0 off geometry) | `R32G32B32A32_SFLOAT` | `STORAGE` in place, else `SAMPLED` | any (declared) | `GENERAL` in place, else `SHADER_READ_ONLY_OPTIMAL` |
//! | geometry: depth (with [`HostCamera::Matrices`] and the background depth) | `D32_SFLOAT`, `D32_SFLOAT_S8_UINT`, `D24_UNORM_S8_UINT`, `X8_D24_UNORM_PACK32`, `D16_UNORM`, `R32_SFLOAT` | `SAMPLED` (a view of the depth aspect) | any (declared) | `SHADER_READ_ONLY_OPTIMAL` |
//! | normal, [`NormalEncoding`] `Signed` / `Unsigned` (xyz; w the roughness for [`ReceiverBrdf::MetallicRoughnessInW`]) | `R32G32B32A32_SFLOAT`, `R16G16B16A16_SFLOAT`, `R16G16B16A16_SNORM`, `R16G16B16A16_UNORM`, `R8G8B8A8_SNORM`, `R8G8B8A8_UNORM`, `A2B10G10R10_UNORM_PACK32`, `A2R10G10B10_UNORM_PACK32` | as position | any (declared) | as position |
//! | normal, `Octahedral` / `OctahedralUnsigned` (Lambertian receivers) | `R32G32_SFLOAT`, `R16G16_SFLOAT`, `R16G16_SNORM`, `R16G16_UNORM`, `R8G8_SNORM`, `R8G8_UNORM` | `SAMPLED` | any (declared) | `SHADER_READ_ONLY_OPTIMAL` |
//! | albedo (rgb; w the metallic for `MetallicRoughnessInW`) | `R32G32B32A32_SFLOAT`, `R16G16B16A16_SFLOAT`, `R8G8B8A8_UNORM`, `R8G8B8A8_SRGB`, `B8G8R8A8_UNORM`, `B8G8R8A8_SRGB`, `A2B10G10R10_UNORM_PACK32` | as position | any (declared) | as position |
//! | S0 and sources (rgb) | `R32G32B32A32_SFLOAT`, `R16G16B16A16_SFLOAT`, `B10G11R11_UFLOAT_PACK32`, `E5B9G9R9_UFLOAT_PACK32` | as position | any (declared) | as position |
//! | output, [`OutputWrite::Copy`] | `R32G32B32A32_SFLOAT` | `TRANSFER_DST` | any (declared) | `TRANSFER_DST_OPTIMAL`, last written by a copy |
//! | output, [`OutputWrite::Store`] / [`OutputWrite::Add`] (may be the S0 image itself) | `R32G32B32A32_SFLOAT`, `R16G16B16A16_SFLOAT`, `B10G11R11_UFLOAT_PACK32` (where the device can store it) | `STORAGE` | any (declared) | `GENERAL`, last written by a compute shader |
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
//! declared layout; on exit the host must make the output's write visible
//! to whatever reads it next (and move the layouts back if it needs to). Internal resources (the pyramids) belong to one of `slots`
//! frame slots: the host passes the slot of the frame being recorded and
//! guarantees the GPU has finished the slot's previous frame, as it does for
//! its own per-frame resources.
//!
//! The post-process keeps no temporal history, by design: SSBC draws no
//! random samples (for given inputs its result is the same every frame);
//! all the noise in its output is the noise of the host's `S0` (its VPLs or
//! whatever sampled its lighting), which the host's own temporal
//! accumulation (its TAA or denoiser, with its motion vectors and
//! disocclusion tests) already averages. A second history inside ssbc would
//! average the same noise twice and lag behind the host's. ssbc's own
//! renderer does keep one ([`crate::Renderer::record_resident`]), because
//! there ssbc draws the VPLs whose noise it averages.
//!
//! Memory is the host's to budget before anything exists:
//! [`SsbcPostProcess::memory`] says what a [`PostProcessShape`] (size,
//! steps, second layer, conversion; [`PostProcessShape::for_inputs`]) holds
//! per slot, [`SsbcPostProcess::prepare`] creates
//! it for every slot (at start-up and at a resize, outside any recording),
//! and [`SsbcPostProcess::record`] allocates nothing: inputs or settings of
//! another shape are an error that names both. Before `prepare` with a new
//! shape, or dropping an [`SsbcPostProcess`], the host waits for the command
//! buffers it recorded into (ssbc cannot see the host's submissions).

use std::sync::Arc;

use ash::vk;

use crate::error::{Error, Result};
use crate::passes::ssbc::{
    FinalImage, Kept, SsbcFrame, SsbcGBuffer, SsbcInputs, SsbcLayer, SsbcPass, SsbcSettings,
};
use crate::passes::PassSlot;
use crate::settings::LayerResolution;
use crate::vk::{DescriptorPool, Device, GpuFrameTimes, GpuProfiler, Image, ImageDesc, Recorder};

mod camera;
mod convert;
mod inputs;

use convert::{ConvertedInputs, HostIo, PackedInputs, SampledInputs};

pub use crate::vk::HostImage;
pub use camera::HostCamera;
pub use inputs::{
    Conversion, HostGeometry, NormalEncoding, OutputWrite, PostOutput, PostProcessInputs,
    PostProcessLayer, ReceiverBrdf, FORMATS,
};

/// The post-process keeps its own final image (S0 is the host's) and each
/// step's residual (`PostOutput::Residual`).
const KEPT: Kept = Kept {
    final_image: FinalImage::Own,
    residuals: true,
    // (The host's receivers may be glossy.)
    glossy_rests: true,
};

/// What a post-process's frame slots are made for: the image size, SSBC's
/// steps and coarsest evaluation level, the second layer's resolution
/// (`None`: one layer) and whether the first layer is converted.
/// [`SsbcPostProcess::prepare`] creates the resources for one;
/// [`SsbcPostProcess::record`] needs inputs and settings of that shape.
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
    /// Whether the first layer is read in place or converted into ssbc's
    /// own copies (which its formats decide; see the module documentation).
    pub conversion: Conversion,
}

impl PostProcessShape {
    /// The shape for RGBA32F images of `extent` (world positions, signed
    /// normals: read in place) with `settings`, and a second layer at
    /// `layer1`'s resolution if any.
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
            conversion: Conversion::None,
        }
    }

    /// The shape `inputs` and `settings` need (their sizes, second layer
    /// and formats), or what is wrong with them.
    pub fn for_inputs(inputs: &PostProcessInputs, settings: &SsbcSettings) -> Result<Self> {
        Ok(Self::of(&inputs.check()?, settings))
    }

    fn of(checked: &inputs::Checked, settings: &SsbcSettings) -> Self {
        Self {
            conversion: checked.conversion,
            ..Self::new(checked.extent, settings, checked.layer1)
        }
    }
}

/// Device memory a post-process holds ([`SsbcPostProcess::memory`]), in
/// bytes. Nothing carries over from one frame to the next (no history): the
/// pyramids, evaluation points, work lists, residuals and converted inputs
/// are all rewritten every frame, so a host may count them as per-frame
/// scratch, though ssbc owns them from `prepare` until the next `prepare`
/// or the drop.
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

/// Passes timed per frame slot: the post-process's query pools hold
/// 2 x this + 2 timestamps (and this many pipeline-statistics queries where
/// the device has them) per slot.
pub const PROFILED_PASSES: u32 = 1024;

/// One slot's resources.
struct SlotResources {
    frame: SsbcFrame,
    converted: Option<ConvertedInputs>,
    /// The first layer's normal and albedo packed, where the rest is read
    /// in place (no conversion).
    packed: Option<PackedInputs>,
    /// The second layer's, if there is one.
    packed_hidden: Option<PackedInputs>,
}

/// One slot's resources, for the shape they were made for.
type SsbcSlot = PassSlot<PostProcessShape, SlotResources>;

/// SSBC on the host's images (see the module documentation). Command
/// buffers must be submitted in the order they were recorded.
///
/// `examples/postprocess.rs` is a whole host; the call itself:
///
/// ```no_run
/// use ash::vk;
/// use ssbc::postprocess::{
///     HostCamera, HostGeometry, HostImage, NormalEncoding, OutputWrite, PostOutput,
///     PostProcessInputs, PostProcessShape, ReceiverBrdf, SsbcPostProcess,
/// };
///
/// /// At start-up and at a resize (the GPU idle): the budget, then the
/// /// resources of every frame slot.
/// fn resize(post: &mut SsbcPostProcess, slots: usize, inputs: &PostProcessInputs) -> ssbc::Result<()> {
///     let settings = ssbc::SsbcSettings { steps: 2, ..Default::default() };
///     let shape = PostProcessShape::for_inputs(inputs, &settings)?;
///     println!("SSBC: {} MiB", SsbcPostProcess::memory(&shape, slots).total >> 20);
///     post.prepare(shape)
/// }
///
/// /// The inputs of a host with a depth buffer, RGB10A2 normals, sRGB
/// /// albedo and an RGBA16F lighting image that SSBC adds onto.
/// fn inputs(
///     [depth, normal, albedo, lighting]: [HostImage; 4],
///     view: glam::Mat4,
///     projection: glam::Mat4, // Vulkan clip space, reversed Z
///     jitter: glam::Vec2,     // this frame's TAA offset, in pixels
///     bound: f32,             // the b the host clamped its lighting with
/// ) -> PostProcessInputs {
///     PostProcessInputs {
///         geometry: HostGeometry::Depth { image: depth, background: 0.0 },
///         normal,
///         normal_encoding: NormalEncoding::Unsigned,
///         albedo,
///         s0: lighting,
///         sources: None,
///         receivers: ReceiverBrdf::Lambertian,
///         output: lighting,
///         write: OutputWrite::Add,
///         camera: HostCamera::Matrices { view, projection, jitter },
///         bound,
///         typical_depth: 5.0,
///         hidden: None,
///     }
/// }
///
/// /// Records SSBC after the host's G-buffer and clamped-lighting passes.
/// fn compensate(
///     post: &mut SsbcPostProcess, // SsbcPostProcess::new(&device, frames_in_flight)
///     cmd: vk::CommandBuffer,     // the host's, recording
///     frame_slot: usize,
///     inputs: &PostProcessInputs,
/// ) -> ssbc::Result<()> {
///     let settings = ssbc::SsbcSettings { steps: 2, ..Default::default() };
///     post.record(cmd, frame_slot, inputs, &settings, PostOutput::Compensated)
/// }
/// ```
pub struct SsbcPostProcess {
    // Field order is drop order: resources before the device.
    slots: Vec<Option<SsbcSlot>>,
    pass: SsbcPass,
    io: HostIo,
    /// Timestamps per slot, reset and written in the host's command buffer.
    profiler: GpuProfiler,
    /// Move the host's images back to their declared layouts on exit.
    restore_layouts: bool,
    device: Arc<Device>,
}

/// Writes `output` of `frame` into the host's output image (`images`) as
/// `inputs.write` says (less `s0` where adding the compensation alone).
fn write_result(
    io: &HostIo,
    (rec, profiler, pool): (&mut Recorder<'_>, &mut GpuProfiler, &DescriptorPool),
    inputs: &PostProcessInputs,
    (output, frame, images): (PostOutput, &SsbcFrame, &WrappedInputs),
    s0: &Image,
) -> Result<()> {
    let result = match output {
        PostOutput::Compensated => frame.final_image.as_ref().expect("FinalImage::Own"),
        PostOutput::Residual(k) => &frame.residuals[k as usize - 1],
    };
    let out = images.output();
    match inputs.write {
        OutputWrite::Copy => {
            let extent = inputs.geometry.image().extent;
            rec.copy_image(result, (0, 0), out, extent);
            Ok(())
        }
        write => {
            let (add, subtract) = convert::write_mode(write, output, images.out_is_s0);
            let subtract = subtract.then_some(s0);
            io.record_write(rec, profiler, pool, result, subtract, out, add)
        }
    }
}

/// The host's images of one frame, wrapped for barriers.
struct WrappedInputs {
    geometry: Image,
    normal: Image,
    albedo: Image,
    s0: Image,
    sources: Option<Image>,
    out: Image,
    /// The output is the s0 image: `out` takes over s0's tracked state
    /// before it is written.
    out_is_s0: bool,
    hidden: Option<[Image; 4]>,
}

impl WrappedInputs {
    fn new(device: &Arc<Device>, inputs: &PostProcessInputs, conversion: Conversion) -> Self {
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
        // Converted inputs are sampled; the others read as storage.
        let first = if conversion == Conversion::None {
            storage
        } else {
            vk::ImageUsageFlags::SAMPLED
        };
        let out_usage = match inputs.write {
            OutputWrite::Copy => vk::ImageUsageFlags::TRANSFER_DST,
            _ => storage,
        };
        Self {
            geometry: wrap(inputs.geometry.image(), first),
            normal: wrap(&inputs.normal, first),
            albedo: wrap(&inputs.albedo, first),
            s0: wrap(&inputs.s0, first),
            sources: inputs.sources.map(|image| wrap(&image, first)),
            out: wrap(&inputs.output, out_usage),
            out_is_s0: inputs.output.image == inputs.s0.image,
            hidden: inputs
                .hidden
                .map(|l| [l.position, l.normal, l.albedo, l.s0].map(|image| wrap(&image, storage))),
        }
    }

    /// The output image, ready to be written: where it is the s0 image, in
    /// the state ssbc's reads of s0 left it.
    fn output(&self) -> &Image {
        if self.out_is_s0 {
            self.out.state.set(self.s0.state.get());
        }
        &self.out
    }

    /// The visible layer (the host's images, or their converted copies)
    /// and the optional hidden one, as SSBC reads them (the host's
    /// G-buffer has no separate geometric normals): a layer read in place
    /// with its normal and albedo `packed` (first layer, hidden layer).
    fn layers<'a>(
        &'a self,
        converted: Option<&'a ConvertedInputs>,
        packed: (Option<&'a PackedInputs>, Option<&'a PackedInputs>),
    ) -> (SsbcLayer<'a>, Option<SsbcLayer<'a>>) {
        let packed_of = |p: Option<&'a PackedInputs>| p.expect("packed at prepare");
        let visible = match converted {
            Some(c) => SsbcLayer {
                gbuffer: SsbcGBuffer {
                    position: &c.position,
                    normal: &c.normal,
                    albedo: &c.albedo,
                    geometric: None,
                },
                s0: &c.s0,
                sources: c.sources.as_ref().unwrap_or(&c.s0),
            },
            None => SsbcLayer {
                gbuffer: SsbcGBuffer {
                    position: &self.geometry,
                    normal: &packed_of(packed.0).normal,
                    albedo: &packed_of(packed.0).albedo,
                    geometric: None,
                },
                s0: &self.s0,
                sources: self.sources.as_ref().unwrap_or(&self.s0),
            },
        };
        let hidden = self.hidden.as_ref().map(|[position, _, _, s0]| SsbcLayer {
            gbuffer: SsbcGBuffer {
                position,
                normal: &packed_of(packed.1).normal,
                albedo: &packed_of(packed.1).albedo,
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
            (&self.geometry, inputs.geometry.image().layout),
            (&self.normal, inputs.normal.layout),
            (&self.albedo, inputs.albedo.layout),
        ];
        // An output that is the s0 image holds its latest state.
        if !self.out_is_s0 {
            host.push((&self.s0, inputs.s0.layout));
        }
        host.push((&self.out, inputs.output.layout));
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
            io: HostIo::new(device)?,
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
        Self::memory_of(Self::slot_bytes(None, shape), slots)
    }

    /// [`SsbcPostProcess::memory`] on `device`, from each resource's memory
    /// requirements there (asked before anything exists): what the
    /// allocator takes (docs/performance.md).
    pub fn memory_on(device: &Device, shape: &PostProcessShape, slots: usize) -> PostProcessMemory {
        Self::memory_of(Self::slot_bytes(Some(device), shape), slots)
    }

    fn slot_bytes(device: Option<&Device>, shape: &PostProcessShape) -> u64 {
        let (steps, layer1) = (shape.steps, shape.layer1);
        crate::passes::ssbc::frame_bytes(device, shape.extent, (steps, layer1), KEPT)
            + ConvertedInputs::bytes(device, shape.conversion, shape.extent)
            + layer1.map_or(0, |r| PackedInputs::bytes(device, r.extent(shape.extent)))
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
    /// the host's images change size or format), outside any recording.
    /// Slots already of that shape are kept. The host has waited for every
    /// command buffer it recorded into before a new shape.
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
        let (pass, io, device) = (&self.pass, &self.io, &self.device);
        for (slot, entry) in self.slots.iter_mut().enumerate() {
            PassSlot::refresh(
                entry,
                shape,
                |_| Ok(false),
                || {
                    Ok(SlotResources {
                        frame: pass.allocate(
                            device,
                            shape.extent,
                            shape.steps,
                            shape.max_eval_level,
                            shape.layer1,
                            KEPT,
                            None,
                        )?,
                        converted: ConvertedInputs::new(
                            device,
                            shape.conversion,
                            shape.extent,
                            slot,
                        )?,
                        packed: (shape.conversion == Conversion::None)
                            .then(|| {
                                let name = format!("ssbc post-process slot {slot}");
                                PackedInputs::new(device, shape.extent, &name)
                            })
                            .transpose()?,
                        packed_hidden: shape
                            .layer1
                            .map(|r| {
                                let name = format!("ssbc post-process slot {slot} layer 1");
                                PackedInputs::new(device, r.extent(shape.extent), &name)
                            })
                            .transpose()?,
                    })
                },
                |held| {
                    let mut layouts = pass.frame_layouts(&held.frame);
                    layouts.extend(io.set_layouts());
                    let pool = DescriptorPool::new(device, &layouts)?;
                    pool.name(&format!("ssbc post-process slot {slot} descriptor pool"));
                    Ok(pool)
                },
            )?;
        }
        Ok(())
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
    /// formats, layouts and synchronisation.
    pub fn record(
        &mut self,
        cmd: vk::CommandBuffer,
        slot: usize,
        inputs: &PostProcessInputs,
        settings: &SsbcSettings,
        output: PostOutput,
    ) -> Result<()> {
        // Checked once: the shape and the camera.
        let checked = inputs.check()?;
        let shape = PostProcessShape::of(&checked, settings);
        Self::check_settings(settings, output)?;
        HostIo::check_device(&self.device, inputs, shape.conversion)?;
        let slot_count = self.slots.len();
        let entry = self
            .slots
            .get_mut(slot)
            .ok_or_else(|| Error::InvalidParameter(format!("frame slot {slot} of {slot_count}")))?;
        // The host finished this slot's previous frame (its promise).
        let prepared = entry.as_ref().map(|held| *held.key());
        let Some(held) = PassSlot::reuse(entry, &shape)? else {
            let prepared = prepared.map_or("nothing".to_string(), |p| format!("{p:?}"));
            return Err(Error::InvalidParameter(format!(
                "SSBC post-process: frame slot {slot} holds {prepared}, these inputs and settings need {shape:?}: call prepare() with it first (record() allocates nothing)"
            )));
        };
        let (resources, pool) = (&held.resources, &held.pool);
        let frame = &resources.frame;

        let images = WrappedInputs::new(&self.device, inputs, shape.conversion);
        let camera = checked.camera;
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
        let recorded = (|| {
            let converted = resources.converted.as_ref();
            if let Some(copies) = converted {
                let host = SampledInputs {
                    geometry: &images.geometry,
                    normal: &images.normal,
                    albedo: &images.albedo,
                    s0: &images.s0,
                    sources: images.sources.as_ref(),
                };
                self.io
                    .record_convert(&mut rec, &mut self.profiler, pool, inputs, host, copies)?;
            }
            let packs = [
                (Some((&images.normal, &images.albedo)), &resources.packed),
                (
                    images.hidden.as_ref().map(|[_, n, a, _]| (n, a)),
                    &resources.packed_hidden,
                ),
            ];
            for (host, packed) in packs {
                if let (Some((normal, albedo)), Some(packed)) = (host, packed) {
                    let cx = (&mut rec, &mut self.profiler, pool);
                    self.io.record_pack(cx, normal, albedo, packed)?;
                }
            }
            let packed = (resources.packed.as_ref(), resources.packed_hidden.as_ref());
            let (visible, hidden) = images.layers(converted, packed);
            let s0 = visible.s0;
            self.pass.record_steps(
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
            )?;
            let target = (output, frame, &images);
            write_result(
                &self.io,
                (&mut rec, &mut self.profiler, pool),
                inputs,
                target,
                s0,
            )?;
            Ok::<_, Error>(())
        })();
        if let Err(e) = recorded {
            // The slot's tracked states describe commands the host will
            // not submit as they are: start it afresh next time.
            self.slots[slot] = None;
            return Err(e);
        }
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
