//! Descriptor set layouts, pools and writes, by hand.
//!
//! Each pass owns one [`DescriptorSetLayout`]. A frame creates one
//! [`DescriptorPool`] sized exactly for the sets its passes allocate; the pool
//! (and with it the sets) is dropped with the frame.

use std::sync::Arc;

use ash::vk;

use super::acceleration::AccelerationStructure;
use super::buffer::Buffer;
use super::buffer_view::BufferView;
use super::device::{Device, Garbage};
use super::image::{Image, Sampler};
use super::shader::{BindingInfo, Shader};
use crate::error::{Error, Result, VkResultExt};

/// A descriptor set layout: its bindings' numbers and types, visible to
/// every stage of the pipeline.
pub struct DescriptorSetLayout {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::DescriptorSetLayout,
    /// Binding numbers and types.
    pub bindings: Vec<(u32, vk::DescriptorType)>,
}

impl DescriptorSetLayout {
    /// The union of `shaders`' bindings (as reflected by build.rs); a
    /// binding two of them declare differently is an error naming it.
    pub fn for_shaders(device: &Arc<Device>, shaders: &[&Shader]) -> Result<Self> {
        let mut bindings: Vec<(u32, vk::DescriptorType)> = Vec::new();
        for shader in shaders {
            for &BindingInfo {
                number, ty, name, ..
            } in shader.bindings
            {
                match bindings.iter().find(|(n, _)| *n == number) {
                    Some((_, t)) if *t != ty => {
                        return Err(Error::InvalidParameter(format!(
                            "internal: binding {number} ('{name}' in shaders/{}) has two types",
                            shader.name
                        )))
                    }
                    Some(_) => {}
                    None => bindings.push((number, ty)),
                }
            }
        }
        bindings.sort_by_key(|b| b.0);
        let stages = vk::ShaderStageFlags::COMPUTE
            | vk::ShaderStageFlags::VERTEX
            | vk::ShaderStageFlags::FRAGMENT;
        let raw_bindings: Vec<_> = bindings
            .iter()
            .map(|&(number, ty)| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(number)
                    .descriptor_type(ty)
                    .descriptor_count(1)
                    .stage_flags(stages)
            })
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&raw_bindings);
        // SAFETY: valid create info.
        let raw = unsafe { device.raw.create_descriptor_set_layout(&info, None) }
            .vk("vkCreateDescriptorSetLayout")?;
        Ok(Self {
            device: device.clone(),
            raw,
            bindings,
        })
    }

    /// Names the layout (see [`Device::set_name`]).
    pub fn name(&self, name: &str) {
        self.device.set_name(self.raw, name);
    }

    /// The descriptor type of each of `bindings`, which must be exactly
    /// this layout's.
    fn types_of(&self, bindings: &[(u32, Binding<'_>)]) -> Result<Vec<vk::DescriptorType>> {
        if bindings.len() != self.bindings.len() {
            return Err(Error::InvalidParameter(format!(
                "internal: {} of the set layout's {} bindings given",
                bindings.len(),
                self.bindings.len()
            )));
        }
        bindings
            .iter()
            .map(|(number, _)| {
                let ty = self.bindings.iter().find(|(n, _)| n == number);
                ty.map(|(_, t)| *t).ok_or_else(|| {
                    Error::InvalidParameter(format!(
                        "internal: binding {number} is not in the set layout"
                    ))
                })
            })
            .collect()
    }
}

impl Drop for DescriptorSetLayout {
    fn drop(&mut self) {
        self.device
            .defer_destroy(Garbage::DescriptorSetLayout(self.raw));
    }
}

/// A pool for the descriptor sets of one frame.
pub struct DescriptorPool {
    device: Arc<Device>,
    raw: vk::DescriptorPool,
}

impl DescriptorPool {
    /// Names the pool (see [`Device::set_name`]).
    pub fn name(&self, name: &str) {
        self.device.set_name(self.raw, name);
    }

    /// A pool with room for one set of each of `layouts` (list a layout
    /// twice for two sets).
    pub fn new(device: &Arc<Device>, layouts: &[&DescriptorSetLayout]) -> Result<Self> {
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for &(_, t) in layouts.iter().flat_map(|l| l.bindings.iter()) {
            match sizes.iter_mut().find(|s| s.ty == t) {
                Some(s) => s.descriptor_count += 1,
                None => sizes.push(vk::DescriptorPoolSize {
                    ty: t,
                    descriptor_count: 1,
                }),
            }
        }
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(layouts.len().max(1) as u32)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let raw = unsafe { device.raw.create_descriptor_pool(&info, None) }
            .vk("vkCreateDescriptorPool")?;
        device.count_resource();
        Ok(Self {
            device: device.clone(),
            raw,
        })
    }

    /// Frees every set allocated from the pool (the sets' last use must be
    /// done: a frame slot resets its pool after waiting for its previous frame).
    pub fn reset(&self) -> Result<()> {
        // SAFETY: no set of this pool is in use by pending work (see above).
        unsafe {
            self.device
                .raw
                .reset_descriptor_pool(self.raw, vk::DescriptorPoolResetFlags::empty())
        }
        .vk("vkResetDescriptorPool")
    }

    /// Allocates one set of `layout` and writes `bindings` (binding number
    /// and resource, one for each of the layout's bindings: what the
    /// generated `Bindings` structs give).
    pub fn allocate(
        &self,
        layout: &DescriptorSetLayout,
        bindings: &[(u32, Binding<'_>)],
    ) -> Result<vk::DescriptorSet> {
        let types = layout.types_of(bindings)?;
        let layouts = [layout.raw];
        let info = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(self.raw)
            .set_layouts(&layouts);
        // SAFETY: the pool was sized for this layout.
        let set = unsafe { self.device.raw.allocate_descriptor_sets(&info) }
            .vk("vkAllocateDescriptorSets")?[0];

        // Infos first (the writes point into these vectors).
        let image_infos: Vec<vk::DescriptorImageInfo> = bindings
            .iter()
            .map(|(_, b)| match *b {
                Binding::StorageImage(image) => vk::DescriptorImageInfo::default()
                    .image_view(image.view)
                    .image_layout(vk::ImageLayout::GENERAL),
                Binding::SampledImage(image, sampler) => vk::DescriptorImageInfo::default()
                    .image_view(image.view)
                    .sampler(sampler.raw)
                    .image_layout(vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL),
                _ => vk::DescriptorImageInfo::default(),
            })
            .collect();
        let buffer_infos: Vec<vk::DescriptorBufferInfo> = bindings
            .iter()
            .map(|(_, b)| match *b {
                Binding::StorageBuffer(buf) | Binding::UniformBuffer(buf) => {
                    vk::DescriptorBufferInfo::default()
                        .buffer(buf.raw)
                        .offset(0)
                        .range(vk::WHOLE_SIZE)
                }
                _ => vk::DescriptorBufferInfo::default(),
            })
            .collect();
        let structures: Vec<[vk::AccelerationStructureKHR; 1]> = bindings
            .iter()
            .map(|(_, b)| match *b {
                Binding::AccelerationStructure(a) => [a.raw],
                _ => [vk::AccelerationStructureKHR::null()],
            })
            .collect();
        let mut structure_writes: Vec<vk::WriteDescriptorSetAccelerationStructureKHR> =
            structures
                .iter()
                .map(|a| vk::WriteDescriptorSetAccelerationStructureKHR::default().acceleration_structures(a))
                .collect();
        let mut writes = Vec::with_capacity(bindings.len());
        for (i, ((number, b), structure)) in bindings.iter().zip(&mut structure_writes).enumerate() {
            let w = vk::WriteDescriptorSet::default()
                .dst_set(set)
                .dst_binding(*number)
                .descriptor_type(types[i]);
            writes.push(match b {
                Binding::StorageImage(_) | Binding::SampledImage(..) => {
                    w.image_info(std::slice::from_ref(&image_infos[i]))
                }
                Binding::StorageBuffer(_) | Binding::UniformBuffer(_) => {
                    w.buffer_info(std::slice::from_ref(&buffer_infos[i]))
                }
                Binding::UniformTexelBuffer(view) | Binding::StorageTexelBuffer(view) => {
                    w.texel_buffer_view(std::slice::from_ref(&view.raw))
                }
                // The structure goes in the write's chain; nothing else
                // says how many there are.
                Binding::AccelerationStructure(_) => {
                    let mut w = w.push_next(structure);
                    w.descriptor_count = 1;
                    w
                }
            });
        }
        // SAFETY: the set is not in use by any command buffer yet.
        unsafe { self.device.raw.update_descriptor_sets(&writes, &[]) };
        Ok(set)
    }
}

impl Drop for DescriptorPool {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::DescriptorPool(self.raw));
    }
}

/// The resource for one binding.
#[derive(Clone, Copy)]
pub enum Binding<'a> {
    /// A storage image's full view (GENERAL layout).
    StorageImage(&'a Image),
    /// A sampled image's full view with its sampler (SHADER_READ_ONLY layout).
    SampledImage(&'a Image, &'a Sampler),
    /// A whole storage buffer.
    StorageBuffer(&'a Buffer),
    /// A whole uniform buffer.
    UniformBuffer(&'a Buffer),
    /// A buffer read as texels (`textureBuffer`).
    UniformTexelBuffer(&'a BufferView),
    /// A buffer read and written as texels (`imageBuffer`).
    StorageTexelBuffer(&'a BufferView),
    /// A top-level acceleration structure (`accelerationStructureEXT`).
    AccelerationStructure(&'a AccelerationStructure),
}

impl<'a> Binding<'a> {
    /// The full view of `image` as storage.
    pub fn storage(image: &'a Image) -> Self {
        Binding::StorageImage(image)
    }
    /// The full view of `image`, sampled with `sampler`.
    pub fn sampled(image: &'a Image, sampler: &'a Sampler) -> Self {
        Binding::SampledImage(image, sampler)
    }

    /// The resource whose last access the barriers track (a texel view's
    /// buffer, an acceleration structure's).
    pub fn tracked(self) -> Tracked<'a> {
        match self {
            Binding::StorageImage(image) | Binding::SampledImage(image, _) => Tracked::Image(image),
            Binding::StorageBuffer(buffer) | Binding::UniformBuffer(buffer) => {
                Tracked::Buffer(buffer)
            }
            Binding::UniformTexelBuffer(view) | Binding::StorageTexelBuffer(view) => {
                Tracked::Buffer(&view.buffer)
            }
            Binding::AccelerationStructure(structure) => Tracked::Buffer(&structure.buffer),
        }
    }
}

/// A resource with tracked last access.
#[derive(Clone, Copy)]
pub enum Tracked<'a> {
    /// An image.
    Image(&'a Image),
    /// A buffer.
    Buffer(&'a Buffer),
}

impl Tracked<'_> {
    /// Whether both are the same resource.
    pub fn same(&self, other: &Tracked<'_>) -> bool {
        match (self, other) {
            (Tracked::Image(a), Tracked::Image(b)) => a.raw == b.raw,
            (Tracked::Buffer(a), Tracked::Buffer(b)) => a.raw == b.raw,
            _ => false,
        }
    }
}
