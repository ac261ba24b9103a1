//! A frame slot's transient memory: what the interleaved gather hands its
//! filter, SSBC's pyramids and the temporal history's reprojection never
//! live at once, so they share one block of device memory
//! ([`AliasedMemory`]). The gather's phase holds, in frames that are not a
//! resident scene's, the shadow maps and the ISM atlas, then the G-buffer's
//! depth buffer, the gather's intermediate images and crease list, and in
//! scenes without normal maps the G-buffer's emission image (every G-buffer
//! layer's, one after another); SSBC's phase its pyramids, evaluation
//! points and claims; the history's its reprojected image. The frame starts
//! each phase with [`Recorder::hand_over`](crate::vk::Recorder::hand_over).

use std::sync::Arc;

use crate::error::Result;
use crate::settings::RenderSettings;
use crate::vk::{AliasPlan, AliasRegion, AliasedMemory, Device, Planned, Tenant};

/// The gather's phase: its intermediates, until the filter and the crease
/// kernel have read them.
pub const GATHER_PHASE: u32 = 0;
/// SSBC's phase: its pyramids and evaluation points, every step.
pub const SSBC_PHASE: u32 = 1;
/// The temporal history's phase: the previous frame's history
/// reprojected, which its blend reads.
pub const TEMPORAL_PHASE: u32 = 2;

/// Who places resources in a slot's transient memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tenancy {
    /// The G-buffer's depth buffer on layer `0` or `1` (only its draw
    /// uses it), and its emission image where that is transient.
    GBuffer(u32),
    /// The bounded lighting of G-buffer layer `0` or `1`.
    Gather(u32),
    /// The direct light's intermediates on G-buffer layer `0` or `1`:
    /// which lights reach each pixel, until the filter has read it.
    Direct(u32),
    /// SSBC.
    Ssbc,
    /// The temporal history.
    Temporal,
    /// The shadow maps' depth images (frames that do not keep them).
    ShadowMaps,
    /// The ISM atlas (frames that do not keep it).
    Ism,
}

/// What a slot's transient memory depends on besides the settings.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlotTraits {
    /// The slot's frames keep temporal history (resident frames).
    pub history: bool,
    /// The scene has glossy materials (SSBC's evaluation points keep
    /// glossy rests).
    pub glossy: bool,
    /// The slot's frames are a resident scene's: the shadow maps and ISMs
    /// may be kept for its next frame (`reuse_unchanged`).
    pub resident: bool,
    /// Punctual lights (cube shadow maps).
    pub lights: usize,
}

impl SlotTraits {
    /// Those of `scene`'s frames, keeping `history` or not, `resident`
    /// or not.
    pub fn of(scene: &crate::scene::Scene, history: bool, resident: bool) -> Self {
        Self {
            history,
            glossy: scene.has_glossy_materials(),
            resident,
            lights: scene.lights.len(),
        }
    }
}

/// Whether S0 is summed in the direct light's image, in place: nothing
/// reads the direct light after the bounded lighting but the history and
/// the output layers.
pub fn s0_in_direct(settings: &RenderSettings, traits: SlotTraits) -> bool {
    !traits.history && !settings.every_output()
}

/// Whether the shadow maps and the ISM atlas are transient: written and
/// read before SSBC in every frame that is not a resident scene's (an
/// immediate frame never keeps them for the next; `reuse_unchanged`), and
/// not read back (`debug_readback` reads the atlas after the frame).
pub fn visibility_is_transient(settings: &RenderSettings, traits: SlotTraits) -> bool {
    !traits.resident && !settings.debug_readback
}

/// Whether the G-buffer's emission image is transient: read after the
/// gathers only by the debug read-back (SSBC reads normal-mapped scenes'
/// geometric normals from the direct light's sources, which carry them on).
pub fn emission_is_transient(settings: &RenderSettings) -> bool {
    !settings.every_output()
}

