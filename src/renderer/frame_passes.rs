//! The frame's passes in the paper's order (`Passes::record`), each with
//! its resources in every frame slot.

use std::sync::Arc;

use super::readback::FrameImages;
use super::FRAME_SLOTS;
use crate::error::Result;
use crate::gpu_scene::SlotScene;
use crate::layer::Layer;
use crate::passes::direct_lighting::{DirectLight, DirectLightingPass};
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::indirect_bounded::{BoundedLighting, IndirectBoundedPass, VplVisibility};
use crate::passes::indirect_light::IndirectLightPass;
use crate::passes::ism::{Ism, IsmPass};
use crate::passes::shadow_maps::{ShadowMapPass, ShadowMaps};
use crate::passes::ssbc::{SsbcLayer, SsbcPass};
use crate::passes::temporal::{HistoryStep, TemporalPass, TemporalReads};
use crate::passes::transient::{self, SlotTransient};
use crate::passes::{Recording, SlotSetup, Stage};
use crate::settings::Visibility;
use crate::vk::{Device, Image};

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
    ) -> Result<(&GBuffer, &DirectLight, SsbcLayer<'_>)> {
        let gbuffer = self.gbuffer.run(cx, setup, (scene, front))?;
        let direct = self.direct_lighting.run(cx, setup, (gbuffer, shadows))?;
        let visibility = match scene.top_level {
            Some(tlas) if setup.settings.visibility == Visibility::Exact => {
                VplVisibility::Exact(tlas)
            }
            _ => VplVisibility::Ism,
        };
        let bounded = self
            .indirect_bounded
            .run(cx, setup, (gbuffer, direct, ism, visibility))?;
        let normal_maps = cx.view.normal_maps;
        Ok((
            gbuffer,
            direct,
            bounded.ssbc_layer(gbuffer, direct, normal_maps),
        ))
    }

    fn images(&self, slot: usize) -> Option<LayerImages<'_>> {
        Some((
            self.gbuffer.resources(slot)?,
            self.direct_lighting.resources(slot)?,
            self.indirect_bounded.resources(slot)?,
        ))
    }

    /// The layers its passes offer in the slot.
    fn layers(&self, slot: usize) -> Vec<(Layer, &Image)> {
        let mut layers = self.gbuffer.layers(slot);
        layers.extend(self.direct_lighting.layers(slot));
        layers.extend(self.indirect_bounded.layers(slot));
        layers
    }

    fn forget(&mut self, slot: usize) {
        self.gbuffer.forget(slot);
        self.direct_lighting.forget(slot);
        self.indirect_bounded.forget(slot);
    }
}

/// The technique passes, each with its resources in every frame slot.
pub(super) struct Passes {
    shadow_maps: Stage<ShadowMapPass>,
    ism: Stage<IsmPass>,
    /// Layer 0, the visible surfaces; layer 1, the deep G-buffer's second
    /// layer (`ssbc.layers` 2).
    layers: [LayerStages; 2],
    ssbc: Stage<SsbcPass>,
    /// Temporal history (resident frames).
    temporal: Stage<TemporalPass>,
    /// The bounded and the whole indirect light as layers of their own
    /// (frames that hand out every output).
    indirect_bounded_layer: Stage<IndirectLightPass>,
    indirect_light: Stage<IndirectLightPass>,
    /// Whether each slot's last frame ran `temporal` (its output is then
    /// the final image).
    temporal_ran: [bool; FRAME_SLOTS],
    /// Each slot's memory the gathers' intermediates and SSBC's pyramids
    /// share (`passes::transient`).
    transient: [Option<SlotTransient>; FRAME_SLOTS],
}

/// How a frame uses temporal history: its fold, and the slot it reads.
#[derive(Clone, Copy)]
pub(super) struct HistoryFrame {
    pub step: HistoryStep,
    pub previous_slot: Option<usize>,
}

