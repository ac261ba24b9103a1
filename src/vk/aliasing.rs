//! Memory aliasing: one block of device memory that the transient resources
//! of different phases of a frame share (their lifetimes do not overlap).
//!
//! A frame slot's interleaved gather writes its intermediate images and
//! reads them back before SSBC begins; SSBC's pyramids are written and read
//! only after. Bound to the same memory, the two take the larger's bytes
//! instead of both. What that costs in care:
//! - every phase's resources are written before they are read in a frame
//!   (their contents do not survive the other phase);
//! - [`Recorder::hand_over`](super::Recorder::hand_over) starts a phase: one
//!   global barrier after everything the other phase did, and each of the
//!   phase's resources starts its next use from an undefined layout
//!   (`SharedUse`), which the tracked barriers then transition;
//! - resources are placed at offsets aligned to
//!   `bufferImageGranularity` as well as their own alignment, so that a
//!   buffer and an optimal image of one phase never share a page.

use std::cell::Cell;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::barrier::ResourceState;
use super::device::{Device, Garbage};
use super::image::ImageDesc;
use crate::error::{Error, Result};

/// A resource to be placed in aliased memory, described before it exists.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Planned {
    /// An image as [`Image::new`](super::Image::new) makes it.
    Image(ImageDesc),
    /// A device-local buffer of `bytes` bytes with `usage`.
    Buffer {
        /// Size in bytes.
        bytes: u64,
        /// How it is used.
        usage: vk::BufferUsageFlags,
    },
}

impl Planned {
    /// Its memory requirements on `device` (asked before it exists).
    fn requirements(&self, device: &Device) -> vk::MemoryRequirements {
        match self {
            Planned::Image(desc) => desc.memory_requirements(device),
            Planned::Buffer { bytes, usage } => super::buffer::requirements(device, *bytes, *usage),
        }
    }

    /// Its bytes without a device: as asked for.
    fn bytes(&self) -> u64 {
        match self {
            Planned::Image(desc) => desc.bytes(None),
            Planned::Buffer { bytes, .. } => (*bytes).max(4),
        }
    }
}

/// The resources one user of aliased memory (a pass on one G-buffer layer)
/// places there, in the order it creates them.
pub type Tenant = Vec<Planned>;

/// How aliased memory is laid out: per phase, its tenants one after
/// another; the phases over each other from offset 0.
#[derive(Clone, Debug, PartialEq)]
pub struct AliasPlan {
    /// Per phase, its tenants.
    pub phases: Vec<Vec<Tenant>>,
}

/// Where each resource goes on a device: offsets aligned to its alignment
/// and to the device's bufferImageGranularity.
struct Placement {
    /// Per phase, per tenant, its range `(start, end)`.
    tenants: Vec<Vec<(u64, u64)>>,
    size: u64,
    alignment: u64,
    memory_type_bits: u32,
}

fn align_up(offset: u64, alignment: u64) -> u64 {
    offset.div_ceil(alignment.max(1)) * alignment.max(1)
}

impl AliasPlan {
    /// Whether it shares anything: at least two phases with resources.
    pub fn shares(&self) -> bool {
        let used = self.phases.iter().filter(|p| p.iter().any(|t| !t.is_empty()));
        used.count() >= 2
    }

    /// The phase that takes the most bytes (the first of equals) and its
    /// bytes, the memory's size: on `device` as [`AliasedMemory::new`]
    /// places it, without one as asked for.
    pub fn largest(&self, device: Option<&Device>) -> (usize, u64) {
        let sizes: Vec<u64> = match device {
            Some(d) => {
                let placed = self.place(d);
                placed.tenants.iter().map(|t| t.last().map_or(0, |r| r.1)).collect()
            }
            None => self
                .phases
                .iter()
                .map(|p| p.iter().flatten().map(Planned::bytes).sum())
                .collect(),
        };
        let most = sizes.iter().copied().max().unwrap_or(0);
        (sizes.iter().position(|&b| b == most).unwrap_or(0), most)
    }

    fn place(&self, device: &Device) -> Placement {
        let granularity = device.limits().buffer_image_granularity.max(1);
        let (mut size, mut alignment, mut memory_type_bits) = (0, granularity, u32::MAX);
        let mut tenants = Vec::new();
        for phase in &self.phases {
            let mut cursor = 0;
            let mut ranges = Vec::new();
            for tenant in phase {
                let start = cursor;
                for resource in tenant {
                    let r = resource.requirements(device);
                    let align = r.alignment.max(granularity);
                    cursor = align_up(cursor, align) + r.size;
                    alignment = alignment.max(align);
                    memory_type_bits &= r.memory_type_bits;
                }
                cursor = align_up(cursor, granularity);
                ranges.push((start, cursor));
            }
            size = size.max(cursor);
            tenants.push(ranges);
        }
        Placement {
            tenants,
            size,
            alignment,
            memory_type_bits,
        }
    }
}

/// No phase owns the memory yet.
const NO_PHASE: u32 = u32::MAX;

/// Device memory the phases of `AliasPlan` share.
pub struct AliasedMemory {
    device: Arc<Device>,
    allocation: Option<Allocation>,
    /// The memory types all its planned resources can use.
    memory_type_bits: u32,
    /// The phase whose resources it holds now.
    owner: AtomicU32,
    /// Incremented at every hand-over between phases.
    epoch: AtomicU64,
}

/// A tenant's part of aliased memory; its resources are placed one after
/// another as they are made ([`Image::new_aliased`](super::Image::new_aliased),
/// [`Buffer::new_aliased`](super::Buffer::new_aliased)).
#[derive(Clone)]
pub struct AliasRegion {
    memory: Arc<AliasedMemory>,
    phase: u32,
    cursor: u64,
    end: u64,
}

