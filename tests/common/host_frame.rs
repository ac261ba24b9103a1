//! A host engine's frame loop around `Renderer::record_resident`: its own
//! command pool, fence and output image; each frame recorded into its
//! command buffer, copied out and read back after its fence.

use ash::vk;
use ssbc::postprocess::HostImage;
use ssbc::renderer::{RenderSettings, Renderer};
use ssbc::resident::ResidentScene;
use ssbc::vk::{Buffer, Device, Image, ImageDesc};
use std::sync::Arc;

/// The host's objects for frames of one size.
pub struct HostFrames {
    device: Arc<Device>,
    output: Image,
    readback: Buffer,
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    extent: (u32, u32),
}

impl HostFrames {
    /// Objects for frames of `settings`' size on `renderer`'s device.
    pub fn new(renderer: &Renderer, settings: &RenderSettings) -> Self {
        let device = renderer.device().clone();
        let (w, h) = (settings.width, settings.height);
        let output = Image::new(
            &device,
            "host.output",
            ImageDesc::new_2d(
                vk::Format::R32G32B32A32_SFLOAT,
                w,
                h,
                // (STORAGE only because ssbc's helper makes a view of it.)
                vk::ImageUsageFlags::TRANSFER_DST
                    | vk::ImageUsageFlags::TRANSFER_SRC
                    | vk::ImageUsageFlags::STORAGE,
            ),
        )
        .unwrap();
        let readback = Buffer::new(
            &device,
            "host.readback",
            w as u64 * h as u64 * 16,
            vk::BufferUsageFlags::TRANSFER_DST,
            gpu_allocator::MemoryLocation::GpuToCpu,
        )
        .unwrap();
        let raw = &device.raw;
        // SAFETY: the host's own pool, buffer and fence on a live device,
        // destroyed in Drop after the last fence has signalled.
        let (pool, cmd, fence) = unsafe {
            let pool = raw
                .create_command_pool(
                    &vk::CommandPoolCreateInfo::default()
                        .queue_family_index(device.queue_family)
                        .flags(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER),
                    None,
                )
                .unwrap();
            let cmd = raw
                .allocate_command_buffers(
                    &vk::CommandBufferAllocateInfo::default()
                        .command_pool(pool)
                        .command_buffer_count(1),
                )
                .unwrap()[0];
            let fence = raw
                .create_fence(&vk::FenceCreateInfo::default(), None)
                .unwrap();
            (pool, cmd, fence)
        };
        Self {
            device,
            output,
            readback,
            pool,
            cmd,
            fence,
            extent: (w, h),
        }
    }

    /// Records a frame of `resident` in `slot` into the host's command
    /// buffer, submits it, waits for its fence and returns the final image
    /// (RGBA rows).
    pub fn frame(
        &mut self,
        renderer: &mut Renderer,
        resident: &ResidentScene,
        settings: &RenderSettings,
        slot: usize,
    ) -> Vec<f32> {
        let layer = ssbc::Layer::Final;
        self.frame_layer(renderer, resident, settings, (slot, layer))
    }

    /// [`HostFrames::frame`], handing over `layer`.
    pub fn frame_layer(
        &mut self,
        renderer: &mut Renderer,
        resident: &ResidentScene,
        settings: &RenderSettings,
        (slot, layer): (usize, ssbc::Layer),
    ) -> Vec<f32> {
        let (raw, cmd, (w, h)) = (&self.device.raw, self.cmd, self.extent);
        // SAFETY: the buffer's previous submission was waited for.
        unsafe {
            raw.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .unwrap();
            raw.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
                .unwrap();
        }
        let host = HostImage {
            image: self.output.raw,
            view: self.output.view,
            format: vk::Format::R32G32B32A32_SFLOAT,
            extent: (w, h),
            layout: vk::ImageLayout::UNDEFINED,
        };
        renderer
            .record_resident(resident, settings, cmd, slot, &host, layer)
            .unwrap();
        // SAFETY: recording the host's own copy and submitting its buffer.
        unsafe {
            let to_src = [vk::ImageMemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::COPY)
                .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)
                .old_layout(vk::ImageLayout::TRANSFER_DST_OPTIMAL)
                .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
                .image(self.output.raw)
                .subresource_range(self.output.full_range())];
            raw.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().image_memory_barriers(&to_src),
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(vk::ImageSubresourceLayers {
                    aspect_mask: vk::ImageAspectFlags::COLOR,
                    mip_level: 0,
                    base_array_layer: 0,
                    layer_count: 1,
                })
                .image_extent(vk::Extent3D {
                    width: w,
                    height: h,
                    depth: 1,
                });
            raw.cmd_copy_image_to_buffer(
                cmd,
                self.output.raw,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                self.readback.raw,
                &[region],
            );
            let host_read = [vk::MemoryBarrier2::default()
                .src_stage_mask(vk::PipelineStageFlags2::COPY)
                .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
                .dst_stage_mask(vk::PipelineStageFlags2::HOST)
                .dst_access_mask(vk::AccessFlags2::HOST_READ)];
            raw.cmd_pipeline_barrier2(
                cmd,
                &vk::DependencyInfo::default().memory_barriers(&host_read),
            );
            raw.end_command_buffer(cmd).unwrap();
            let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
            raw.queue_submit2(
                self.device.queue,
                &[vk::SubmitInfo2::default().command_buffer_infos(&cmds)],
                self.fence,
            )
            .unwrap();
            raw.wait_for_fences(&[self.fence], true, u64::MAX).unwrap();
            raw.reset_fences(&[self.fence]).unwrap();
        }
        self.readback.read().unwrap()
    }
}

impl Drop for HostFrames {
    fn drop(&mut self) {
        // SAFETY: every submission was waited for.
        unsafe {
            self.device.raw.destroy_fence(self.fence, None);
            self.device.raw.destroy_command_pool(self.pool, None);
        }
    }
}