impl Passes {
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            shadow_maps: Stage::new(ShadowMapPass::new(device)?, FRAME_SLOTS),
            ism: Stage::new(IsmPass::new(device)?, FRAME_SLOTS),
            layers: [LayerStages::new(device, 0)?, LayerStages::new(device, 1)?],
            ssbc: Stage::new(SsbcPass::new(device)?, FRAME_SLOTS),
            temporal: Stage::new(TemporalPass::new(device)?, FRAME_SLOTS),
            indirect_bounded_layer: Stage::new(
                IndirectLightPass::new(device, Layer::IndirectBounded)?,
                FRAME_SLOTS,
            ),
            indirect_light: Stage::new(
                IndirectLightPass::new(device, Layer::Indirect)?,
                FRAME_SLOTS,
            ),
            temporal_ran: [false; FRAME_SLOTS],
            transient: [const { None }; FRAME_SLOTS],
        })
    }

    /// Brings the slot's transient memory up to `setup`'s plan (its
    /// previous frame is done). New memory drops its tenants' resources,
    /// which are made anew in it.
    fn refresh_transient(&mut self, setup: &SlotSetup<'_>) -> Result<()> {
        let traits = setup.traits();
        let plan = transient::plan(setup.settings, traits);
        let slot = setup.slot;
        if self.transient[slot]
            .as_ref()
            .is_some_and(|t| t.plan == plan)
        {
            return Ok(());
        }
        self.shadow_maps.forget(slot);
        self.ism.forget(slot);
        for layer in &mut self.layers {
            layer.forget(slot);
        }
        self.ssbc.forget(slot);
        // (Its history restarts: the plan changes with the size, the
        // gather or the SSBC layers and steps.)
        self.temporal.forget(slot);
        self.temporal_ran[slot] = false;
        self.transient[slot] = None; // the old memory first
        self.transient[slot] = Some(SlotTransient::new(setup.device, slot, plan)?);
        Ok(())
    }

    /// The frame: every pass in order, each given what it reads from the
    /// passes before it (its resources are brought up to `setup` first).
    pub fn record(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        scene: SlotScene<'_>,
        history: Option<HistoryFrame>,
    ) -> Result<()> {
        self.temporal_ran[setup.slot] = false;
        self.refresh_transient(setup)?;
        // Out of `self` while the stages record (put back after).
        let slot = setup.slot;
        let transient = self.transient[slot].take();
        let with_transient = SlotSetup {
            transient: transient.as_ref(),
            ..*setup
        };
        // Shadow maps and ISMs in transient memory are not there to keep.
        let visibility = transient
            .as_ref()
            .and_then(|t| t.region(transient::Tenancy::Ism));
        if visibility.is_some() {
            cx.reuse = false;
        }
        let result = self.record_stages(cx, &with_transient, scene, history);
        self.transient[slot] = transient;
        result
    }

    /// [`Passes::record`] with the slot's transient memory in `setup`:
    /// each of its phases begins with a hand-over.
    fn record_stages(
        &mut self,
        cx: &mut Recording<'_, '_>,
        setup: &SlotSetup<'_>,
        scene: SlotScene<'_>,
        history: Option<HistoryFrame>,
    ) -> Result<()> {
        let memory = setup.transient.and_then(|t| t.memory.as_deref());
        let begin = |cx: &mut Recording<'_, '_>, phase| {
            if let Some(memory) = memory {
                cx.rec.hand_over(memory, phase);
            }
        };
        begin(cx, transient::GATHER_PHASE);
        let shadows = self.shadow_maps.run(cx, setup, scene)?;
        let ism = self
            .ism
            .run(cx, setup, (scene, setup.cache.versions.objects))?;
        let [layer0, layer1] = &mut self.layers;
        let (front, direct, visible) = layer0.run(cx, setup, (scene, None), (shadows, ism))?;
        if setup.settings.every_output() {
            let reads = (visible.s0, &direct.radiance);
            self.indirect_bounded_layer.run(cx, setup, reads)?;
        } else {
            self.indirect_bounded_layer.forget(setup.slot);
        }
        let ssbc = &setup.settings.ssbc;
        let hidden = if ssbc.layers == 2 && ssbc.steps > 0 {
            let (_, _, hidden) = layer1.run(cx, setup, (scene, Some(front)), (shadows, ism))?;
            Some(hidden)
        } else {
            // Not drawn this frame: free what an earlier frame held.
            layer1.forget(setup.slot);
            None
        };
        begin(cx, transient::SSBC_PHASE);
        self.ssbc.run(cx, setup, (visible, hidden))?;
        if let Some(history) = history {
            begin(cx, transient::TEMPORAL_PHASE);
            self.temporal(cx, setup, history)?;
        }
        self.indirect_light(cx, setup)
    }

    /// The indirect light as a layer, from the final image (the history's,
    /// if the frame ran it): only in frames that make every output.
    fn indirect_light(&mut self, cx: &mut Recording<'_, '_>, setup: &SlotSetup<'_>) -> Result<()> {
        let slot = setup.slot;
        if !setup.settings.every_output() {
            self.indirect_light.forget(slot);
            return Ok(());
        }
        let history = self.temporal_ran[slot].then_some(&self.temporal);
        let images = written!(self, history, None).images(slot);
        let images = images.expect("recorded above");
        let reads = (images.layer(Layer::Final), images.layer(Layer::Direct));
        let reads = reads
            .0
            .zip(reads.1)
            .expect("offered by S0 and the direct light");
        self.indirect_light.run(cx, setup, reads)?;
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
        let (gbuffer, direct, _) = self.layers[0].images(slot).expect("recorded above");
        let before = written!(self, None, None).images(slot);
        let before = before.expect("recorded above");
        let final_image = before.layer(Layer::Final).expect("offered by S0");
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

    /// Frame slots that hold resources (whose memory the allocator counts).
    pub fn slots_in_use(&self) -> u32 {
        (0..FRAME_SLOTS)
            .filter(|&s| self.images(s).is_some())
            .count() as u32
    }

    /// The images the slot's last recorded frame wrote.
    pub fn images(&self, slot: usize) -> Option<FrameImages<'_>> {
        let history = self.temporal_ran[slot].then_some(&self.temporal);
        written!(self, history, Some(&self.indirect_light)).images(slot)
    }

    /// Drops the slot's resources (after a frame that was not submitted).
    pub fn forget(&mut self, slot: usize) {
        self.shadow_maps.forget(slot);
        self.ism.forget(slot);
        for layer in &mut self.layers {
            layer.forget(slot);
        }
        self.ssbc.forget(slot);
        self.temporal.forget(slot);
        self.temporal_ran[slot] = false;
        self.indirect_bounded_layer.forget(slot);
        self.indirect_light.forget(slot);
        self.transient[slot] = None;
    }

    /// Frees every slot's temporal history (a frame without one).
    pub fn forget_history(&mut self) {
        for slot in 0..FRAME_SLOTS {
            self.temporal.forget(slot);
            self.temporal_ran[slot] = false;
        }
    }

    /// Device memory the temporal history's images take in every slot.
    pub fn history_bytes(&self) -> u64 {
        (0..FRAME_SLOTS)
            .filter_map(|slot| self.temporal.resources(slot))
            .map(|t| {
                let (w, h) = (t.output.desc.width, t.output.desc.height);
                let transient = t.reprojected.shared.is_some();
                crate::passes::temporal::slot_bytes(None, (w, h), transient)
            })
            .sum()
    }
}

