//! GPU buffers with `Drop`-based lifetimes and tracked last access.

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::aliasing::{AliasRegion, SharedUse};
use super::barrier::ResourceState;
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// A buffer and its memory. Host-visible buffers are persistently mapped.
pub struct Buffer {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::Buffer,
    allocation: Option<Allocation>,
    /// Its place in memory other phases' resources share (none: its own).
    pub(crate) shared: Option<SharedUse>,
    /// Size in bytes.
    pub size: u64,
    pub(crate) state: Cell<ResourceState>,
}

/// Bytes of device memory a buffer of `size` bytes with `usage` takes, as
/// [`Buffer::new`] makes it: on `device` its memory requirements, asked
/// before it exists (Vulkan 1.3); without one, `size` (as
/// [`ImageDesc::bytes`](super::ImageDesc::bytes) for images).
pub fn buffer_bytes(device: Option<&Device>, size: u64, usage: vk::BufferUsageFlags) -> u64 {
    match device.filter(|_| size > 0) {
        Some(device) => requirements(device, size, usage).size,
        None => size,
    }
}

/// The memory requirements of a buffer [`Buffer::new`] would make on
/// `device`, asked before it exists (Vulkan 1.3).
pub(crate) fn requirements(
    device: &Device,
    size: u64,
    usage: vk::BufferUsageFlags,
) -> vk::MemoryRequirements {
    let info = create_info(size, usage);
    let query = vk::DeviceBufferMemoryRequirements::default().create_info(&info);
    let mut requirements = vk::MemoryRequirements2::default();
    // SAFETY: a valid create info on a live Vulkan 1.3 device.
    unsafe {
        device
            .raw
            .get_device_buffer_memory_requirements(&query, &mut requirements)
    };
    requirements.memory_requirements
}

/// How [`Buffer::new`] creates a buffer of `size` bytes (at least 4).
fn create_info(size: u64, usage: vk::BufferUsageFlags) -> vk::BufferCreateInfo<'static> {
    vk::BufferCreateInfo::default()
        .size(size.max(4))
        .usage(usage)
        .sharing_mode(vk::SharingMode::EXCLUSIVE)
}

