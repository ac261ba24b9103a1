//! A scene uploaded to the GPU: vertex and index buffers, materials, the
//! base-colour texture array, and lights.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::Result;
use crate::gpu_types::GpuMaterial;
use crate::scene::{Bounds, Scene};
use crate::vk::{Buffer, CommandPool, Device, Image, ImageDesc, Sampler};

/// Largest side of the texture array; bigger textures are downsampled.
const MAX_TEXTURE_SIDE: u32 = 2048;

/// GPU copies of a [`Scene`]'s geometry and materials.
pub struct GpuScene {
    /// World-space vertices (`scene::Vertex`).
    pub vertices: Buffer,
    /// Triangle-list indices (u32).
    pub indices: Buffer,
    /// Number of indices.
    pub index_count: u32,
    /// `GpuMaterial` per material.
    pub materials: Buffer,
    /// All base-colour textures, resized to one size, one layer each (sRGB).
    pub textures: Image,
    /// Bilinear, repeating sampler for `textures`.
    pub texture_sampler: Sampler,
    /// Scene bounds.
    pub bounds: Bounds,
}

impl GpuScene {
    /// Uploads `scene` (waits for the texture copy to finish).
    pub fn upload(device: &Arc<Device>, pool: &mut CommandPool, scene: &Scene) -> Result<Self> {
        let vertices = Buffer::with_data(
            device,
            "vertices",
            &scene.vertices,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        let indices = Buffer::with_data(
            device,
            "indices",
            &scene.indices,
            vk::BufferUsageFlags::INDEX_BUFFER,
        )?;
        let mats: Vec<GpuMaterial> = scene.materials.iter().map(GpuMaterial::new).collect();
        let materials = Buffer::with_data(
            device,
            "materials",
            &mats,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;

        // One array layer per texture, all resized to the largest size.
        let (w, h) = scene
            .textures
            .iter()
            .fold((1, 1), |(w, h), t| (w.max(t.width), h.max(t.height)));
        let (w, h) = (w.min(MAX_TEXTURE_SIDE), h.min(MAX_TEXTURE_SIDE));
        let layers = scene.textures.len().max(1) as u32;
        let mut texels = Vec::with_capacity((w * h * 4 * layers) as usize);
        if scene.textures.is_empty() {
            texels.extend([255u8; 4]);
        }
        for t in &scene.textures {
            if (t.width, t.height) == (w, h) {
                texels.extend_from_slice(&t.rgba8);
            } else {
                let img = image::RgbaImage::from_raw(t.width, t.height, t.rgba8.clone())
                    .expect("texture size matches its data");
                let resized =
                    image::imageops::resize(&img, w, h, image::imageops::FilterType::Triangle);
                texels.extend_from_slice(resized.as_raw());
            }
        }
        let textures = Image::new(
            device,
            "base_color_textures",
            ImageDesc {
                format: vk::Format::R8G8B8A8_SRGB,
                width: w,
                height: h,
                layers,
                mip_levels: 1,
                usage: vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST,
                array: true,
            },
        )?;
        let staging = Buffer::new(
            device,
            "texture_staging",
            texels.len() as u64,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, &texels)?;
        let mut rec = pool.begin()?;
        rec.copy_buffer_to_image(&staging, &textures, (w, h), layers);
        let done = rec.submit()?;
        device.wait(done)?;

        let texture_sampler =
            Sampler::new(device, vk::Filter::LINEAR, vk::SamplerAddressMode::REPEAT)?;
        Ok(Self {
            vertices,
            indices,
            index_count: scene.indices.len() as u32,
            materials,
            textures,
            texture_sampler,
            bounds: scene.bounds(),
        })
    }
}
