//! One file per technique pass. A pass implements [`Pass`]: it owns its
//! pipelines (created once with the renderer) and, per frame slot, the
//! resources it writes ([`Pass::Resources`], made for a [`Pass::Key`]) with
//! a descriptor pool sized for the sets it allocates per frame
//! ([`Pass::set_layouts`]). Recording a pass declares every resource it
//! touches (barriers follow from that), opens a GPU timestamp scope, and
//! records its commands. [`Stage`] keeps a pass's resources for every frame
//! slot and remakes them only when their key changes.
//!
//! Adding a pass: a file here implementing [`Pass`] (with the layers it
//! offers, [`Pass::layers`], which the read-back, GPU hand-off and host
//! copies pick from), a [`Stage`] of it in the renderer's `Passes`, and one
//! line in the renderer's list of passes, naming what it reads
//! (`passes/indirect_light.rs` is a small example).

pub mod direct_lighting;
pub mod gbuffer;
pub mod indirect_bounded;
pub mod indirect_light;
pub mod ism;
pub mod shadow_maps;
pub mod ssbc;
pub mod temporal;
pub mod transient;

use std::sync::Arc;

use ash::vk;
use glam::Mat4;

use crate::error::{Error, Result};
use crate::layer::Layer;
use crate::scene::Scene;
use crate::scene_cache::SceneCache;
use crate::settings::RenderSettings;
use crate::vk::{
    DescriptorPool, DescriptorSetLayout, Device, GpuProfiler, Image, ImageDesc, Recorder,
};
use ssbc::SsbcCamera;

/// What a pass's per-slot resources are made from: the device, the frame's
/// settings and the scene's CPU products.
pub struct SlotSetup<'a> {
    /// The device.
    pub device: &'a Arc<Device>,
    /// The frame slot (`0..FRAME_SLOTS`).
    pub slot: usize,
    /// The frame's settings.
    pub settings: &'a RenderSettings,
    /// The scene.
    pub scene: &'a Scene,
    /// Its bounds, VPLs, ISM points and GPU copy.
    pub cache: &'a SceneCache,
    /// The slot's transient memory, which passes whose resources never
    /// live at once share (None: each pass allocates its own).
    pub transient: Option<&'a transient::SlotTransient>,
    /// Whether the slot's frames keep temporal history (resident frames
    /// with `history.enabled`).
    pub history: bool,
    /// Whether they are a resident scene's (view-independent passes may
    /// keep their output for the slot's next frame).
    pub resident: bool,
}

impl SlotSetup<'_> {
    /// The extent of G-buffer layer `layer` (layer 1 at
    /// `ssbc.layer1_resolution`, see [`gbuffer`]).
    pub fn layer_extent(&self, layer: u32) -> (u32, u32) {
        match layer {
            0 => self.extent(),
            _ => self.settings.ssbc.layer1_resolution.extent(self.extent()),
        }
    }

    /// The image size.
    pub fn extent(&self) -> (u32, u32) {
        (self.settings.width, self.settings.height)
    }

    /// What the slot's transient memory depends on besides the settings.
    pub fn traits(&self) -> transient::SlotTraits {
        transient::SlotTraits::of(self.scene, self.history, self.resident)
    }

    /// Where `tenant` places its transient resources (None: in memory of
    /// their own).
    pub fn region(&self, tenant: transient::Tenancy) -> Option<crate::vk::AliasRegion> {
        self.transient?.region(tenant)
    }
}

/// The camera and bound every pass of a frame records with.
#[derive(Clone, Copy, Debug)]
pub struct FrameView {
    /// The camera as SSBC sees it (eye, optical axis, pixel side).
    pub camera: SsbcCamera,
    /// World to clip space.
    pub view_proj: Mat4,
    /// Distance along the optical axis to the centre of the scene's bounds.
    pub centre_depth: f32,
    /// The clamping bound b (1/m²).
    pub bound: f32,
    /// Length of the scene bounds' diagonal (m).
    pub diagonal: f32,
    /// Whether any material is glossy (not Lambertian): SSBC then gives
    /// glossy receivers their BRDF.
    pub glossy: bool,
    /// Whether any material has a normal map: SSBC then reads the
    /// G-buffer's geometric normals (without, the shading normal is the
    /// surface's and the pyramid's base level skips those loads).
    pub normal_maps: bool,
}

impl FrameView {
    /// World to clip space and the eye: what temporal history keeps of a
    /// frame's view.
    pub fn eye(&self) -> (Mat4, glam::Vec3) {
        (self.view_proj, self.camera.position)
    }
}

