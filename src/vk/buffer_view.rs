//! Texel views of buffers (`VkBufferView`): a buffer read as an array of
//! formatted texels through `texelFetch` on a `textureBuffer` (GL_EXT_samplerless_texture_functions).
//!
//! Why SSBC uses them: a traversal reads pyramid texels at addresses that
//! differ per invocation. A storage-buffer load of a `vec4` costs lavapipe a
//! branchy per-lane loop for every 32-bit component, while a texel fetch of a
//! whole `R32G32B32A32` texel is one vectorised gather. Real GPUs read both
//! through their caches; the texel path costs them nothing.

use std::sync::Arc;

use ash::vk;

use super::buffer::Buffer;
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// A buffer with a view of all of it as texels of one format. The buffer
/// must have been created with texel-buffer usage; the view owns it, so
/// that barriers reach it through the view (both are destroyed through the
/// same deferred queue, the view first).
pub struct BufferView {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::BufferView,
    /// The buffer viewed.
    pub buffer: Buffer,
}

impl BufferView {
    /// Views all of `buffer` as `format` texels of `texel_bytes` bytes each;
    /// fails if that is more texels than the device allows
    /// (`maxTexelBufferElements`).
    pub fn new(
        device: &Arc<Device>,
        buffer: Buffer,
        format: vk::Format,
        texel_bytes: u64,
        name: &str,
    ) -> Result<Self> {
        let texels = buffer.size / texel_bytes;
        let max = device.limits().max_texel_buffer_elements as u64;
        if texels > max {
            return Err(Error::InvalidParameter(format!(
                "{name} needs {texels} texels; this device views at most {max} \
                 (maxTexelBufferElements): render smaller"
            )));
        }
        let info = vk::BufferViewCreateInfo::default()
            .buffer(buffer.raw)
            .format(format)
            .offset(0)
            .range(texels * texel_bytes);
        // SAFETY: `buffer` is live, has texel-buffer usage (caller) and the
        // range lies inside it.
        let raw = unsafe { device.raw.create_buffer_view(&info, None) }.vk("vkCreateBufferView")?;
        device.set_name(raw, name);
        Ok(Self {
            device: device.clone(),
            raw,
            buffer,
        })
    }
}

impl Drop for BufferView {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::BufferView(self.raw));
    }
}