/// [`Written`] from `passes`' fields (each borrowed alone, so that another
/// stage may record meanwhile), with the temporal and indirect-light stages
/// given.
macro_rules! written {
    ($passes:expr, $temporal:expr, $indirect_light:expr) => {
        Written {
            layers: &$passes.layers,
            bounded_layer: &$passes.indirect_bounded_layer,
            ssbc: &$passes.ssbc,
            ism: &$passes.ism,
            temporal: $temporal,
            indirect_light: $indirect_light,
        }
    };
}
use written;

/// The stages a slot's images come from, borrowed apart from a stage that
/// records (None: not part of the images asked for).
struct Written<'p> {
    layers: &'p [LayerStages; 2],
    bounded_layer: &'p Stage<IndirectLightPass>,
    ssbc: &'p Stage<SsbcPass>,
    ism: &'p Stage<IsmPass>,
    temporal: Option<&'p Stage<TemporalPass>>,
    indirect_light: Option<&'p Stage<IndirectLightPass>>,
}

impl<'p> Written<'p> {
    /// What the slot's passes wrote, each pass's layers in the frame's order.
    fn images(&self, slot: usize) -> Option<FrameImages<'p>> {
        let frame = self.ssbc.resources(slot)?;
        let [layer0, layer1] = self.layers;
        layer0.images(slot)?;
        let mut layers = layer0.layers(slot);
        layers.extend(self.bounded_layer.layers(slot));
        // Stale resources of an earlier two-layer frame are not this frame's.
        if frame.layer1().is_some() && layer1.images(slot).is_some() {
            layers.extend(layer1.layers(slot));
        }
        layers.extend(self.ssbc.layers(slot));
        for stage in [
            self.temporal.map(|t| t.layers(slot)),
            self.indirect_light.map(|i| i.layers(slot)),
        ] {
            layers.extend(stage.unwrap_or_default());
        }
        Some(FrameImages {
            layers,
            ssbc: frame,
            ism: self.ism.resources(slot)?,
        })
    }
}
