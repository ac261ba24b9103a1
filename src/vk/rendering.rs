//! Dynamic rendering scopes: what a draw writes and reads, stated once for
//! both the barriers and `vkCmdBeginRendering`.

use ash::vk;

use super::barrier::Access;
use super::buffer::Buffer;
use super::commands::Recorder;
use super::image::Image;

/// The attachments and vertex input of a rendering scope. Colour targets
/// are cleared to 0 and the depth target to `depth_clear`; both are stored.
pub struct RenderTargets<'a> {
    /// Colour attachments, in the fragment shader's output order.
    pub colors: &'a [&'a Image],
    /// The depth attachment (all of it is declared; a scope may draw into
    /// one layer of it, [`Recorder::begin_rendering`]).
    pub depth: &'a Image,
    /// Depth's clear value (0 with reversed depth).
    pub depth_clear: f32,
    /// Vertex and index buffers the draws fetch from.
    pub vertex_input: &'a [&'a Buffer],
}

impl Recorder<'_> {
    /// Declares every access of `targets` (attachment writes, vertex input)
    /// and flushes the barriers, with those the caller declared for its
    /// descriptor sets.
    pub fn declare_targets(&mut self, targets: &RenderTargets<'_>) {
        for color in targets.colors {
            self.use_image(*color, Access::ColorAttachmentWrite);
        }
        self.use_image(targets.depth, Access::DepthAttachmentWrite);
        for buffer in targets.vertex_input {
            self.use_buffer(buffer, Access::VertexInput);
        }
        self.flush_barriers();
    }

    /// Begins rendering into `targets` (declared with
    /// [`Recorder::declare_targets`]) over their whole extent, into the
    /// depth view `depth_layer` (a layer's view; None: the whole image's),
    /// with the viewport and scissor set to it. The caller ends it with
    /// [`Recorder::end_rendering`].
    pub fn begin_rendering(&mut self, targets: &RenderTargets<'_>, depth_layer: Option<vk::ImageView>) {
        let clear = |value| {
            move |view| {
                vk::RenderingAttachmentInfo::default()
                    .image_view(view)
                    .load_op(vk::AttachmentLoadOp::CLEAR)
                    .store_op(vk::AttachmentStoreOp::STORE)
                    .clear_value(value)
            }
        };
        let black = vk::ClearValue {
            color: vk::ClearColorValue { float32: [0.0; 4] },
        };
        let color_attachments: Vec<_> = targets
            .colors
            .iter()
            .map(|c| clear(black)(c.view).image_layout(vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL))
            .collect();
        let far = vk::ClearValue {
            depth_stencil: vk::ClearDepthStencilValue {
                depth: targets.depth_clear,
                stencil: 0,
            },
        };
        let depth_attachment = clear(far)(depth_layer.unwrap_or(targets.depth.view))
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL);
        let (width, height) = (targets.depth.desc.width, targets.depth.desc.height);
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: vk::Extent2D { width, height },
        };
        let info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .color_attachments(&color_attachments)
            .depth_attachment(&depth_attachment);
        let viewport = vk::Viewport {
            x: 0.0,
            y: 0.0,
            width: width as f32,
            height: height as f32,
            min_depth: 0.0,
            max_depth: 1.0,
        };
        // SAFETY: recording; declare_targets put the attachments in their
        // layouts.
        unsafe {
            self.device.raw.cmd_begin_rendering(self.cmd, &info);
            self.device.raw.cmd_set_viewport(self.cmd, 0, &[viewport]);
            self.device.raw.cmd_set_scissor(self.cmd, 0, &[area]);
        }
    }

    /// Ends the rendering scope [`Recorder::begin_rendering`] began.
    pub fn end_rendering(&mut self) {
        // SAFETY: closes the scope begun on this command buffer.
        unsafe { self.device.raw.cmd_end_rendering(self.cmd) };
    }
}
