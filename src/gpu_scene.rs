//! A scene uploaded to the GPU: vertex and index buffers, materials, and the
//! two texture arrays (colour textures in sRGB, normal maps linear).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::Result;
use crate::gpu_types::GpuMaterial;
use crate::scene::{Bounds, Scene};
use crate::vk::{Buffer, Device, Image, ImageDesc, Recorder, Sampler};

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
    /// Texture data not yet copied into `color_textures` (0) and
    /// `linear_textures` (1): (staging buffer, array, extent, layers).
    pending: Vec<(Buffer, usize, (u32, u32), u32)>,
    /// Staging buffers whose copies are recorded in a frame that may not
    /// have been submitted yet (released by the next frame).
    recorded: Vec<Buffer>,
}

impl GpuScene {
    /// Uploads `scene`: geometry and materials at once (host-visible
    /// buffers), textures into staging buffers whose copies the next frame
    /// records ([`GpuScene::record_uploads`]), so nothing waits.
    pub fn upload(device: &Arc<Device>, scene: &Scene) -> Result<Self> {
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
            for t in [m.normal_texture, m.reflectance_texture()]
                .into_iter()
                .flatten()
            {
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
        let (color_textures, color_staging) = upload_array(
            device,
            "scene.color_textures",
            vk::Format::R8G8B8A8_SRGB,
            scene
                .textures
                .iter()
                .zip(&as_color)
                .filter(|(_, &u)| u)
                .map(|(t, _)| t),
        )?;
        let (linear_textures, linear_staging) = upload_array(
            device,
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
            pending: [color_staging, linear_staging]
                .into_iter()
                .enumerate()
                .map(|(i, (b, extent, layers))| (b, i, extent, layers))
                .collect(),
            recorded: Vec::new(),
        })
    }

    /// Records the texture copies still pending (the first frame after an
    /// upload does this before its passes).
    pub fn record_uploads(&mut self, rec: &mut Recorder<'_>) {
        for (staging, array, extent, layers) in self.pending.drain(..) {
            let image = if array == 0 {
                &self.color_textures
            } else {
                &self.linear_textures
            };
            rec.copy_buffer_to_image(&staging, image, extent, layers);
            self.recorded.push(staging);
        }
    }

    /// Whether texture copies are still to be recorded.
    pub fn has_pending_uploads(&self) -> bool {
        !self.pending.is_empty()
    }

    /// Lets the staging buffers go once the frame that copies them has been
    /// submitted (they are then destroyed after that submission finishes).
    pub fn release_staging(&mut self) {
        self.recorded.clear();
    }
}

/// Uploads `textures` as the layers of one array (all resized to the
/// largest size, at most [`MAX_TEXTURE_SIDE`]; one white texel if none).
/// The image and its staging buffer, extent and layer count.
type StagedArray = (Image, (Buffer, (u32, u32), u32));

fn upload_array<'a>(
    device: &Arc<Device>,
    name: &str,
    format: vk::Format,
    textures: impl Iterator<Item = &'a crate::scene::Texture> + Clone,
) -> Result<StagedArray> {
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
    Ok((image, (staging, (w, h), layers)))
}
