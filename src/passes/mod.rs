//! One file per technique pass. Each pass owns its pipeline and descriptor
//! layout (created once with the renderer) and, per frame, the descriptor set
//! binding that frame's resources. Recording a pass declares every resource
//! it touches (barriers follow from that), opens a GPU timestamp scope, and
//! records its commands.

pub mod direct_lighting;
pub mod gbuffer;
pub mod indirect_bounded;
pub mod ism;
pub mod shadow_maps;
pub mod ssbc;

use ash::vk;

use crate::vk::{Device, Image};

/// Begins dynamic rendering into `colors` and `depth` (all cleared), with a
/// full-size viewport and scissor.
pub(crate) fn begin_rendering(
    device: &Device,
    cmd: vk::CommandBuffer,
    extent: (u32, u32),
    colors: &[vk::ImageView],
    depth: vk::ImageView,
) {
    let color_attachments: Vec<_> = colors
        .iter()
        .map(|&view| {
            vk::RenderingAttachmentInfo::default()
                .image_view(view)
                .image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL)
                .load_op(vk::AttachmentLoadOp::CLEAR)
                .store_op(vk::AttachmentStoreOp::STORE)
                .clear_value(vk::ClearValue {
                    color: vk::ClearColorValue { float32: [0.0; 4] },
                })
        })
        .collect();
    let depth_attachment = vk::RenderingAttachmentInfo::default()
        .image_view(depth)
        .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
        .load_op(vk::AttachmentLoadOp::CLEAR)
        .store_op(vk::AttachmentStoreOp::STORE)
        .clear_value(vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: 1.0,
                stencil: 0,
            },
        });
    let area = vk::Rect2D {
        offset: vk::Offset2D::default(),
        extent: vk::Extent2D {
            width: extent.0,
            height: extent.1,
        },
    };
    let info = vk::RenderingInfo::default()
        .render_area(area)
        .layer_count(1)
        .color_attachments(&color_attachments)
        .depth_attachment(&depth_attachment);
    let viewport = vk::Viewport {
        x: 0.0,
        y: 0.0,
        width: extent.0 as f32,
        height: extent.1 as f32,
        min_depth: 0.0,
        max_depth: 1.0,
    };
    // SAFETY: recording; attachments were transitioned by the caller.
    unsafe {
        device.raw.cmd_begin_rendering(cmd, &info);
        device.raw.cmd_set_viewport(cmd, 0, &[viewport]);
        device.raw.cmd_set_scissor(cmd, 0, &[area]);
    }
}

/// A render-target image of the G-buffer or a lighting layer.
pub(crate) fn storage_image(
    device: &std::sync::Arc<Device>,
    name: &str,
    format: vk::Format,
    extent: (u32, u32),
    extra_usage: vk::ImageUsageFlags,
) -> crate::Result<Image> {
    Image::new(
        device,
        name,
        crate::vk::ImageDesc::new_2d(
            format,
            extent.0,
            extent.1,
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC | extra_usage,
        ),
    )
}
