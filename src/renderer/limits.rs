//! What the device and the settings allow, checked before a frame.

use crate::error::{Error, Result};
use crate::memory::FrameMemory;
use crate::passes::gbuffer::GBuffer;
use crate::passes::transient::{self, SlotTraits};
use crate::passes::{direct_lighting, indirect_bounded, radiance_desc};
use crate::settings::{Bound, RenderSettings, SsbcSettings};
use crate::vk::Device;

/// Largest number of ISM points uploaded (VPLs x points per VPL).
const MAX_ISM_POINTS: u64 = 1 << 26;

/// Validates an image size against the device.
fn check_size(device: &Device, width: u32, height: u32) -> Result<()> {
    let max = device.limits().max_image_dimension2_d;
    if width == 0 || height == 0 {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} is empty"
        )));
    }
    if width > max || height > max {
        return Err(Error::InvalidParameter(format!(
            "image size {width}x{height} exceeds the device limit of {max} pixels per side"
        )));
    }
    Ok(())
}

/// What a frame holds besides its passes' resources.
#[derive(Clone, Copy, Debug)]
pub(super) struct FrameUse {
    /// A temporal history (resident frames of ssbc's own with
    /// `history.enabled`).
    pub history: bool,
    /// Read-back buffers ([`super::Renderer::render`]'s frames).
    pub readback: bool,
    /// Glossy receivers (a scene with glossy materials): SSBC's
    /// evaluation points keep their glossy rests.
    pub glossy: bool,
    /// Frames of a resident scene, whose view-independent passes (shadow
    /// maps, ISMs) keep their output for the slot's next frame. An
    /// immediate frame's never match it: their images are transient.
    pub resident: bool,
}

impl FrameUse {
    /// A frame sent on by `S`, with or without a temporal history.
    pub fn of<S: super::sink::FrameSink>(
        history: bool,
        resident: bool,
        scene: &crate::scene::Scene,
    ) -> Self {
        Self {
            history,
            resident,
            readback: S::READS_BACK,
            glossy: scene.has_glossy_materials(),
        }
    }

    /// With `scene`'s materials.
    pub fn with_scene(self, scene: &crate::scene::Scene) -> Self {
        Self {
            glossy: scene.has_glossy_materials(),
            ..self
        }
    }

    /// What the slot's transient memory depends on, with `lights`
    /// punctual lights.
    fn traits(self, lights: usize) -> SlotTraits {
        SlotTraits {
            history: self.history,
            glossy: self.glossy,
            resident: self.resident,
            lights,
        }
    }

    /// Both: what [`super::frame_memory`] reports.
    pub const ALL: Self = Self {
        history: true,
        readback: true,
        glossy: true,
        resident: true,
    };
}

/// The settings a still view's history frames take where visibility
/// cannot be exact and the host asked for converging ISMs
/// (`HistorySettings::converging_isms`), if its frames keep history.
pub(super) fn still_view_isms(settings: &RenderSettings, uses: FrameUse) -> Option<RenderSettings> {
    let converging = uses.history
        && settings.history.enabled
        && settings.history.converging_isms
        && settings.visibility == crate::settings::Visibility::Auto;
    converging.then(|| {
        let mut s = settings.clone();
        s.resolve_auto_for_convergence(false, true);
        s
    })
}

/// [`frame_memory`] of the larger of the host's frames and its still
/// view's ([`still_view_isms`]).
pub(super) fn slot_memory(
    device: Option<&Device>,
    settings: &RenderSettings,
    lights: usize,
    uses: FrameUse,
) -> FrameMemory {
    let host = frame_memory(device, settings, lights, uses);
    match still_view_isms(settings, uses) {
        Some(still) => {
            let still = frame_memory(device, &still, lights, uses);
            if still.total() > host.total() {
                still
            } else {
                host
            }
        }
        None => host,
    }
}

