//! Device memory by part: what one frame slot's resources take, estimated
//! before they exist ([`crate::renderer::frame_memory`]) and measured from
//! the allocator after ([`FrameMemory::measured`]).

use serde::Serialize;

use crate::vk::Device;

/// Bytes of device memory of one frame slot, by part.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct FrameMemory {
    /// The G-buffers (every layer's images and depth).
    pub gbuffer: u64,
    /// Direct and bounded VPL lighting, `S0` and what it sends.
    pub lighting: u64,
    /// SSBC's pyramids (geometry, areas, radiance) and evaluation points.
    pub ssbc_pyramids: u64,
    /// SSBC's work lists (pending pixels, requests, fallback, statistics).
    pub ssbc_lists: u64,
    /// SSBC's per-step images (residuals, what they send, texels read) and
    /// its final image.
    pub ssbc_images: u64,
    /// The ISM atlas, the VPLs, and the ISM points with their ray-cast
    /// layers.
    pub ism: u64,
    /// The punctual lights' cube shadow maps.
    pub shadow_maps: u64,
    /// The temporal history of resident frames.
    pub history: u64,
    /// Host-visible copies of the read-back layers (immediate frames).
    pub readback: u64,
}

/// The parts, named as in the timings JSON, in the order of the fields.
const PARTS: [&str; 9] = [
    "gbuffer",
    "lighting",
    "ssbc_pyramids",
    "ssbc_lists",
    "ssbc_images",
    "ism",
    "shadow_maps",
    "history",
    "readback",
];

/// Where an allocation named `name` (its debug name) belongs: the prefixes
/// the passes name their per-slot resources with. None: the scene's or the
/// device's own (meshes, textures, acceleration structures, staging).
fn part_of(name: &str) -> Option<usize> {
    let starts = |p: &str| name.starts_with(p);
    Some(if starts("gbuffer") {
        0
    } else if starts("lighting") || starts("ssbc.s0") {
        1
    } else if starts("ssbc.pyramid") || starts("ssbc.eval_points") {
        2
    } else if [
        "ssbc.pending",
        "ssbc.requests",
        "ssbc.top_points",
        "ssbc.stats",
    ]
    .iter()
    .any(|p| starts(p))
    {
        3
    } else if starts("ssbc.") {
        4
    } else if starts("ism.") || starts("vpls") {
        5
    } else if starts("shadow_maps") {
        6
    } else if starts("temporal.") {
        7
    } else if starts("readback.") {
        8
    } else {
        return None;
    })
}

impl FrameMemory {
    /// Bytes of all parts.
    pub fn total(&self) -> u64 {
        self.parts().iter().map(|(_, b)| b).sum()
    }

    /// Of [`FrameMemory::total`], what a frame slot carries from one of
    /// its frames to a later one: the temporal history and, with it, the
    /// G-buffer the next frame reprojects against; the shadow maps and
    /// ISMs, kept while the lights and surfaces stay.
    pub fn persistent(&self) -> u64 {
        let gbuffer = if self.history > 0 { self.gbuffer } else { 0 };
        self.history + gbuffer + self.ism + self.shadow_maps
    }

    /// Of [`FrameMemory::total`], what each frame rewrites before it reads
    /// it: lighting, SSBC's pyramids, lists and images, read-back (and the
    /// G-buffer without history).
    pub fn transient(&self) -> u64 {
        self.total() - self.persistent()
    }

    /// Each part's name (as in the timings JSON) and bytes.
    pub fn parts(&self) -> [(&'static str, u64); 9] {
        let bytes = [
            self.gbuffer,
            self.lighting,
            self.ssbc_pyramids,
            self.ssbc_lists,
            self.ssbc_images,
            self.ism,
            self.shadow_maps,
            self.history,
            self.readback,
        ];
        std::array::from_fn(|i| (PARTS[i], bytes[i]))
    }

    fn part_mut(&mut self, i: usize) -> &mut u64 {
        match i {
            0 => &mut self.gbuffer,
            1 => &mut self.lighting,
            2 => &mut self.ssbc_pyramids,
            3 => &mut self.ssbc_lists,
            4 => &mut self.ssbc_images,
            5 => &mut self.ism,
            6 => &mut self.shadow_maps,
            7 => &mut self.history,
            _ => &mut self.readback,
        }
    }

    /// What `device`'s allocator holds now for frame slots, by part (its
    /// live allocations, grouped by their names): every slot that holds
    /// resources together, so one slot's after a renderer's first frame.
    pub fn measured(device: &Device) -> Self {
        let mut m = Self::default();
        for a in device.allocation_report() {
            if let Some(i) = part_of(&a.name) {
                *m.part_mut(i) += a.size;
            }
        }
        m
    }

    /// A one-line summary: the total and each part that takes anything, in
    /// MiB, and bytes per pixel of a `pixels` image.
    pub fn summary(&self, pixels: u64) -> String {
        let mib = |b: u64| b as f64 / (1u64 << 20) as f64;
        let parts: Vec<String> = self
            .parts()
            .iter()
            .filter(|(_, b)| *b > 0)
            .map(|(n, b)| format!("{n} {:.1}", mib(*b)))
            .collect();
        format!(
            "{:.1} MiB ({:.0} bytes per pixel): {}",
            mib(self.total()),
            self.total() as f64 / pixels.max(1) as f64,
            parts.join(", ")
        )
    }
}

/// A frame slot's device memory as estimated before it was allocated and
/// as measured from the allocator (`slots` frame slots hold resources).
#[derive(Clone, Copy, Debug, Serialize)]
pub struct MemoryReport {
    /// One slot's, from the settings ([`crate::renderer::frame_memory`]).
    pub estimated: FrameMemory,
    /// Every slot's that holds resources, from the allocator.
    pub measured: FrameMemory,
    /// Frame slots that hold resources.
    pub slots: u32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_per_slot_name_has_a_part_and_the_scene_none() {
        for (name, part) in [
            ("gbuffer_layer1.position", "gbuffer"),
            ("lighting.interleaved", "lighting"),
            ("ssbc.s0", "lighting"),
            ("ssbc.eval_points.claims", "ssbc_pyramids"),
            ("ssbc.pending_b", "ssbc_lists"),
            ("ssbc.residual_sources_2", "ssbc_images"),
            ("ism.atlas", "ism"),
            ("vpls.subsets", "ism"),
            ("shadow_maps.depth", "shadow_maps"),
            ("temporal.history", "history"),
            ("readback.ssbc.s0", "readback"),
        ] {
            assert_eq!(part_of(name).map(|i| PARTS[i]), Some(part), "{name}");
        }
        assert_eq!(part_of("scene.texture_staging"), None);
        let mut m = FrameMemory::default();
        *m.part_mut(3) = 5;
        assert_eq!(m.ssbc_lists, 5);
        assert_eq!(m.total(), 5);
    }
}
