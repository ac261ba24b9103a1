//! Acceleration structures (VK_KHR_acceleration_structure) for ray queries:
//! a bottom level per mesh (its triangles, in its object space) and a top
//! level of the objects' instances. Builds are recorded like any other
//! command; the structure's buffer carries the tracked access, so barriers
//! between a build and the shaders that query it follow from
//! [`Access::AccelerationStructureBuild`] and [`Access::ComputeRayQuery`].

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::barrier::Access;
use super::buffer::Buffer;
use super::commands::Recorder;
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// An acceleration structure and the buffer that holds it.
pub struct AccelerationStructure {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::AccelerationStructureKHR,
    /// Its storage: barriers are tracked on it.
    pub buffer: Buffer,
    /// Its device address (what instances name a bottom level by).
    pub address: vk::DeviceAddress,
}

/// A range of a mesh's triangles in the scene's vertex and index buffers.
#[derive(Clone, Copy, Debug)]
pub struct TriangleRange {
    /// Its first index.
    pub first_index: u32,
    /// Its triangle count.
    pub triangles: u32,
    /// Its first vertex (added to its indices).
    pub vertex_offset: u32,
    /// Its highest vertex index, after the offset.
    pub max_vertex: u32,
}

/// The geometry of a build: what it reads and how it is laid out.
enum Geometry<'a> {
    Triangles {
        vertices: &'a Buffer,
        stride: u64,
        indices: &'a Buffer,
        range: TriangleRange,
    },
    Instances {
        buffer: &'a Buffer,
        count: u32,
    },
}

impl Geometry<'_> {
    /// The structure's type, its geometry for a build and its primitive
    /// count.
    fn describe(
        &self,
    ) -> (
        vk::AccelerationStructureTypeKHR,
        vk::AccelerationStructureGeometryKHR<'static>,
        u32,
    ) {
        match self {
        Geometry::Triangles {
            vertices,
            stride,
            indices,
            range,
        } => {
            let triangles = vk::AccelerationStructureGeometryTrianglesDataKHR::default()
                .vertex_format(vk::Format::R32G32B32_SFLOAT)
                .vertex_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: vertices.device_address()
                        + range.vertex_offset as u64 * stride,
                })
                .vertex_stride(*stride)
                .max_vertex(range.max_vertex.saturating_sub(range.vertex_offset))
                .index_type(vk::IndexType::UINT32)
                .index_data(vk::DeviceOrHostAddressConstKHR {
                    device_address: indices.device_address() + range.first_index as u64 * 4,
                });
            (
                vk::AccelerationStructureTypeKHR::BOTTOM_LEVEL,
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(vk::GeometryTypeKHR::TRIANGLES)
                    .geometry(vk::AccelerationStructureGeometryDataKHR { triangles })
                    .flags(vk::GeometryFlagsKHR::OPAQUE),
                range.triangles,
            )
        }
        Geometry::Instances { buffer, count } => {
            let instances = vk::AccelerationStructureGeometryInstancesDataKHR::default()
                .array_of_pointers(false)
                .data(vk::DeviceOrHostAddressConstKHR {
                    device_address: buffer.device_address(),
                });
            (
                vk::AccelerationStructureTypeKHR::TOP_LEVEL,
                vk::AccelerationStructureGeometryKHR::default()
                    .geometry_type(vk::GeometryTypeKHR::INSTANCES)
                    .geometry(vk::AccelerationStructureGeometryDataKHR { instances }),
                *count,
            )
        }
    }
    }
}

fn functions(device: &Device) -> Result<&ash::khr::acceleration_structure::Device> {
    device
        .ray_queries()
        .map(|r| &r.functions)
        .ok_or_else(|| Error::InvalidParameter("the device has no ray queries".into()))
}

impl AccelerationStructure {
    /// Records the build of a bottom level over one range of triangles
    /// (opaque; positions are the first 12 bytes of each `stride`-byte
    /// vertex). Returns it with the scratch buffer, which must live until
    /// the recording's submission finishes.
    pub fn bottom_level(
        rec: &mut Recorder<'_>,
        name: &str,
        (vertices, stride): (&Buffer, u64),
        indices: &Buffer,
        range: TriangleRange,
    ) -> Result<(Self, Buffer)> {
        let geometry = Geometry::Triangles {
            vertices,
            stride,
            indices,
            range,
        };
        Self::build(rec, name, geometry)
    }

