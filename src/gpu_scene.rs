//! A scene uploaded to the GPU: vertex and index buffers, materials, and the
//! two texture arrays (colour textures in sRGB, normal maps linear).

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
    /// Indices before this one are triangles of opaque materials (drawn
    /// without an alpha test); alpha-masked ones follow.
    pub masked_index_start: u32,
    /// `GpuMaterial` per material.
    pub materials: Buffer,
    /// Base-colour and emissive textures, resized to one size, one layer each (sRGB).
    pub color_textures: Image,
    /// Normal maps, resized to one size, one layer each (linear).
    pub linear_textures: Image,
    /// Nearest, clamped sampler (material.glsl filters and wraps by hand).
    pub texture_sampler: Sampler,
    /// Scene bounds.
    pub bounds: Bounds,
}

impl GpuScene {
    /// Uploads `scene` (waits for the texture copy to finish).
    pub fn upload(device: &Arc<Device>, pool: &mut CommandPool, scene: &Scene) -> Result<Self> {
        let vertices = Buffer::with_data(
            device,
            "scene.vertices",
            &scene.vertices,
            vk::BufferUsageFlags::VERTEX_BUFFER,
        )?;
        // Opaque triangles first: the shadow pass draws them depth-only (an
        // alpha test in the fragment shader costs rasterizers their fast
        // depth-only path: llvmpipe's shadow pass was 14x slower with it).
        let masked = |tri: &[u32]| {
            let material = scene.vertices[tri[0] as usize].material as usize;
            scene
                .materials
                .get(material)
                .is_some_and(|m| m.alpha != crate::scene::AlphaMode::Opaque)
        };
        let (mut ordered, mut masked_tris) = (Vec::new(), Vec::new());
        for tri in scene.indices.chunks_exact(3) {
            if masked(tri) {
                masked_tris.extend_from_slice(tri);
            } else {
                ordered.extend_from_slice(tri);
            }
        }
        let masked_index_start = ordered.len() as u32;
        ordered.extend(masked_tris);
        let indices = Buffer::with_data(
            device,
            "scene.indices",
            &ordered,
            vk::BufferUsageFlags::INDEX_BUFFER,
        )?;
        // Which textures go to which array.
        let mut as_color = vec![false; scene.textures.len()];
        let mut as_linear = vec![false; scene.textures.len()];
        for m in &scene.materials {
            for t in [m.texture, m.emissive_texture.map(|t| t.index)]
                .into_iter()
                .flatten()
            {
                as_color[t] = true;
            }
            if let Some(t) = m.normal_texture {
                as_linear[t.index] = true;
            }
        }
        let layers = |used: &[bool]| -> Vec<i32> {
            let mut next = 0;
            used.iter()
                .map(|&u| {
                    if u {
                        next += 1;
                        next - 1
                    } else {
                        -1
                    }
                })
                .collect()
        };
        let (color_layer, linear_layer) = (layers(&as_color), layers(&as_linear));
        let mats: Vec<GpuMaterial> = scene
            .materials
            .iter()
            .map(|m| GpuMaterial::new(m, &color_layer, &linear_layer))
            .collect();
        let materials = Buffer::with_data(
            device,
            "scene.materials",
            &mats,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let color_textures = upload_array(
            device,
            pool,
            "scene.color_textures",
            vk::Format::R8G8B8A8_SRGB,
            scene
                .textures
                .iter()
                .zip(&as_color)
                .filter(|(_, &u)| u)
                .map(|(t, _)| t),
        )?;
        let linear_textures = upload_array(
            device,
            pool,
            "scene.linear_textures",
            vk::Format::R8G8B8A8_UNORM,
            scene
                .textures
                .iter()
                .zip(&as_linear)
                .filter(|(_, &u)| u)
                .map(|(t, _)| t),
        )?;
        let texture_sampler = Sampler::new(
            device,
            vk::Filter::NEAREST,
            vk::SamplerAddressMode::CLAMP_TO_EDGE,
        )?
        .named("scene.texture_sampler");
        Ok(Self {
            vertices,
            indices,
            index_count: scene.indices.len() as u32,
            masked_index_start,
            materials,
            color_textures,
            linear_textures,
            texture_sampler,
            bounds: scene.bounds(),
        })
    }
}

/// Uploads `textures` as the layers of one array (all resized to the
/// largest size, at most [`MAX_TEXTURE_SIDE`]; one white texel if none).
fn upload_array<'a>(
    device: &Arc<Device>,
    pool: &mut CommandPool,
    name: &str,
    format: vk::Format,
    textures: impl Iterator<Item = &'a crate::scene::Texture> + Clone,
) -> Result<Image> {
    let (w, h) = textures
        .clone()
        .fold((1, 1), |(w, h), t| (w.max(t.width), h.max(t.height)));
    let (w, h) = (w.min(MAX_TEXTURE_SIDE), h.min(MAX_TEXTURE_SIDE));
    let mut texels = Vec::new();
    let mut layers = 0u32;
    for t in textures {
        layers += 1;
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
    if layers == 0 {
        layers = 1;
        texels.extend([255u8; 4]);
    }
    let image = Image::new(
        device,
        name,
        ImageDesc {
            format,
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
        "scene.texture_staging",
        texels.len() as u64,
        vk::BufferUsageFlags::TRANSFER_SRC,
        MemoryLocation::CpuToGpu,
    )?;
    staging.write(0, &texels)?;
    let mut rec = pool.begin()?;
    rec.copy_buffer_to_image(&staging, &image, (w, h), layers);
    let done = rec.submit()?;
    device.wait(done)?;
    Ok(image)
}
