//! The scene as ray queries see it, for exact VPL visibility: a bottom-level
//! acceleration structure per mesh (built by the first frame after an
//! upload, as the textures are copied) and, per frame slot, a top level of
//! the visible objects' instances (rebuilt when the objects change).
//!
//! Alpha-masked materials would need an alpha test in every ray query;
//! scenes that have them keep ISM visibility (`RayScene::new` says why).

use std::sync::Arc;

use ash::vk;
use bytemuck::Zeroable as _;
use glam::Mat4;

use crate::error::Result;
use crate::scene::{AlphaMode, Scene};
use crate::vk::{Access, AccelerationStructure, Buffer, Device, Recorder, TriangleRange};

/// `VkAccelerationStructureInstanceKHR`, as the GPU reads it.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Instance {
    /// Object to world, the top three rows of the matrix, row by row.
    transform: [f32; 12],
    /// Custom index (low 24 bits) and mask (high 8).
    index_and_mask: u32,
    /// Hit group offset (low 24 bits) and flags (high 8).
    offset_and_flags: u32,
    /// The bottom level's device address.
    structure: u64,
}

/// One frame slot's top level.
struct SlotTopLevel {
    structure: AccelerationStructure,
    /// The instances it was built from (host-written).
    _instances: Buffer,
    /// Its build's scratch (kept until the slot's next build: a host's
    /// command buffer gives ssbc no submission to wait on).
    _scratch: Buffer,
    /// The objects version it holds.
    version: u64,
}

/// Acceleration structures of an uploaded scene.
pub struct RayScene {
    device: Arc<Device>,
    /// Per mesh, its bottom level (None: no triangles, or not built yet).
    bottom: Vec<Option<AccelerationStructure>>,
    built: bool,
    /// Per frame slot, its top level.
    top: Vec<Option<SlotTopLevel>>,
}

/// Whether exact visibility is possible for `scene` on `device`: ray
/// queries, and no alpha-masked material (a ray query would need the alpha
/// test).
pub fn exact_visibility_possible(device: &Device, scene: &Scene) -> bool {
    device.ray_queries().is_some() && scene.materials.iter().all(|m| m.alpha == AlphaMode::Opaque)
}

impl RayScene {
    /// The structures for `scene` on `device`, or None where exact
    /// visibility is not possible ([`exact_visibility_possible`]; logged).
    pub fn new(device: &Arc<Device>, scene: &Scene, slots: usize) -> Option<Self> {
        device.ray_queries()?;
        if !exact_visibility_possible(device, scene) {
            log::info!(
                "exact visibility unavailable for '{}': alpha-masked materials (ISMs are used)",
                scene.name
            );
            return None;
        }
        Some(Self {
            device: device.clone(),
            bottom: Vec::new(),
            built: false,
            top: (0..slots).map(|_| None).collect(),
        })
    }

    /// Buffer usage the scene's vertices and indices need as build inputs
    /// (and as storage: the traced ISM reads a hit triangle's corners).
    pub const INPUT_USAGE: vk::BufferUsageFlags = vk::BufferUsageFlags::from_raw(
        vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR.as_raw()
            | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS.as_raw()
            | vk::BufferUsageFlags::STORAGE_BUFFER.as_raw(),
    );

    /// Records the bottom levels' builds (one per mesh: its opaque
    /// triangles), once after the upload; their
    /// scratch buffers go to `scratch` (freed once the recording's
    /// submission finishes).
    pub fn record_bottom_levels(
        &mut self,
        rec: &mut Recorder<'_>,
        (vertices, indices): (&Buffer, &Buffer),
        meshes: &[TriangleRange],
        scratch: &mut Vec<Buffer>,
    ) -> Result<()> {
        if self.built {
            return Ok(());
        }
        let stride = std::mem::size_of::<crate::scene::Vertex>() as u64;
        self.bottom.clear();
        for (i, &range) in meshes.iter().enumerate() {
            if range.triangles == 0 {
                self.bottom.push(None);
                continue;
            }
            let name = format!("scene.mesh{i}.blas");
            let (blas, s) = AccelerationStructure::bottom_level(
                rec,
                &name,
                (vertices, stride),
                indices,
                range,
            )?;
            self.bottom.push(Some(blas));
            scratch.push(s);
        }
        self.built = true;
        Ok(())
    }

    /// Records frame slot `slot`'s top level over `scene`'s visible objects
    /// unless it holds `version` of them (the slot's previous frame is done).
    pub fn record_top_level(
        &mut self,
        rec: &mut Recorder<'_>,
        slot: usize,
        scene: &Scene,
        version: u64,
    ) -> Result<()> {
        if self.top[slot].as_ref().is_some_and(|t| t.version == version) {
            return Ok(());
        }
        let instances: Vec<Instance> = scene
            .objects()
            .iter()
            .enumerate()
            .filter(|(_, o)| o.visible)
            .filter_map(|(i, o)| {
                let blas = self.bottom.get(o.mesh)?.as_ref()?;
                Some(Instance {
                    transform: rows(o.transform),
                    index_and_mask: (i as u32 & 0xFF_FFFF) | 0xFF << 24,
                    offset_and_flags: (vk::GeometryInstanceFlagsKHR::TRIANGLE_FACING_CULL_DISABLE
                        | vk::GeometryInstanceFlagsKHR::FORCE_OPAQUE)
                        .as_raw()
                        << 24,
                    structure: blas.address,
                })
            })
            .collect();
        for blas in self.bottom.iter().flatten() {
            rec.use_buffer(&blas.buffer, Access::AccelerationStructureBuildRead);
        }
        let none = [Instance::zeroed()];
        let buffer = Buffer::with_data(
            &self.device,
            &format!("frame slot {slot} scene.instances"),
            if instances.is_empty() {
                &none[..]
            } else {
                &instances
            },
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_BUILD_INPUT_READ_ONLY_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
        )?;
        let name = format!("frame slot {slot} scene.tlas");
        let (structure, scratch) =
            AccelerationStructure::top_level(rec, &name, &buffer, instances.len() as u32)?;
        self.top[slot] = Some(SlotTopLevel {
            structure,
            _instances: buffer,
            _scratch: scratch,
            version,
        });
        Ok(())
    }

    /// Whether the bottom levels have been recorded.
    pub fn is_built(&self) -> bool {
        self.built
    }

    /// Frame slot `slot`'s top level, once recorded.
    pub fn top_level(&self, slot: usize) -> Option<&AccelerationStructure> {
        self.top[slot].as_ref().map(|t| &t.structure)
    }
}

/// The top three rows of `m`, row by row (VkTransformMatrixKHR).
fn rows(m: Mat4) -> [f32; 12] {
    let r = m.transpose().to_cols_array();
    [
        r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], r[10], r[11],
    ]
}