/// The plan of a slot's transient memory for `settings` and `traits`: per
/// phase, its tenants' resources in the order they make them.
pub fn plan(settings: &RenderSettings, traits: SlotTraits) -> AliasPlan {
    let extent = (settings.width, settings.height);
    let ssbc = &settings.ssbc;
    let layer1 = ssbc.second_layer().filter(|_| ssbc.steps > 0);
    let layers = std::iter::once(extent).chain(layer1.map(|r| r.extent(extent)));
    let emission_is_transient = emission_is_transient(settings);
    // The shadow maps and the ISM atlas, as their passes make them.
    let visibility = visibility_is_transient(settings, traits);
    let shadow_views = (6 * traits.lights as u32).max(1);
    let shadow_maps = super::shadow_maps::depth_desc(settings.shadow_map_size, shadow_views);
    let atlas = super::ism::atlas_desc(
        settings.vpl.count as u32,
        settings.ism_tile,
        settings.ism_back_face_maps(),
    );
    let visibility = [shadow_maps, atlas].map(|desc| match visibility {
        true => vec![Planned::Image(desc)],
        false => Vec::new(),
    });
    // Two tenants, then three a layer, in `SlotTransient::region`'s order.
    let gather: Vec<Tenant> = visibility
        .into_iter()
        .chain(layers
        .flat_map(|e| {
            [
                super::gbuffer::GBuffer::transient_resources(e, emission_is_transient),
                super::indirect_bounded::transient_resources(e, settings.gather),
                super::direct_lighting::transient_resources(e),
            ]
        }))
        .collect();
    // Without a step SSBC holds a 1x1 frame's resources: nothing to share.
    let ssbc = match ssbc.steps {
        0 => Vec::new(),
        steps => super::ssbc::transient_resources(
            extent,
            (steps, ssbc.second_layer()),
            super::ssbc::SsbcPass::kept(settings, traits.glossy),
        ),
    };
    // (A frame without history leaves it unused: it is never the largest.)
    let temporal = match traits.history {
        true => super::temporal::transient_resources(extent),
        false => Vec::new(),
    };
    AliasPlan {
        phases: vec![gather, vec![ssbc], vec![temporal]],
    }
}

/// The prefix of the part of frame memory a plan's memory counts as: that
/// of its largest phase, `phase` (`AliasPlan::largest`; `memory::part_of`).
pub fn part_name(phase: usize) -> &'static str {
    match phase as u32 {
        GATHER_PHASE => "lighting",
        SSBC_PHASE => "ssbc.pyramid",
        _ => "temporal",
    }
}

/// A frame slot's transient memory, as made for its plan.
pub struct SlotTransient {
    /// What it was made for.
    pub plan: AliasPlan,
    /// The memory (None: the plan shares nothing; each pass allocates its
    /// own).
    pub memory: Option<Arc<AliasedMemory>>,
    regions: Vec<Vec<AliasRegion>>,
}

impl SlotTransient {
    /// Memory for `plan` in frame slot `slot`, if it shares anything.
    pub fn new(device: &Arc<Device>, slot: usize, plan: AliasPlan) -> Result<Self> {
        if !plan.shares() {
            return Ok(Self {
                plan,
                memory: None,
                regions: Vec::new(),
            });
        }
        // Named for the largest part it holds (frame memory by part).
        let (largest, _) = plan.largest(Some(device));
        let name = format!("{}.transient slot {slot}", part_name(largest));
        let (memory, regions) = AliasedMemory::new(device, &name, &plan)?;
        Ok(Self {
            plan,
            memory: Some(memory),
            regions,
        })
    }

    /// Where `tenant` places its resources (None: in memory of their own).
    pub fn region(&self, tenant: Tenancy) -> Option<AliasRegion> {
        let (phase, index) = match tenant {
            Tenancy::ShadowMaps => (GATHER_PHASE, 0),
            Tenancy::Ism => (GATHER_PHASE, 1),
            Tenancy::GBuffer(layer) => (GATHER_PHASE, 2 + 3 * layer as usize),
            Tenancy::Gather(layer) => (GATHER_PHASE, 3 + 3 * layer as usize),
            Tenancy::Direct(layer) => (GATHER_PHASE, 4 + 3 * layer as usize),
            Tenancy::Ssbc => (SSBC_PHASE, 0),
            Tenancy::Temporal => (TEMPORAL_PHASE, 0),
        };
        let planned = self.plan.phases.get(phase as usize)?.get(index)?;
        let region = self.regions.get(phase as usize)?.get(index)?;
        // (A tenant that places nothing makes what it makes on its own.)
        (!planned.is_empty()).then(|| region.clone())
    }
}