    /// Records the build of a top level over `count` instances
    /// (`VkAccelerationStructureInstanceKHR`, host-written into `buffer`),
    /// whose bottom levels the caller declared read
    /// ([`Access::AccelerationStructureBuildRead`]). Returns it with the
    /// scratch buffer, which must live until the submission finishes.
    pub fn top_level(
        rec: &mut Recorder<'_>,
        name: &str,
        buffer: &Buffer,
        count: u32,
    ) -> Result<(Self, Buffer)> {
        Self::build(rec, name, Geometry::Instances { buffer, count })
    }

    fn build(rec: &mut Recorder<'_>, name: &str, geometry: Geometry<'_>) -> Result<(Self, Buffer)> {
        let device = rec.device.clone();
        let ext = functions(&device)?;
        let (ty, geometry_info, primitives) = geometry.describe();
        let geometries = [geometry_info];
        let mut info = vk::AccelerationStructureBuildGeometryInfoKHR::default()
            .ty(ty)
            .flags(vk::BuildAccelerationStructureFlagsKHR::PREFER_FAST_TRACE)
            .mode(vk::BuildAccelerationStructureModeKHR::BUILD)
            .geometries(&geometries);
        let mut sizes = vk::AccelerationStructureBuildSizesInfoKHR::default();
        // SAFETY: the geometry describes buffers of this device.
        unsafe {
            ext.get_acceleration_structure_build_sizes(
                vk::AccelerationStructureBuildTypeKHR::DEVICE,
                &info,
                &[primitives],
                &mut sizes,
            )
        };
        let storage = Buffer::new(
            &device,
            name,
            sizes.acceleration_structure_size,
            vk::BufferUsageFlags::ACCELERATION_STRUCTURE_STORAGE_KHR
                | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let alignment = device.ray_queries().map_or(1, |r| r.scratch_alignment);
        let scratch = Buffer::new(
            &device,
            &format!("{name}.scratch"),
            sizes.build_scratch_size + alignment,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::SHADER_DEVICE_ADDRESS,
            MemoryLocation::GpuOnly,
        )?;
        let create = vk::AccelerationStructureCreateInfoKHR::default()
            .buffer(storage.raw)
            .size(sizes.acceleration_structure_size)
            .ty(ty);
        // SAFETY: `storage` was made with acceleration-structure storage
        // usage and is large enough (the sizes query above).
        let raw = unsafe { ext.create_acceleration_structure(&create, None) }
            .vk("vkCreateAccelerationStructureKHR")?;
        let address_info = vk::AccelerationStructureDeviceAddressInfoKHR::default()
            .acceleration_structure(raw);
        // SAFETY: `raw` was just created.
        let address = unsafe { ext.get_acceleration_structure_device_address(&address_info) };
        let structure = Self {
            device: device.clone(),
            raw,
            buffer: storage,
            address,
        };
        device.set_name(raw, name);

        match &geometry {
            Geometry::Triangles {
                vertices, indices, ..
            } => {
                rec.use_buffer(vertices, Access::AccelerationStructureInput);
                rec.use_buffer(indices, Access::AccelerationStructureInput);
            }
            Geometry::Instances { buffer, .. } => {
                rec.use_buffer(buffer, Access::AccelerationStructureInput)
            }
        }
        rec.use_buffer(&structure.buffer, Access::AccelerationStructureBuild);
        rec.use_buffer(&scratch, Access::AccelerationStructureBuild);
        rec.flush_barriers();
        let scratch_address = scratch.device_address().next_multiple_of(alignment);
        info = info
            .dst_acceleration_structure(raw)
            .scratch_data(vk::DeviceOrHostAddressKHR {
                device_address: scratch_address,
            });
        let ranges = [vk::AccelerationStructureBuildRangeInfoKHR::default()
            .primitive_count(primitives)];
        // SAFETY: recording; the inputs, the destination and the scratch
        // are declared above, and live until the submission finishes (the
        // caller keeps the scratch; the others are deferred-destroyed).
        unsafe { ext.cmd_build_acceleration_structures(rec.cmd, &[info], &[&ranges[..]]) };
        Ok((structure, scratch))
    }
}

impl Drop for AccelerationStructure {
    fn drop(&mut self) {
        // Queued before its buffer (dropped after this), so destroyed first.
        self.device
            .defer_destroy(Garbage::AccelerationStructure(self.raw));
    }
}
