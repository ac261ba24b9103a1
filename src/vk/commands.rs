//! Command recording: a pool, a command buffer, and barriers batched from the
//! tracked state of the resources a pass declares it uses.

use std::sync::Arc;

use ash::vk;

use std::cell::Cell;

use super::aliasing::{AliasedMemory, SharedUse};
use super::barrier::{transition, Access, ResourceState};
use super::buffer::Buffer;
use super::device::{Device, Garbage};
use super::image::Image;
use crate::error::{Result, VkResultExt};

/// A tightly packed copy region covering `layers` layers of mip 0.
fn color_region(extent: (u32, u32), layers: u32, mip_level: u32) -> vk::BufferImageCopy {
    vk::BufferImageCopy::default()
        .image_subresource(vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level,
            base_array_layer: 0,
            layer_count: layers,
        })
        .image_extent(vk::Extent3D {
            width: extent.0,
            height: extent.1,
            depth: 1,
        })
}

/// An image whose last access ssbc tracks: its own [`Image`]s and the
/// swapchain's images.
pub trait TrackedImage {
    /// The raw handle.
    fn tracked_raw(&self) -> vk::Image;
    /// Its access state.
    fn tracked_state(&self) -> &Cell<ResourceState>;
    /// The subresources barriers cover.
    fn tracked_range(&self) -> vk::ImageSubresourceRange;
    /// Its place in aliased memory, if it has one.
    fn tracked_shared(&self) -> Option<&SharedUse> {
        None
    }
}

impl TrackedImage for Image {
    fn tracked_raw(&self) -> vk::Image {
        self.raw
    }
    fn tracked_state(&self) -> &Cell<ResourceState> {
        &self.state
    }
    fn tracked_range(&self) -> vk::ImageSubresourceRange {
        self.full_range()
    }
    fn tracked_shared(&self) -> Option<&SharedUse> {
        self.shared.as_ref()
    }
}

/// A command pool with one primary command buffer, reset for every recording.
pub struct CommandPool {
    device: Arc<Device>,
    raw: vk::CommandPool,
    cmd: vk::CommandBuffer,
}

impl CommandPool {
    /// Names the pool and its command buffer (see [`Device::set_name`]).
    pub fn name(&self, name: &str) {
        self.device
            .set_name(self.raw, &format!("{name} command pool"));
        self.device.set_name(self.cmd, &format!("{name} commands"));
    }

    /// Creates the pool on the device's queue family.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(device.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid create info.
        let raw =
            unsafe { device.raw.create_command_pool(&info, None) }.vk("vkCreateCommandPool")?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(raw)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: pool just created.
        let cmd = match unsafe { device.raw.allocate_command_buffers(&alloc) } {
            Ok(c) => c[0],
            Err(result) => {
                // SAFETY: nothing allocated from it.
                unsafe { device.raw.destroy_command_pool(raw, None) };
                return Err(crate::Error::Vulkan {
                    call: "vkAllocateCommandBuffers",
                    result,
                });
            }
        };
        Ok(Self {
            device: device.clone(),
            raw,
            cmd,
        })
    }

    /// Resets the pool and starts recording. The previous recording must have
    /// finished on the GPU (the caller waited for its submission).
    pub fn begin(&mut self) -> Result<Recorder<'_>> {
        // SAFETY: the caller guarantees the last submission of this pool is done.
        unsafe {
            self.device
                .raw
                .reset_command_pool(self.raw, vk::CommandPoolResetFlags::empty())
                .vk("vkResetCommandPool")?;
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            self.device
                .raw
                .begin_command_buffer(self.cmd, &begin)
                .vk("vkBeginCommandBuffer")?;
        }
        Ok(Recorder {
            device: &self.device,
            cmd: self.cmd,
            image_barriers: Vec::new(),
            buffer_barriers: Vec::new(),
        })
    }
}

impl Drop for CommandPool {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::CommandPool(self.raw));
    }
}