/// What a pass records with besides its own resources and what it reads.
pub struct Recording<'r, 'a> {
    /// The command buffer being recorded, with its barrier tracking.
    pub rec: &'r mut Recorder<'a>,
    /// Timestamp scopes and labels.
    pub profiler: &'r mut GpuProfiler,
    /// Camera and bound.
    pub view: &'r FrameView,
    /// The frame's settings.
    pub settings: &'r RenderSettings,
    /// A pass after which recording fails (tests that a failed frame leaves
    /// the renderer usable).
    pub fault: &'r mut Option<String>,
    /// Whether view-independent passes may keep what the slot's previous
    /// frame wrote ([`Pass::VIEW_INDEPENDENT`]): the frame is submitted by
    /// ssbc (a host's command buffer may never run) and the settings ask
    /// for it.
    pub reuse: bool,
    /// Passes that kept the slot's previous output instead of recording.
    pub reused: &'r mut Vec<String>,
}

impl Recording<'_, '_> {
    /// Fails if a fault was injected after the pass `name`.
    fn checkpoint(&mut self, name: &str) -> Result<()> {
        match self.fault.take_if(|f| f == name) {
            Some(f) => Err(Error::InvalidParameter(format!(
                "injected fault after {f} (a test of recovery)"
            ))),
            None => Ok(()),
        }
    }
}

/// A technique pass as the frame sees it.
pub trait Pass {
    /// Its name (descriptor pools, injected faults).
    const NAME: &'static str;
    /// Whether what it writes depends on nothing but its [`Key`](Pass::Key)
    /// (not on the camera): a slot whose resources hold what an earlier,
    /// submitted frame wrote for the same key keeps it and records nothing.
    const VIEW_INDEPENDENT: bool = false;
    /// What its resources were made for (size, settings, versions of the
    /// data they hold); they are updated or made anew when it changes.
    type Key: PartialEq;
    /// Its per-slot resources: what it writes, which later passes and the
    /// read-back see.
    type Resources;
    /// What it reads from earlier passes.
    type Reads<'a>;

    /// The G-buffer layer it works on (0: the visible surfaces; 1: the
    /// deep G-buffer's second layer); its name gets a `_layer1` suffix.
    fn layer(&self) -> u32 {
        0
    }
    /// Its name in descriptor pools and injected faults: [`Pass::NAME`],
    /// on layer 1 with `_layer1`.
    fn label(&self) -> String {
        layer_name(Self::NAME, self.layer())
    }
    /// The key of the resources `setup` needs.
    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key;
    /// Makes the resources.
    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<Self::Resources>;
    /// Rewrites the resources in place (no allocation) for a new key; false
    /// when they must be made anew. The slot's previous frame is done.
    fn update(&self, _resources: &mut Self::Resources, _setup: &SlotSetup<'_>) -> Result<bool> {
        Ok(false)
    }
    /// The images of `resources` a frame can hand out ([`Layer`]: read
    /// back, kept on the GPU, copied into a host's image). The frame's
    /// `Final` is the last pass's that offers one.
    fn layers<'r>(&self, _resources: &'r Self::Resources) -> Vec<(Layer, &'r Image)> {
        Vec::new()
    }
    /// Layouts of every descriptor set one frame allocates (one entry per set).
    fn set_layouts(&self, resources: &Self::Resources) -> Vec<&DescriptorSetLayout>;
    /// Records the pass, allocating its sets from `pool`.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        reads: Self::Reads<'_>,
        resources: &Self::Resources,
    ) -> Result<()>;
}

/// A pass's resources in one frame slot: what they were made for, and the
/// descriptor pool its sets come from each frame.
pub struct PassSlot<K, R> {
    key: K,
    /// The resources.
    pub resources: R,
    /// Sized for the sets one frame allocates; reset every frame.
    pub pool: DescriptorPool,
    /// Whether `resources` hold what the pass wrote for `key` in a frame
    /// ssbc submitted (cleared when they are made or rewritten).
    holds_output: bool,
}

impl<K: PartialEq, R> PassSlot<K, R> {
    /// What the resources were made for.
    pub fn key(&self) -> &K {
        &self.key
    }

    /// The slot's resources for a new frame (its previous frame is done),
    /// kept as they are with the pool reset, if they were made for `key`;
    /// `None`, making nothing, otherwise.
    pub fn reuse<'s>(held: &'s mut Option<Self>, key: &K) -> Result<Option<&'s mut Self>> {
        match held {
            Some(s) if s.key == *key => {
                s.pool.reset()?;
                Ok(Some(s))
            }
            _ => Ok(None),
        }
    }

    /// Brings `held` up to `key` for a new frame in its slot (whose previous
    /// frame is done): kept as it is for the same key, rewritten by
    /// `update` when it can be (true), made anew by `prepare` (and its pool
    /// by `pool`) otherwise. The pool is reset.
    pub fn refresh(
        held: &mut Option<Self>,
        key: K,
        update: impl FnOnce(&mut R) -> Result<bool>,
        prepare: impl FnOnce() -> Result<R>,
        pool: impl FnOnce(&R) -> Result<DescriptorPool>,
    ) -> Result<&mut Self> {
        if let Some(s) = held.as_mut() {
            let same = s.key == key;
            if same || update(&mut s.resources)? {
                s.holds_output &= same;
                s.key = key;
                s.pool.reset()?;
                return Ok(held.as_mut().expect("checked above"));
            }
        }
        *held = None; // free the old resources first
        let resources = prepare()?;
        let pool = pool(&resources)?;
        Ok(held.insert(Self {
            key,
            resources,
            pool,
            holds_output: false,
        }))
    }
}