/// Device memory one frame slot takes at `settings` with `lights` punctual
/// lights, by part, as the passes allocate it (without a device: the bytes
/// asked for; with one, SSBC's resources as its memory requirements say),
/// with the history and read-back `uses` says. Two frames in flight take
/// two slots.
pub(super) fn frame_memory(
    device: Option<&Device>,
    settings: &RenderSettings,
    lights: usize,
    uses: FrameUse,
) -> FrameMemory {
    let extent = (settings.width, settings.height);
    let pixels = extent.0 as u64 * extent.1 as u64;
    // What never lives at once shares memory (`passes::transient`).
    let traits = uses.traits(lights);
    let plan = transient::plan(settings, traits);
    let shared = plan.shares();
    let (gbuffer, mut lighting) = layer_memory(device, settings, uses, shared);
    let outputs = settings.every_output();
    if outputs {
        // The layers made on request: the bounded and the whole indirect light.
        lighting += 2 * crate::passes::indirect_light::desc(extent).bytes(device);
    }
    let ssbc = crate::passes::ssbc::frame_memory(
        device,
        crate::passes::ssbc::SsbcPass::allocated_extent(extent, settings.ssbc.steps),
        (settings.ssbc.steps, settings.ssbc.second_layer()),
        crate::passes::ssbc::SsbcPass::kept(settings, uses.glossy),
    );
    let vpls = settings.vpl.count as u64;
    // The atlas (whole rows of tiles), the VPLs, their interleaving subsets
    // and ray-cast layers (a LayerBlock per block); the point
    // blocks they share, in object space with their normals and discs and
    // placed in the world (a position and normal, a disc).
    let atlas_desc = crate::passes::ism::atlas_desc(
        settings.vpl.count as u32,
        settings.ism_tile,
        settings.ism_back_face_maps(),
    );
    let atlas = atlas_desc.bytes(device);
    let blocks = vpls.min(crate::scene_cache::MAX_POINT_BLOCKS as u64);
    let subsets = 4 * (settings.pattern_side() as u64).pow(2) + 4;
    let gpu_vpl = std::mem::size_of::<crate::gpu_types::GpuVpl>() as u64;
    let layer = std::mem::size_of::<crate::cpu::ism_rays::LayerBlock>() as u64
        * (crate::cpu::ism_rays::BASE_GRID as u64).pow(2);
    // (The atlas and the shadow maps of a frame whose passes cannot keep
    // them lie in the slot's transient memory.)
    let visibility_shared = shared && transient::visibility_is_transient(settings, traits);
    let ism = if visibility_shared { 0 } else { atlas }
        + vpls * (gpu_vpl + layer)
        + subsets
        + blocks * settings.points_per_vpl as u64 * (16 + 4 + 4 + 16 + 4);
    // A cube (six views) per light.
    let shadow_maps = if lights == 0 || visibility_shared {
        0
    } else {
        let views = 6 * lights as u32;
        crate::passes::shadow_maps::depth_desc(settings.shadow_map_size, views).bytes(device)
    };
    // Resident frames' temporal history.
    let history = if uses.history && settings.history.enabled {
        crate::passes::temporal::slot_bytes(device, extent, shared)
    } else {
        0
    };
    // One staging buffer the read-back images go through in bands: as
    // large as the largest of them (an RGBA32F image of the frame's size;
    // with debug read-back the ISM atlas too), at most STAGING_BYTES.
    let readback = if uses.readback {
        let debug = settings.debug_readback;
        let atlas = if debug { atlas_desc.bytes(None) } else { 0 };
        super::readback::staging_bytes((pixels * 16).max(atlas))
    } else {
        0
    };
    let (mut ssbc_pyramids, ssbc_images) = (ssbc.pyramids, ssbc.images);
    let mut ssbc_lists = ssbc.work_lists + ssbc.stats;
    let mut history = history;
    if shared {
        // SSBC's pyramids and work lists lie in it (with a step), and it
        // counts as its largest phase's part.
        if settings.ssbc.steps > 0 {
            ssbc_pyramids = 0;
            ssbc_lists = ssbc.stats;
        }
        let (largest, bytes) = plan.largest(device);
        *match transient::part_name(largest) {
            "lighting" => &mut lighting,
            "temporal" => &mut history,
            _ => &mut ssbc_pyramids,
        } += bytes;
    }
    FrameMemory {
        gbuffer,
        lighting,
        ssbc_pyramids,
        ssbc_lists,
        ssbc_images,
        ism,
        shadow_maps,
        history,
        readback,
    }
}

