//! A scene uploaded to the GPU: every mesh once (object-space vertex and
//! index buffers), the objects' transforms (one buffer per frame slot,
//! rewritten when objects move), materials, and the two texture arrays
//! (colour textures in sRGB, normal maps linear).

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::error::Result;
use crate::gpu_types::{GpuMaterial, GpuObject};
use crate::ray_scene::RayScene;
use crate::scene::{AlphaMode, Scene};
use crate::texture_mips::{self, Texels};
use crate::vk::{Buffer, Device, Image, ImageDesc, Pipeline, Recorder, Sampler, TriangleRange};

/// Largest side of the texture array; bigger textures are downsampled.
const MAX_TEXTURE_SIDE: u32 = 2048;

/// Where a mesh lies in the scene's vertex and index buffers: its opaque
/// triangles' indices first, then its alpha-masked ones'.
#[derive(Clone, Copy, Debug)]
pub struct GpuMesh {
    /// Its first vertex (added to its indices).
    pub vertex_offset: i32,
    /// Its first index.
    pub first_index: u32,
    /// Indices of opaque triangles (from `first_index`).
    pub opaque_count: u32,
    /// Indices of alpha-masked triangles (after the opaque ones).
    pub masked_count: u32,
}

/// Every mesh's vertices and indices in one array each, and where each
/// mesh is: per mesh, opaque triangles first. The shadow pass draws them
/// depth-only (an alpha test in the fragment shader costs rasterizers
/// their fast depth-only path: llvmpipe's shadow pass was 14x slower with
/// it).
fn pack_meshes(scene: &Scene) -> (Vec<crate::scene::Vertex>, Vec<u32>, Vec<GpuMesh>) {
    let (mut vertices, mut indices, mut meshes) = (Vec::new(), Vec::new(), Vec::new());
    for mesh in scene.meshes() {
        let (mut opaque, mut masked) = (Vec::new(), Vec::new());
        for tri in mesh.indices.chunks_exact(3) {
            if masked_material(scene, mesh.vertices[tri[0] as usize].material) {
                masked.extend_from_slice(tri);
            } else {
                opaque.extend_from_slice(tri);
            }
        }
        meshes.push(GpuMesh {
            vertex_offset: vertices.len() as i32,
            first_index: indices.len() as u32,
            opaque_count: opaque.len() as u32,
            masked_count: masked.len() as u32,
        });
        vertices.extend_from_slice(&mesh.vertices);
        indices.extend(opaque);
        indices.extend(masked);
    }
    (vertices, indices, meshes)
}

/// Each texture's layer in an array that holds the `used` ones (-1: not
/// in it).
fn array_layers(used: &[bool]) -> Vec<i32> {
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
}

/// Which array each texture goes to, by how the materials read it.
struct TextureRoles {
    /// Base colour or emission: sRGB.
    as_color: Vec<bool>,
    /// Normal or metallic-roughness map: linear.
    as_linear: Vec<bool>,
    /// A normal map (averaged as unit vectors in its mips, unless it is a
    /// metallic-roughness map too).
    as_normals: Vec<bool>,
    /// A metallic-roughness map.
    as_data: Vec<bool>,
}

impl TextureRoles {
    fn of(scene: &Scene) -> Self {
        let none = vec![false; scene.textures.len()];
        let mut roles = Self {
            as_color: none.clone(),
            as_linear: none.clone(),
            as_normals: none.clone(),
            as_data: none,
        };
        for m in &scene.materials {
            for t in [m.texture, m.emissive_texture.map(|t| t.index)]
                .into_iter()
                .flatten()
            {
                roles.as_color[t] = true;
            }
            for t in [m.normal_texture, m.reflectance_texture()]
                .into_iter()
                .flatten()
            {
                roles.as_linear[t.index] = true;
            }
            if let Some(t) = m.normal_texture {
                roles.as_normals[t.index] = true;
            }
            if let Some(t) = m.reflectance_texture() {
                roles.as_data[t.index] = true;
            }
        }
        roles
    }
}

/// Frames that may be in flight at once: each has its command pool,
/// timestamp queries and resources, and its copy of the objects here.
pub const FRAME_SLOTS: usize = 2;

impl GpuMesh {
    /// Its opaque triangles, for a bottom-level acceleration structure
    /// (`vertex_count`: the mesh's vertices).
    pub fn opaque_triangles(&self, vertex_count: u32) -> TriangleRange {
        TriangleRange {
            first_index: self.first_index,
            triangles: self.opaque_count / 3,
            vertex_offset: self.vertex_offset as u32,
            max_vertex: self.vertex_offset as u32 + vertex_count.saturating_sub(1),
        }
    }
}