impl<'a> Recorder<'a> {
    /// Records into a command buffer a host engine began (and will end and
    /// submit itself); call [`Recorder::flush_barriers`] when done.
    pub fn for_host(device: &'a Arc<Device>, cmd: vk::CommandBuffer) -> Self {
        Recorder {
            device,
            cmd,
            image_barriers: Vec::new(),
            buffer_barriers: Vec::new(),
        }
    }
}

/// Records one command buffer. Passes call [`Recorder::use_image`] and
/// [`Recorder::use_buffer`] for everything they touch, then
/// [`Recorder::flush_barriers`] emits one `vkCmdPipelineBarrier2`.
pub struct Recorder<'a> {
    /// The device.
    pub device: &'a Arc<Device>,
    /// The raw command buffer being recorded.
    pub cmd: vk::CommandBuffer,
    image_barriers: Vec<vk::ImageMemoryBarrier2<'static>>,
    buffer_barriers: Vec<vk::BufferMemoryBarrier2<'static>>,
}

impl Recorder<'_> {
    /// Declares the next use of `image`; a barrier is queued if needed.
    pub fn use_image(&mut self, image: &impl TrackedImage, access: Access) {
        let state = image.tracked_state();
        let before = match image.tracked_shared() {
            Some(shared) => shared.state(state.get()),
            None => state.get(),
        };
        let (barrier, after) = transition(before, access, true);
        state.set(after);
        if let Some(b) = barrier {
            self.image_barriers.push(
                vk::ImageMemoryBarrier2::default()
                    .src_stage_mask(b.src_stage)
                    .src_access_mask(b.src_access)
                    .dst_stage_mask(b.dst_stage)
                    .dst_access_mask(b.dst_access)
                    .old_layout(b.old_layout)
                    .new_layout(b.new_layout)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .image(image.tracked_raw())
                    .subresource_range(image.tracked_range()),
            );
        }
    }

    /// Hands `image` back to its owner (a host) in `layout`: a barrier from
    /// its tracked last access that makes ssbc's writes available and
    /// visible to every later command, in that layout. ssbc does not use it
    /// again in this recording.
    pub fn hand_back(&mut self, image: &impl TrackedImage, layout: vk::ImageLayout) {
        let state = image.tracked_state().get();
        let (write_stage, write_access) = state
            .last_write
            .unwrap_or((vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE));
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        self.image_barriers.push(
            vk::ImageMemoryBarrier2::default()
                .src_stage_mask(write_stage | state.visible_stages)
                .src_access_mask(write_access)
                .dst_stage_mask(all)
                .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
                .old_layout(state.layout)
                .new_layout(layout)
                .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                .image(image.tracked_raw())
                .subresource_range(image.tracked_range()),
        );
        image.tracked_state().set(ResourceState {
            layout,
            last_write: Some((all, vk::AccessFlags2::MEMORY_WRITE)),
            visible_stages: all,
            visible_access: vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE,
        });
    }

    /// Declares the next use of `buffer`; a barrier is queued if needed.
    pub fn use_buffer(&mut self, buffer: &Buffer, access: Access) {
        let before = match &buffer.shared {
            Some(shared) => shared.state(buffer.state.get()),
            None => buffer.state.get(),
        };
        let (barrier, after) = transition(before, access, false);
        buffer.state.set(after);
        if let Some(b) = barrier {
            self.buffer_barriers.push(
                vk::BufferMemoryBarrier2::default()
                    .src_stage_mask(b.src_stage)
                    .src_access_mask(b.src_access)
                    .dst_stage_mask(b.dst_stage)
                    .dst_access_mask(b.dst_access)
                    .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
                    .buffer(buffer.raw)
                    .offset(0)
                    .size(vk::WHOLE_SIZE),
            );
        }
    }

    /// Starts `phase` of aliased memory: if another phase held it, one
    /// barrier after every command so far (whatever that phase's resources
    /// did), and the phase's resources start over from an undefined layout
    /// at their next use.
    pub fn hand_over(&mut self, memory: &AliasedMemory, phase: u32) {
        if !memory.begin_phase(phase) {
            return;
        }
        self.flush_barriers();
        let all = vk::PipelineStageFlags2::ALL_COMMANDS;
        let barrier = vk::MemoryBarrier2::default()
            .src_stage_mask(all)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(all)
            .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE);
        let info = vk::DependencyInfo::default().memory_barriers(std::slice::from_ref(&barrier));
        // SAFETY: recording; a global barrier references no resource.
        unsafe { self.device.raw.cmd_pipeline_barrier2(self.cmd, &info) };
    }

    /// Emits every queued barrier in one call.
    pub fn flush_barriers(&mut self) {
        if self.image_barriers.is_empty() && self.buffer_barriers.is_empty() {
            return;
        }
        let info = vk::DependencyInfo::default()
            .image_memory_barriers(&self.image_barriers)
            .buffer_memory_barriers(&self.buffer_barriers);
        // SAFETY: recording; barriers reference live resources.
        unsafe { self.device.raw.cmd_pipeline_barrier2(self.cmd, &info) };
        self.image_barriers.clear();
        self.buffer_barriers.clear();
    }

    /// Copies mip 0 / layer 0 of a colour image into a buffer (tightly packed).
    pub fn copy_image_to_buffer(&mut self, image: &Image, buffer: &Buffer) {
        self.use_image(image, Access::TransferRead);
        self.use_buffer(buffer, Access::TransferWrite);
        self.flush_barriers();
        let region = color_region((image.desc.width, image.desc.height), 1, 0);
        // SAFETY: layouts set by the barrier above; buffer sized by the caller.
        unsafe {
            self.device.raw.cmd_copy_image_to_buffer(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[region],
            )
        };
    }

    /// Copies rows `rows` of mip 0 / layer 0 of a colour image to the start
    /// of a buffer (tightly packed).
    pub fn copy_image_rows_to_buffer(
        &mut self,
        image: &Image,
        rows: std::ops::Range<u32>,
        buffer: &Buffer,
    ) {
        self.use_image(image, Access::TransferRead);
        self.use_buffer(buffer, Access::TransferWrite);
        self.flush_barriers();
        let extent = (image.desc.width, rows.end - rows.start);
        let region = color_region(extent, 1, 0).image_offset(vk::Offset3D {
            x: 0,
            y: rows.start as i32,
            z: 0,
        });
        // SAFETY: layouts set by the barrier above; the rows lie in the
        // image and the buffer is sized by the caller.
        unsafe {
            self.device.raw.cmd_copy_image_to_buffer(
                self.cmd,
                image.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw,
                &[region],
            )
        };
    }

    /// Copies `size` bytes from `src` at `src_offset` to `dst` at `dst_offset`.
    pub fn copy_buffer(
        &mut self,
        src: &Buffer,
        src_offset: u64,
        dst: &Buffer,
        dst_offset: u64,
        size: u64,
    ) {
        self.use_buffer(src, Access::TransferRead);
        self.use_buffer(dst, Access::TransferWrite);
        self.flush_barriers();
        let region = vk::BufferCopy {
            src_offset,
            dst_offset,
            size,
        };
        // SAFETY: barriers above; the caller keeps both ranges inside the buffers.
        unsafe {
            self.device
                .raw
                .cmd_copy_buffer(self.cmd, src.raw, dst.raw, &[region])
        };
    }

    /// Uploads tightly packed texels from `buffer` into `layers` layers of
    /// mip 0 of `image` (of size `extent`): a texture or a swapchain image.
    pub fn copy_buffer_to_image(
        &mut self,
        buffer: &Buffer,
        image: &impl TrackedImage,
        extent: (u32, u32),
        layers: u32,
    ) {
        self.copy_regions_to_image(buffer, image, &[color_region(extent, layers, 0)]);
    }

    /// Uploads every mip level and layer of `image` (a colour array of
    /// `texel_bytes` per texel) from `buffer`, where they lie tightly
    /// packed level after level, each level's layers together.
    pub fn copy_buffer_to_mips(&mut self, buffer: &Buffer, image: &Image, texel_bytes: u64) {
        let desc = &image.desc;
        let mut offset = 0;
        let regions: Vec<_> = (0..desc.mip_levels)
            .map(|level| {
                let extent = ((desc.width >> level).max(1), (desc.height >> level).max(1));
                let region =
                    color_region(extent, desc.layers, level).buffer_offset(offset);
                offset += extent.0 as u64 * extent.1 as u64 * desc.layers as u64 * texel_bytes;
                region
            })
            .collect();
        self.copy_regions_to_image(buffer, image, &regions);
    }

    fn copy_regions_to_image(
        &mut self,
        buffer: &Buffer,
        image: &impl TrackedImage,
        regions: &[vk::BufferImageCopy],
    ) {
        self.use_buffer(buffer, Access::TransferRead);
        self.use_image(image, Access::TransferWrite);
        self.flush_barriers();
        // SAFETY: layouts set by the barrier above; the caller's buffer
        // holds every region.
        unsafe {
            self.device.raw.cmd_copy_buffer_to_image(
                self.cmd,
                buffer.raw,
                image.tracked_raw(),
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                regions,
            )
        };
    }

    /// Copies `extent` of mip 0 / layer 0 of `src` from `src_origin` into
    /// `dst` at its origin (size-compatible formats), e.g. into a swapchain
    /// image.
    pub fn copy_image(
        &mut self,
        src: &Image,
        src_origin: (u32, u32),
        dst: &impl TrackedImage,
        extent: (u32, u32),
    ) {
        self.use_image(src, Access::TransferRead);
        self.use_image(dst, Access::TransferWrite);
        self.flush_barriers();
        let layers = vk::ImageSubresourceLayers {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            mip_level: 0,
            base_array_layer: 0,
            layer_count: 1,
        };
        let region = vk::ImageCopy::default()
            .src_subresource(layers)
            .src_offset(vk::Offset3D {
                x: src_origin.0 as i32,
                y: src_origin.1 as i32,
                z: 0,
            })
            .dst_subresource(layers)
            .extent(vk::Extent3D {
                width: extent.0,
                height: extent.1,
                depth: 1,
            });
        // SAFETY: layouts set by the barrier above; the caller keeps `extent` (at
        // `src_origin` in `src`) inside both images.
        unsafe {
            self.device.raw.cmd_copy_image(
                self.cmd,
                src.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                dst.tracked_raw(),
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                &[region],
            )
        };
    }

    /// Writes `data` (at most 65536 bytes, a multiple of 4) into `buffer` at
    /// `offset` from the command stream.
    pub fn update_buffer(&mut self, buffer: &Buffer, offset: u64, data: &[u8]) {
        self.use_buffer(buffer, Access::TransferWrite);
        self.flush_barriers();
        // SAFETY: barrier above; the caller keeps the range inside the buffer
        // and the size within vkCmdUpdateBuffer's limits.
        unsafe {
            self.device
                .raw
                .cmd_update_buffer(self.cmd, buffer.raw, offset, data)
        };
    }

    /// Fills a buffer with a 32-bit value.
    pub fn fill_buffer(&mut self, buffer: &Buffer, value: u32) {
        self.use_buffer(buffer, Access::TransferWrite);
        self.flush_barriers();
        // SAFETY: whole buffer, size is a multiple of 4 (Buffer::new rounds).
        unsafe {
            self.device
                .raw
                .cmd_fill_buffer(self.cmd, buffer.raw, 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Ends recording, submits, and returns the timeline value to wait on.
    pub fn submit(self) -> Result<u64> {
        self.submit_with(&[], &[])
    }

    /// Like [`Recorder::submit`], also waiting on binary semaphores (at the
    /// given stages) and signalling others (for a swapchain).
    pub fn submit_with(
        self,
        waits: &[(vk::Semaphore, vk::PipelineStageFlags2)],
        signals: &[vk::Semaphore],
    ) -> Result<u64> {
        // SAFETY: recording was begun in CommandPool::begin.
        unsafe { self.device.raw.end_command_buffer(self.cmd) }.vk("vkEndCommandBuffer")?;
        self.device.submit_with(&[self.cmd], waits, signals)
    }
}