impl Buffer {
    /// Creates a buffer of `size` bytes (at least 4) in `location`.
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> Result<Self> {
        let info = create_info(size, usage);
        let size = info.size;
        // SAFETY: valid create info on a live device.
        let raw = unsafe { device.raw.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: `raw` was just created from this device.
        let requirements = unsafe { device.raw.get_buffer_memory_requirements(raw) };
        let allocation = device.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: never used or bound.
                unsafe { device.raw.destroy_buffer(raw, None) };
                return Err(e.into());
            }
        };
        // SAFETY: memory comes from the allocator for these requirements.
        let bound = unsafe {
            device
                .raw
                .bind_buffer_memory(raw, allocation.memory(), allocation.offset())
        };
        let buffer = Self {
            device: device.clone(),
            raw,
            allocation: Some(allocation),
            shared: None,
            size,
            state: Cell::new(ResourceState::default()),
        };
        bound.vk("vkBindBufferMemory")?;
        device.set_name(raw, name);
        device.count_resource();
        Ok(buffer)
    }

    /// Creates a device-local buffer of `size` bytes (at least 4) in
    /// `region` of memory other phases' resources share (see
    /// [`AliasedMemory`](super::AliasedMemory)).
    pub fn new_aliased(
        device: &Arc<Device>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        region: &mut AliasRegion,
    ) -> Result<Self> {
        let info = create_info(size, usage);
        let size = info.size;
        // SAFETY: valid create info on a live device.
        let raw = unsafe { device.raw.create_buffer(&info, None) }.vk("vkCreateBuffer")?;
        // SAFETY: `raw` was just created from this device.
        let requirements = unsafe { device.raw.get_buffer_memory_requirements(raw) };
        let (memory, offset, shared) = match region.place(name, requirements) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: never used or bound.
                unsafe { device.raw.destroy_buffer(raw, None) };
                return Err(e);
            }
        };
        let buffer = Self {
            device: device.clone(),
            raw,
            allocation: None,
            shared: Some(shared),
            size,
            state: Cell::new(ResourceState::default()),
        };
        // SAFETY: memory placed for these requirements.
        unsafe { device.raw.bind_buffer_memory(raw, memory, offset) }.vk("vkBindBufferMemory")?;
        device.set_name(raw, name);
        device.count_resource();
        Ok(buffer)
    }

    /// A host-visible buffer filled with `data`.
    pub fn with_data<T: bytemuck::Pod>(
        device: &Arc<Device>,
        name: &str,
        data: &[T],
        usage: vk::BufferUsageFlags,
    ) -> Result<Self> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let buffer = Self::new(
            device,
            name,
            bytes.len() as u64,
            usage,
            MemoryLocation::CpuToGpu,
        )?;
        buffer.write(0, bytes)?;
        Ok(buffer)
    }

    fn mapped(&self) -> Result<(*mut u8, usize)> {
        let allocation = self
            .allocation
            .as_ref()
            .expect("allocation lives until drop");
        let ptr = allocation.mapped_ptr().ok_or(Error::Vulkan {
            call: "map (buffer is not host visible)",
            result: vk::Result::ERROR_MEMORY_MAP_FAILED,
        })?;
        Ok((ptr.as_ptr() as *mut u8, allocation.size() as usize))
    }

    /// The buffer's device address (it was made with
    /// `SHADER_DEVICE_ADDRESS` usage on a device with bufferDeviceAddress).
    pub fn device_address(&self) -> vk::DeviceAddress {
        let info = vk::BufferDeviceAddressInfo::default().buffer(self.raw);
        // SAFETY: a live buffer of this device; the caller made it with
        // device-address usage.
        unsafe { self.device.raw.get_buffer_device_address(&info) }
    }

    /// The device the buffer lives on.
    pub fn device(&self) -> &Arc<Device> {
        &self.device
    }

    /// Copies `bytes` into a host-visible buffer at `offset`. The caller makes
    /// sure the GPU is not using the range (submission orders host writes).
    pub fn write(&self, offset: usize, bytes: &[u8]) -> Result<()> {
        let (ptr, len) = self.mapped()?;
        assert!(offset + bytes.len() <= len, "buffer write out of range");
        // SAFETY: range checked above; the mapping is valid while `self` lives.
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), ptr.add(offset), bytes.len()) };
        self.device.count_upload(bytes.len());
        Ok(())
    }

    /// Appends the first `len` bytes of the host-visible buffer to `out`
    /// (after the GPU finished).
    pub fn read_into(&self, len: usize, out: &mut Vec<u8>) -> Result<()> {
        let (ptr, size) = self.mapped()?;
        assert!(len <= size, "buffer read out of range");
        // SAFETY: `len` bytes are inside the mapping, which is valid while
        // `self` lives; memory is host coherent (GpuToCpu).
        out.extend_from_slice(unsafe { std::slice::from_raw_parts(ptr, len) });
        Ok(())
    }

    /// Reads the whole host-visible buffer as `T`s (after the GPU finished).
    pub fn read<T: bytemuck::Pod>(&self) -> Result<Vec<T>> {
        let (ptr, _) = self.mapped()?;
        let count = self.size as usize / std::mem::size_of::<T>();
        let mut out = vec![T::zeroed(); count];
        // SAFETY: `count * size_of::<T>()` bytes are inside the mapping; the
        // destination is a separate Vec, and memory is host coherent or the
        // allocator chose a coherent type for GpuToCpu.
        unsafe {
            std::ptr::copy_nonoverlapping(
                ptr,
                out.as_mut_ptr() as *mut u8,
                count * std::mem::size_of::<T>(),
            )
        };
        Ok(out)
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // Its own memory is freed with it; aliased memory after its last
        // resource (queued when `shared` drops, after this).
        self.device
            .defer_destroy(Garbage::Buffer(self.raw, self.allocation.take()));
    }
}