/// One indexed draw of a range of a mesh for one object (its index goes in
/// the push block, where the vertex shaders read it).
#[derive(Clone, Copy, Debug)]
pub struct Draw {
    /// First index.
    pub first_index: u32,
    /// Index count.
    pub count: u32,
    /// Added to the indices.
    pub vertex_offset: i32,
    /// The object.
    pub object: u32,
}

/// A scene as one frame slot draws it: its GPU copy and the slot's copy of
/// the objects' transforms.
#[derive(Clone, Copy)]
pub struct SlotScene<'a> {
    /// Meshes, materials, textures.
    pub scene: &'a GpuScene,
    /// `GpuObject` per scene object.
    pub objects: &'a Buffer,
    /// The objects' top-level acceleration structure, where this frame
    /// casts rays (exact visibility, or traced ISM texels).
    pub top_level: Option<&'a crate::vk::AccelerationStructure>,
}

/// GPU copies of a [`Scene`]'s meshes, objects and materials.
pub struct GpuScene {
    /// Object-space vertices of every mesh (`scene::Vertex`).
    pub vertices: Buffer,
    /// Triangle-list indices (u32) of every mesh, local to it.
    pub indices: Buffer,
    /// Each mesh's place in `vertices` and `indices`.
    pub meshes: Vec<GpuMesh>,
    /// Per mesh, its first index and first vertex (`[u32; 2]`), for
    /// kernels that read a ray query's triangle.
    pub mesh_ranges: Buffer,
    /// Per frame slot, `GpuObject` per scene object, and the version of
    /// the objects it holds.
    objects: Vec<(Buffer, u64)>,
    /// The visible objects' draws of opaque triangles, and of alpha-masked
    /// ones (for the objects of [`GpuScene::set_objects`]).
    draws: [Vec<Draw>; 2],
    /// `GpuMaterial` per material.
    pub materials: Buffer,
    /// Base-colour and emissive textures, resized to one size, one layer
    /// each (sRGB), with mipmaps.
    pub color_textures: Image,
    /// Normal maps and metallic-roughness maps, resized to one size, one
    /// layer each (linear), with mipmaps.
    pub linear_textures: Image,
    /// Nearest, clamped sampler (material.glsl filters and wraps by hand).
    pub texture_sampler: Sampler,
    /// Texture data not yet copied into `color_textures` (0) and
    /// `linear_textures` (1): (staging buffer, array).
    pending: Vec<(Buffer, usize)>,
    /// Staging buffers whose copies are recorded in a frame that may not
    /// have been submitted yet (released by the next frame).
    recorded: Vec<Buffer>,
    /// Each mesh's vertex count (the acceleration structures' bounds).
    vertex_counts: Vec<u32>,
    /// Acceleration structures for exact visibility (None: the device has
    /// no ray queries, or the scene needs alpha tests).
    pub rays: Option<RayScene>,
}

impl GpuScene {
    /// Uploads `scene`: meshes and materials at once (host-visible
    /// buffers), textures into staging buffers whose copies the next frame
    /// records ([`GpuScene::record_uploads`]), so nothing waits; objects
    /// per frame slot ([`GpuScene::write_objects`]).
    pub fn upload(device: &Arc<Device>, scene: &Scene, slots: usize) -> Result<Self> {
        let (vertices, indices, meshes) = pack_meshes(scene);
        let rays = RayScene::new(device, scene, slots);
        let input = match rays {
            Some(_) => RayScene::INPUT_USAGE,
            None => vk::BufferUsageFlags::empty(),
        };
        let vertices = Buffer::with_data(
            device,
            "scene.vertices",
            &vertices,
            vk::BufferUsageFlags::VERTEX_BUFFER | input,
        )?;
        let indices = Buffer::with_data(
            device,
            "scene.indices",
            &indices,
            vk::BufferUsageFlags::INDEX_BUFFER | input,
        )?;
        let ranges: Vec<[u32; 2]> = meshes
            .iter()
            .map(|m| [m.first_index, m.vertex_offset as u32])
            .chain(std::iter::once([0, 0]))
            .collect();
        let mesh_ranges = Buffer::with_data(
            device,
            "scene.mesh_ranges",
            &ranges,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let objects = (0..slots)
            .map(|slot| Ok((objects_buffer(device, slot, scene.objects().len())?, 0)))
            .collect::<Result<Vec<_>>>()?;
        let TextureRoles {
            as_color,
            as_linear,
            as_normals,
            as_data,
        } = TextureRoles::of(scene);
        let (color_layer, linear_layer) = (array_layers(&as_color), array_layers(&as_linear));
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
                .map(|(t, _)| (t, Texels::Srgb)),
        )?;
        let (linear_textures, linear_staging) = upload_array(
            device,
            "scene.linear_textures",
            vk::Format::R8G8B8A8_UNORM,
            scene
                .textures
                .iter()
                .enumerate()
                .filter(|&(i, _)| as_linear[i])
                .map(|(i, t)| {
                    let normals = as_normals[i] && !as_data[i];
                    (t, if normals { Texels::Normals } else { Texels::Linear })
                }),
        )?;
        let texture_sampler = Sampler::new(
            device,
            vk::Filter::NEAREST,
            vk::SamplerAddressMode::CLAMP_TO_EDGE,
        )?
        .named("scene.texture_sampler");
        let mut gpu = Self {
            vertices,
            indices,
            meshes,
            mesh_ranges,
            objects,
            draws: Default::default(),
            materials,
            color_textures,
            linear_textures,
            texture_sampler,
            pending: [color_staging, linear_staging]
                .into_iter()
                .enumerate()
                .map(|(i, b)| (b, i))
                .collect(),
            recorded: Vec::new(),
            vertex_counts: scene
                .meshes()
                .iter()
                .map(|m| m.vertices.len() as u32)
                .collect(),
            rays,
        };
        gpu.set_objects(scene);
        Ok(gpu)
    }