impl AliasedMemory {
    /// Allocates memory for `plan` (named `name`, as the allocator reports
    /// it) and returns each tenant's region, per phase.
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        plan: &AliasPlan,
    ) -> Result<(Arc<Self>, Vec<Vec<AliasRegion>>)> {
        let placement = plan.place(device);
        let requirements = vk::MemoryRequirements {
            size: placement.size.max(placement.alignment),
            alignment: placement.alignment,
            memory_type_bits: placement.memory_type_bits,
        };
        if requirements.memory_type_bits == 0 {
            return Err(Error::InvalidParameter(format!(
                "'{name}': its resources have no memory type in common"
            )));
        }
        // Non-linear: the allocator keeps it a granularity page away from
        // any neighbour (its own buffers and images are placed apart).
        let allocation = device.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        })?;
        let memory = Arc::new(Self {
            device: device.clone(),
            allocation: Some(allocation),
            memory_type_bits: placement.memory_type_bits,
            owner: AtomicU32::new(NO_PHASE),
            epoch: AtomicU64::new(0),
        });
        let regions = placement
            .tenants
            .iter()
            .enumerate()
            .map(|(phase, ranges)| {
                let region = |&(start, end)| AliasRegion {
                    memory: memory.clone(),
                    phase: phase as u32,
                    cursor: start,
                    end,
                };
                ranges.iter().map(region).collect()
            })
            .collect();
        Ok((memory, regions))
    }

    /// Makes `phase` the owner; true if it was another phase's (the caller
    /// then records a barrier after everything that phase did).
    pub(crate) fn begin_phase(&self, phase: u32) -> bool {
        if self.owner.swap(phase, Ordering::Relaxed) == phase {
            return false;
        }
        self.epoch.fetch_add(1, Ordering::Relaxed);
        true
    }
}

impl Drop for AliasedMemory {
    fn drop(&mut self) {
        if let Some(allocation) = self.allocation.take() {
            // Queued after the resources bound to it (they hold this Arc).
            self.device.defer_destroy(Garbage::Memory(allocation));
        }
    }
}

impl AliasRegion {
    /// The memory and offset for a resource with `requirements`, named
    /// `name`, and what tracks its phase; fails if the region is too small
    /// (its plan said otherwise).
    pub(crate) fn place(
        &mut self,
        name: &str,
        requirements: vk::MemoryRequirements,
    ) -> Result<(vk::DeviceMemory, u64, SharedUse)> {
        let granularity = self.memory.device.limits().buffer_image_granularity.max(1);
        let offset = align_up(self.cursor, requirements.alignment.max(granularity));
        let allocation = self.memory.allocation.as_ref().expect("live until drop");
        // Every memory type the plan's resources had in common (the
        // allocator chose one of them) is one this resource can use.
        let types = self.memory.memory_type_bits;
        let fits = offset + requirements.size <= self.end
            && requirements.memory_type_bits & types == types;
        if !fits {
            return Err(Error::InvalidParameter(format!(
                "'{name}' ({} bytes) does not fit its planned place in aliased memory",
                requirements.size
            )));
        }
        self.cursor = offset + requirements.size;
        let use_ = SharedUse {
            memory: self.memory.clone(),
            phase: self.phase,
            epoch: Cell::new(u64::MAX),
        };
        // SAFETY: the handle is only bound to resources, never freed here.
        let memory = unsafe { allocation.memory() };
        Ok((memory, allocation.offset() + offset, use_))
    }
}

/// A resource's place in aliased memory: its phase, and the hand-over it
/// last saw.
pub struct SharedUse {
    memory: Arc<AliasedMemory>,
    phase: u32,
    epoch: Cell<u64>,
}

impl SharedUse {
    /// The state a resource's next use starts from: `state`, or, if
    /// another phase used the memory since this resource's last use, an
    /// undefined layout after the hand-over's barrier (which made every
    /// earlier access available to all commands).
    pub(crate) fn state(&self, state: ResourceState) -> ResourceState {
        let epoch = self.memory.epoch.load(Ordering::Relaxed);
        if self.epoch.get() == epoch {
            return state;
        }
        let owner = self.memory.owner.load(Ordering::Relaxed);
        assert_eq!(
            owner, self.phase,
            "a resource of phase {} used while phase {owner} holds its memory",
            self.phase
        );
        self.epoch.set(epoch);
        ResourceState {
            layout: vk::ImageLayout::UNDEFINED,
            last_write: None,
            visible_stages: vk::PipelineStageFlags2::ALL_COMMANDS,
            visible_access: vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offsets_align_up() {
        assert_eq!(align_up(0, 256), 0);
        assert_eq!(align_up(1, 256), 256);
        assert_eq!(align_up(512, 256), 512);
        assert_eq!(align_up(7, 0), 7);
    }

    #[test]
    fn a_plan_shares_only_with_two_phases_in_use() {
        let buffer = Planned::Buffer {
            bytes: 100,
            usage: vk::BufferUsageFlags::STORAGE_BUFFER,
        };
        let plan = |phases: Vec<Vec<Tenant>>| AliasPlan { phases };
        assert!(plan(vec![vec![vec![buffer]], vec![vec![buffer, buffer]]]).shares());
        assert!(!plan(vec![vec![vec![buffer]], vec![vec![]]]).shares());
        let two = plan(vec![vec![vec![buffer], vec![buffer]], vec![vec![buffer]]]);
        assert_eq!(two.largest(None), (0, 200), "the larger phase and its bytes");
    }
}