/// The G-buffers' and the lighting images' bytes of every G-buffer layer
/// (the visible surfaces and, with a second SSBC layer, the hidden ones at
/// its resolution), less what lies in `shared` transient memory.
fn layer_memory(
    device: Option<&Device>,
    settings: &RenderSettings,
    uses: FrameUse,
    shared: bool,
) -> (u64, u64) {
    let extent = (settings.width, settings.height);
    let layer1 = settings
        .ssbc
        .second_layer()
        .filter(|_| settings.ssbc.steps > 0);
    let layers = std::iter::once(extent).chain(layer1.map(|r| r.extent(extent)));
    let (mut gbuffer, mut lighting) = (0, 0);
    for layer in layers {
        // (Where memory is shared the depth buffer is transient, and the
        // emission image may be.)
        let emission = shared && transient::emission_is_transient(settings);
        let [position, normal, albedo, emission_desc, depth] = GBuffer::descs(layer);
        let own = [(position, true), (normal, true), (albedo, true)]
            .into_iter()
            .chain([(emission_desc, !emission), (depth, !shared)]);
        gbuffer += own
            .filter(|(_, kept)| *kept)
            .map(|(d, _)| d.bytes(device))
            .sum::<u64>();
        // Direct light, what it sends and (unless transient) the lights it
        // comes from; the bounded lighting (S0 in the
        // direct light's image, where nothing reads that later).
        let s0_in_direct = transient::s0_in_direct(settings, uses.traits(0));
        lighting += 2 * radiance_desc(layer).bytes(device)
            + if shared {
                0
            } else {
                direct_lighting::lights_desc(layer).bytes(device)
            }
            + indirect_bounded::memory_bytes(device, layer, settings.gather, shared)
            - if s0_in_direct {
                radiance_desc(layer).bytes(device)
            } else {
                0
            };
    }
    (gbuffer, lighting)
}

/// Fails, before anything is allocated, if one frame slot's resources
/// cannot fit in the device's largest device-local heap.
fn check_memory(
    device: &Device,
    settings: &RenderSettings,
    lights: usize,
    uses: FrameUse,
) -> Result<()> {
    let needed = frame_memory(Some(device), settings, lights, uses).total();
    let heap = device.device_local_heap();
    if heap == 0 || needed <= heap {
        return Ok(());
    }
    Err(Error::InvalidParameter(format!(
        "{}x{} needs about {} MiB of device memory per frame; this device's largest heap has \
         {} MiB: render smaller, with fewer SSBC steps or VPLs{}",
        settings.width,
        settings.height,
        needed >> 20,
        heap >> 20,
        SsbcSettings::lighter_second_layer(settings.ssbc.second_layer())
    )))
}

/// Checks `settings` against what `device` can do.
pub(super) fn check_settings(
    device: &Device,
    settings: &RenderSettings,
    lights: usize,
    uses: FrameUse,
) -> Result<()> {
    check_size(device, settings.width, settings.height)?;
    let max = device.limits().max_image_dimension2_d;
    let sm = settings.shadow_map_size;
    if sm < 16 || sm > max {
        return Err(Error::InvalidParameter(format!(
            "shadow_map_size {sm} outside 16..={max}"
        )));
    }
    if let Bound::Value(b) = settings.bound {
        if b.is_nan() || b <= 0.0 {
            return Err(Error::InvalidParameter(format!(
                "bound {b} must be positive (or inf)"
            )));
        }
    }
    if settings.vpl.count > 0 && settings.points_per_vpl == 0 {
        return Err(Error::InvalidParameter(
            "points_per_vpl must be at least 1".into(),
        ));
    }
    // The VPLs' blocks of ISM points (they share blocks beyond
    // MAX_POINT_BLOCKS), 16 bytes a point, lie in one storage buffer.
    let max_range = device.limits().max_storage_buffer_range as u64;
    let blocks = crate::scene_cache::point_blocks(settings.vpl.count) as u64;
    let points = blocks * settings.points_per_vpl as u64;
    if settings.vpl.count > 0 && points * 16 > max_range {
        return Err(Error::InvalidParameter(format!(
            "{blocks} blocks of {} ISM points (one per VPL, up to {}) need {} MiB; this \
             device's storage buffers hold at most {} MiB (maxStorageBufferRange): use fewer \
             points per VPL",
            settings.points_per_vpl,
            crate::scene_cache::MAX_POINT_BLOCKS,
            (points * 16) >> 20,
            max_range >> 20
        )));
    }
    if settings.ssbc.steps > 0 {
        crate::passes::ssbc::check_size(
            device,
            settings.width,
            settings.height,
            settings.ssbc.second_layer(),
        )?;
    }
    if settings.vpl.count as u64 * settings.points_per_vpl as u64 > MAX_ISM_POINTS {
        return Err(Error::InvalidParameter(format!(
            "{} VPLs x {} points per VPL exceeds {MAX_ISM_POINTS} ISM points",
            settings.vpl.count, settings.points_per_vpl
        )));
    }
    settings.validate()?;
    if settings.vpl.count > 0 {
        crate::passes::ism::check_atlas(
            device,
            settings.vpl.count as u32,
            settings.ism_tile,
            settings.ism_back_face_maps(),
        )?;
    }
    check_memory(device, settings, lights, uses)
}