    /// Makes the draws of `scene`'s visible objects (after objects moved,
    /// were shown or hidden; the meshes and materials are those uploaded).
    /// An object whose material override is alpha-masked (or opaque) draws
    /// its whole mesh as such.
    pub fn set_objects(&mut self, scene: &Scene) {
        let mut draws: [Vec<Draw>; 2] = Default::default();
        for (i, o) in scene.objects().iter().enumerate() {
            let Some(mesh) = self.meshes.get(o.mesh).filter(|_| o.visible) else {
                continue;
            };
            let draw = |first_index: u32, count: u32| Draw {
                first_index,
                count,
                vertex_offset: mesh.vertex_offset,
                object: i as u32,
            };
            let total = mesh.opaque_count + mesh.masked_count;
            match o.material {
                Some(m) => {
                    draws[masked_material(scene, m) as usize].push(draw(mesh.first_index, total))
                }
                None => {
                    draws[0].push(draw(mesh.first_index, mesh.opaque_count));
                    draws[1].push(draw(
                        mesh.first_index + mesh.opaque_count,
                        mesh.masked_count,
                    ));
                }
            }
        }
        for list in &mut draws {
            list.retain(|d| d.count > 0);
        }
        self.draws = draws;
    }

    /// The visible objects' draws of their opaque triangles (`masked`
    /// false) or alpha-masked ones.
    pub fn draws(&self, masked: bool) -> &[Draw] {
        &self.draws[masked as usize]
    }

    /// Writes `scene`'s objects into frame slot `slot`'s buffer unless it
    /// already holds `version` of them (the slot's previous frame is done);
    /// a buffer too small for objects added since is made anew.
    pub fn write_objects(&mut self, slot: usize, scene: &Scene, version: u64) -> Result<()> {
        let (buffer, held) = &mut self.objects[slot];
        if *held != version {
            let objects: Vec<GpuObject> = scene.objects().iter().map(GpuObject::new).collect();
            let bytes: &[u8] = bytemuck::cast_slice(&objects);
            if bytes.len() as u64 > buffer.size {
                *buffer = objects_buffer(buffer.device(), slot, objects.len())?;
            }
            buffer.write(0, bytes)?;
            *held = version;
        }
        Ok(())
    }