/// A pass and its resources in every frame slot.
pub struct Stage<P: Pass> {
    /// The pass (pipelines and layouts).
    pub pass: P,
    slots: Vec<Option<PassSlot<P::Key, P::Resources>>>,
}

impl<P: Pass> Stage<P> {
    /// `pass` with `slots` frame slots, none prepared.
    pub fn new(pass: P, slots: usize) -> Self {
        Self {
            pass,
            slots: (0..slots).map(|_| None).collect(),
        }
    }

    /// Brings the slot's resources up to `setup`, records the pass reading
    /// `reads`, and returns what it wrote.
    pub fn run(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        reads: P::Reads<'_>,
    ) -> Result<&P::Resources> {
        let pass = &self.pass;
        let name = pass.label();
        let held = PassSlot::refresh(
            &mut self.slots[setup.slot],
            pass.key(setup),
            |resources| pass.update(resources, setup),
            || pass.prepare(setup),
            |resources| {
                let pool = DescriptorPool::new(setup.device, &pass.set_layouts(resources))?;
                pool.name(&format!(
                    "frame slot {} {name} descriptor pool",
                    setup.slot
                ));
                Ok(pool)
            },
        )?;
        if P::VIEW_INDEPENDENT && cx.reuse && held.holds_output {
            // Its inputs are those of the slot's previous frame, which ran.
            cx.reused.push(name.clone());
        } else {
            held.holds_output = false;
            pass.record(cx, &held.pool, reads, &held.resources)?;
            // Valid once the frame runs: a frame that fails before it is
            // submitted drops the slot's resources (`forget`).
            held.holds_output = P::VIEW_INDEPENDENT && cx.reuse;
        }
        cx.checkpoint(&name)?;
        Ok(&held.resources)
    }

    /// Takes the slot's resources out, to read them while another slot's
    /// are brought up; [`Stage::restore`] puts them back.
    pub fn take(&mut self, slot: usize) -> Option<PassSlot<P::Key, P::Resources>> {
        self.slots[slot].take()
    }

    /// Puts back what [`Stage::take`] took.
    pub fn restore(&mut self, slot: usize, held: Option<PassSlot<P::Key, P::Resources>>) {
        self.slots[slot] = held;
    }

    /// The slot's resources, if prepared.
    pub fn resources(&self, slot: usize) -> Option<&P::Resources> {
        self.slots[slot].as_ref().map(|s| &s.resources)
    }

    /// The layers the slot's resources offer ([`Pass::layers`]; none
    /// without resources).
    pub fn layers(&self, slot: usize) -> Vec<(Layer, &Image)> {
        self.resources(slot)
            .map_or_else(Vec::new, |r| self.pass.layers(r))
    }

    /// Drops the slot's resources (after a frame that was recorded but not
    /// submitted: their tracked states describe commands that never ran).
    pub fn forget(&mut self, slot: usize) {
        self.slots[slot] = None;
    }
}

/// A render-target image of the G-buffer or a lighting layer, as
/// described before it exists (the memory estimates take the same).
pub(crate) fn storage_desc(
    format: vk::Format,
    extent: (u32, u32),
    extra_usage: vk::ImageUsageFlags,
) -> ImageDesc {
    let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | extra_usage;
    ImageDesc::new_2d(format, extent.0, extent.1, usage)
}

/// A linear-radiance layer (RGBA32F storage image) of the frame's size.
pub(crate) fn radiance_desc(extent: (u32, u32)) -> ImageDesc {
    storage_desc(
        vk::Format::R32G32B32A32_SFLOAT,
        extent,
        vk::ImageUsageFlags::empty(),
    )
}

/// A linear-radiance layer ([`radiance_desc`]).
pub(crate) fn radiance_image(
    device: &Arc<Device>,
    name: &str,
    extent: (u32, u32),
) -> crate::Result<Image> {
    Image::new(device, name, radiance_desc(extent))
}

/// A pass's profiling and resource name on G-buffer layer `layer`:
/// `base` on layer 0, `base_layer1` on layer 1.
pub(crate) fn layer_name(base: &str, layer: u32) -> String {
    match layer {
        0 => base.to_string(),
        l => format!("{base}_layer{l}"),
    }
}