    /// The scene as frame slot `slot` draws it.
    pub fn for_slot(&self, slot: usize) -> SlotScene<'_> {
        SlotScene {
            scene: self,
            objects: &self.objects[slot].0,
            top_level: None,
        }
    }

    /// Records `draws` with `pipeline` (bound, with the vertex and index
    /// buffers), pushing each draw's object at `object_offset` in its push
    /// block.
    pub fn record_draws(
        &self,
        device: &Device,
        cmd: vk::CommandBuffer,
        (pipeline, object_offset): (&Pipeline, u32),
        draws: &[Draw],
    ) {
        for d in draws {
            pipeline.push_at(cmd, object_offset, &d.object.to_ne_bytes());
            // SAFETY: recording inside a rendering scope with the pipeline
            // bound; the range lies inside the index buffer, the object
            // inside the bound objects buffer.
            unsafe {
                device
                    .raw
                    .cmd_draw_indexed(cmd, d.count, 1, d.first_index, d.vertex_offset, 0)
            };
        }
    }

    /// Binds the vertex and index buffers.
    pub fn bind_geometry(&self, device: &Device, cmd: vk::CommandBuffer) {
        // SAFETY: recording; both buffers live as long as the scene.
        unsafe {
            device
                .raw
                .cmd_bind_vertex_buffers(cmd, 0, &[self.vertices.raw], &[0]);
            device
                .raw
                .cmd_bind_index_buffer(cmd, self.indices.raw, 0, vk::IndexType::UINT32);
        }
    }

    /// Records the texture copies still pending and the meshes'
    /// acceleration structures (the first frame after an upload does this
    /// before its passes).
    pub fn record_uploads(&mut self, rec: &mut Recorder<'_>) -> Result<()> {
        for (staging, array) in self.pending.drain(..) {
            let image = if array == 0 {
                &self.color_textures
            } else {
                &self.linear_textures
            };
            rec.copy_buffer_to_mips(&staging, image, 4);
            self.recorded.push(staging);
        }
        if let Some(rays) = &mut self.rays {
            let meshes: Vec<_> = self
                .meshes
                .iter()
                .zip(&self.vertex_counts)
                .map(|(mesh, &vertices)| mesh.opaque_triangles(vertices))
                .collect();
            let inputs = (&self.vertices, &self.indices);
            rays.record_bottom_levels(rec, inputs, &meshes, &mut self.recorded)?;
        }
        Ok(())
    }

    /// Whether texture copies or acceleration structures are still to be
    /// recorded.
    pub fn has_pending_uploads(&self) -> bool {
        !self.pending.is_empty() || self.rays.as_ref().is_some_and(|r| !r.is_built())
    }

    /// Lets the staging buffers go once the frame that copies them has been
    /// submitted (they are then destroyed after that submission finishes).
    pub fn release_staging(&mut self) {
        self.recorded.clear();
    }
}

/// Whether `scene`'s material `m` is alpha-masked (its triangles are drawn
/// with the alpha test).
fn masked_material(scene: &Scene, m: u32) -> bool {
    scene
        .materials
        .get(m as usize)
        .is_some_and(|m| m.alpha != AlphaMode::Opaque)
}

/// Frame slot `slot`'s host-visible buffer for `count` `GpuObject`s.
fn objects_buffer(device: &Arc<Device>, slot: usize, count: usize) -> Result<Buffer> {
    Buffer::new(
        device,
        &format!("frame slot {slot} scene.objects"),
        (count.max(1) * std::mem::size_of::<GpuObject>()) as u64,
        vk::BufferUsageFlags::STORAGE_BUFFER,
        MemoryLocation::CpuToGpu,
    )
}

/// Uploads `textures` as the layers of one array (all resized to the
/// largest size, at most [`MAX_TEXTURE_SIDE`] and halved until the array
/// fits [`texture_mips::ARRAY_BUDGET_BYTES`]; one white texel if none)
/// with their mipmaps (`texture_mips`), each texture with how its texels
/// are averaged. The image and its staging buffer.
type StagedArray = (Image, Buffer);

fn upload_array<'a>(
    device: &Arc<Device>,
    name: &str,
    format: vk::Format,
    textures: impl Iterator<Item = (&'a crate::scene::Texture, Texels)> + Clone,
) -> Result<StagedArray> {
    let (w, h) = textures
        .clone()
        .fold((1, 1), |(w, h), (t, _)| (w.max(t.width), h.max(t.height)));
    let largest = (w.min(MAX_TEXTURE_SIDE), h.min(MAX_TEXTURE_SIDE));
    let count = textures.clone().count() as u32;
    let (w, h) = texture_mips::array_extent(largest, count, texture_mips::ARRAY_BUDGET_BYTES);
    if (w, h) != largest {
        log::info!(
            "{name}: {count} textures at {w}x{h} instead of {}x{} (at most {} MiB with mipmaps)",
            largest.0,
            largest.1,
            texture_mips::ARRAY_BUDGET_BYTES >> 20
        );
    }
    let levels = texture_mips::level_count(w, h);
    // Level by level, every layer of a level together (one copy per level).
    let mut per_level = vec![Vec::new(); levels as usize];
    let mut layers = 0u32;
    for (t, texels) in textures {
        layers += 1;
        let top = texture_mips::resize((t.width, t.height), &t.rgba8, (w, h), texels);
        for (level, texels) in texture_mips::mip_chain(w, h, &top, texels)
            .into_iter()
            .enumerate()
        {
            per_level[level + 1].extend(texels);
        }
        per_level[0].extend(top);
    }
    if layers == 0 {
        layers = 1;
        per_level = vec![vec![255u8; 4]];
    }
    let levels = per_level.len() as u32;
    let texels = per_level.concat();
    let image = Image::new(
        device,
        name,
        ImageDesc {
            format,
            width: w,
            height: h,
            layers,
            mip_levels: levels,
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
    Ok((image, staging))
}
