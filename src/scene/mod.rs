//! The renderer's scene: world-space triangles, glTF metallic-roughness
//! materials (with emission, alpha masks and normal maps), punctual lights
//! in radiometric units, and cameras. No Vulkan here.
//!
//! Scenes come from glTF ([`load`], [`load_gltf_bytes`]), from the built-in generators
//! ([`builtin`]), or from a host engine's own data through [`Scene::add_mesh`]
//! and the public fields.

mod animation;
mod deform;
pub use animation::NodeAnimation;
pub mod builtin;
mod camera;
mod light;
mod material;
mod objects;
mod tangents;
unstable_pub! {
    mod gltf_loader;
}

use glam::{Affine2, Mat3, Mat4, Vec2, Vec3, Vec4};

use crate::error::{Error, Result};
pub use camera::{Camera, Perspective, DEFAULT_ASPECT};
pub use light::{Light, LightKind};
pub use material::{AlphaMode, Material, Reflectance, Texture, TextureRef, TextureSampler, Wrap};
pub use objects::{Instance, Instances, Mesh, Object, Placement};
use tangents::{handedness, triangle_tangent, vertex_tangents};

/// One vertex of a [`Mesh`] in object space, as uploaded to the GPU (60
/// bytes); [`Scene::triangle`] gives them in world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Vertex {
    /// Position (m).
    pub position: [f32; 3],
    /// Unit normal.
    pub normal: [f32; 3],
    /// Texture coordinate (every texture of the material uses this set; a
    /// glTF material's `texCoord` set and `KHR_texture_transform` applied).
    pub uv: [f32; 2],
    /// Index into [`Scene::materials`].
    pub material: u32,
    /// Unit tangent (xyz, along +u) and the handedness of the
    /// bitangent (w = ±1), for normal maps; zero without one.
    pub tangent: [f32; 4],
    /// Linear RGBA that multiplies the material's base colour and alpha
    /// (glTF's `COLOR_0`), as 16-bit unsigned normalized integers; white
    /// without one ([`Vertex::WHITE`]).
    pub color: [u16; 4],
}

impl Vertex {
    /// The colour of a vertex without one: white, opaque.
    pub const WHITE: [u16; 4] = [u16::MAX; 4];

    /// [`Vertex::color`] as floats in [0, 1].
    pub fn color(&self) -> Vec4 {
        Vec4::from(self.color.map(|c| c as f32 / u16::MAX as f32))
    }
}

impl Default for Vertex {
    /// Every attribute zero, the colour white.
    fn default() -> Self {
        Self {
            color: Self::WHITE,
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

/// A mesh's vertex attributes (object space) and triangles, for
/// [`Scene::new_mesh`]. Every slice but `positions` and `indices` may be
/// empty: flat normals are then computed, uvs are zero, tangents are
/// generated when the material has a normal map, colours are white.
#[derive(Clone, Copy, Debug, Default)]
pub struct MeshData<'a> {
    /// Vertex positions (m).
    pub positions: &'a [Vec3],
    /// Vertex normals.
    pub normals: &'a [Vec3],
    /// Texture coordinates.
    pub uvs: &'a [[f32; 2]],
    /// Tangents: xyz along +u, w the bitangent's handedness (glTF's
    /// TANGENT).
    pub tangents: &'a [Vec4],
    /// Linear RGBA in [0, 1] multiplying the base colour (glTF's COLOR_0).
    pub colors: &'a [Vec4],
    /// Three vertex indices a triangle, counter-clockwise seen from its
    /// front.
    pub indices: &'a [u32],
}

/// Axis-aligned bounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Bounds {
    /// Centre.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    /// Radius of the bounding sphere around the centre.
    pub fn radius(&self) -> f32 {
        (self.max - self.min).length() * 0.5
    }
    /// These bounds grown to hold `p`.
    pub fn including(self, p: Vec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }
    /// The union of both.
    pub fn union(self, other: Self) -> Self {
        self.including(other.min).including(other.max)
    }
    /// The bounds of these bounds' 8 corners moved by `transform`.
    pub fn transformed(&self, transform: Mat4) -> Self {
        let corner = |i: u32| {
            let pick = |bit: u32, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
            transform.transform_point3(Vec3::new(
                pick(1, self.min.x, self.max.x),
                pick(2, self.min.y, self.max.y),
                pick(4, self.min.z, self.max.z),
            ))
        };
        let first = corner(0);
        (1..8).fold(
            Self {
                min: first,
                max: first,
            },
            |b, i| b.including(corner(i)),
        )
    }
}

/// A scene ready to render: meshes (object space, each stored once) drawn by
/// objects (transforms, material overrides, visibility), materials,
/// textures, lights and cameras.
///
/// Meshes and objects change through methods (the scene keeps an index of
/// its visible objects' triangles, [`Scene::instances`], in step with them).
#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// Name for logs (file name or built-in name).
    pub name: String,
    meshes: Vec<Mesh>,
    objects: Vec<Object>,
    /// Materials; `Vertex::material` and `Object::material` index this.
    pub materials: Vec<Material>,
    /// Base-colour textures.
    pub textures: Vec<Texture>,
    /// Punctual lights.
    pub lights: Vec<Light>,
    /// Cameras in document order (the first is used unless asked otherwise).
    pub cameras: Vec<Camera>,
    /// The last keyframe time of the glTF file's first animation (seconds;
    /// None without one), from its accessors' declared maxima: how long
    /// [`load_at`] has poses to show.
    pub animation_end: Option<f32>,
    /// The visible objects numbered by triangle (made on first use after a
    /// change).
    instances: std::sync::OnceLock<Instances>,
    /// The glTF file's first animation, for posing objects later.
    animation: Option<std::sync::Arc<NodeAnimation>>,
}

/// Maximum number of triangles a scene may hold in the world, every
/// object counted (keeps hostile files bounded).
pub const MAX_TRIANGLES: usize = 1 << 24;

impl Scene {
    /// An empty scene.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            ..Default::default()
        }
    }

    /// Adds a two-sided, opaque, non-emissive material and returns its index.
    pub fn add_material(&mut self, base_color: Vec3, texture: Option<usize>) -> u32 {
        self.materials.push(Material::diffuse(base_color, texture));
        (self.materials.len() - 1) as u32
    }

    /// Keeps `animation` for [`Scene::pose`].
    pub(crate) fn set_animation(&mut self, animation: NodeAnimation) {
        self.animation = Some(std::sync::Arc::new(animation));
    }

    /// Where the file's first animation puts each object that came from a
    /// glTF node at time `t` (seconds, clamped to its keyframes), without
    /// reading the file again: (object, transform), the transform None
    /// where the node is scaled to nothing (hidden). Empty without an
    /// animation. Lights and cameras are not posed.
    pub fn pose(&self, t: f32) -> Vec<(usize, Option<Mat4>)> {
        let Some(animation) = &self.animation else {
            return Vec::new();
        };
        let world = animation.node_transforms(t);
        self.objects
            .iter()
            .enumerate()
            .filter_map(|(i, o)| {
                let m = *world.get(&o.node?)?;
                Some((i, (!animation::collapses(&m)).then_some(m)))
            })
            .collect()
    }

    /// The meshes (object space).
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// The objects.
    pub fn objects(&self) -> &[Object] {
        &self.objects
    }

    /// Mesh `index` to change in place (hosts that deform a mesh; every
    /// object drawing it changes).
    pub fn mesh_mut(&mut self, index: usize) -> Result<&mut Mesh> {
        self.instances = Default::default();
        let count = self.meshes.len();
        self.meshes
            .get_mut(index)
            .ok_or_else(|| out_of_range("mesh", index, count))
    }

    /// Adds a mesh drawn once: the mesh (given in object space) and an
    /// object placing it with `transform`. `normals` may be empty (flat
    /// normals are computed), `uvs` may be empty. Tangents are generated if
    /// the material has a normal map. Returns the object's index.
    pub fn add_mesh(
        &mut self,
        positions: &[Vec3],
        normals: &[Vec3],
        uvs: &[[f32; 2]],
        indices: &[u32],
        transform: Mat4,
        material: u32,
    ) -> Result<usize> {
        let mesh = self.new_mesh(
            MeshData {
                positions,
                normals,
                uvs,
                indices,
                ..Default::default()
            },
            material,
        )?;
        self.add_object(Object::new(mesh, transform))
    }

    /// Checks a mesh's data against itself and its material (which it
    /// returns).
    fn check_mesh(&self, data: &MeshData, material: u32) -> Result<&Material> {
        let bad = |m: &str| Err(Error::scene(&self.name, m));
        if data.indices.len() % 3 != 0 {
            return bad("index count is not a multiple of 3");
        }
        if !data.normals.is_empty() && data.normals.len() != data.positions.len()
            || !data.uvs.is_empty() && data.uvs.len() != data.positions.len()
            || !data.tangents.is_empty() && data.tangents.len() != data.positions.len()
            || !data.colors.is_empty() && data.colors.len() != data.positions.len()
        {
            return bad("attribute counts differ from the position count");
        }
        if data
            .colors
            .iter()
            .any(|c| !(c.cmpge(Vec4::ZERO) & c.cmple(Vec4::ONE)).all())
        {
            return bad("a vertex colour is outside [0, 1]");
        }
        if let Some(&i) = data
            .indices
            .iter()
            .find(|&&i| i as usize >= data.positions.len())
        {
            return bad(&format!(
                "index {i} out of range ({} vertices)",
                data.positions.len()
            ));
        }
        let Some(mat) = self.materials.get(material as usize) else {
            return bad(&format!("material {material} does not exist"));
        };
        if data.indices.len() / 3 > MAX_TRIANGLES {
            return bad(&format!("more than {MAX_TRIANGLES} triangles"));
        }
        Ok(mat)
    }

    /// Adds a mesh in object space that objects can then draw
    /// ([`Scene::add_object`]); returns its index.
    pub fn new_mesh(&mut self, data: MeshData, material: u32) -> Result<usize> {
        let normal_texture = self.check_mesh(&data, material)?.normal_texture;
        let MeshData {
            positions,
            normals,
            uvs,
            tangents,
            colors,
            indices,
        } = data;
        let wants_tangents = normal_texture.is_some();
        // Tangents are generated along the normal map's own u and v.
        let normal_map_uv = normal_texture.map_or(Affine2::IDENTITY, |t| t.uv);
        let mapped_uvs: Vec<[f32; 2]> = if normal_map_uv == Affine2::IDENTITY {
            Vec::new()
        } else {
            uvs.iter()
                .map(|&uv| normal_map_uv.transform_point2(Vec2::from(uv)).into())
                .collect()
        };
        let tangent_uvs = if mapped_uvs.is_empty() {
            uvs
        } else {
            &mapped_uvs
        };
        let uv = |i: usize| uvs.get(i).copied().unwrap_or([0.0; 2]);
        let tangent_uv = |i: usize| tangent_uvs.get(i).copied().unwrap_or([0.0; 2]);
        let color = |i: usize| {
            colors
                .get(i)
                .map(|c| c.to_array().map(|v| (v * u16::MAX as f32).round() as u16))
                .unwrap_or(Vertex::WHITE)
        };
        let mut mesh = Mesh::default();
        if normals.is_empty() {
            // Flat normals: unshare vertices, one normal per triangle (the
            // front face is counter-clockwise in object space).
            for tri in indices.chunks_exact(3) {
                let p = [0, 1, 2].map(|k| positions[tri[k] as usize]);
                let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
                let uvt = [
                    uv(tri[0] as usize),
                    uv(tri[1] as usize),
                    uv(tri[2] as usize),
                ];
                let generated = if wants_tangents && tangents.is_empty() {
                    triangle_tangent(&p, &[0, 1, 2].map(|k| tangent_uv(tri[k] as usize)), n)
                } else {
                    Vec4::ZERO
                };
                let base = mesh.vertices.len() as u32;
                for (k, &i) in tri.iter().enumerate() {
                    mesh.vertices.push(Vertex {
                        position: p[k].into(),
                        normal: n.into(),
                        uv: uvt[k],
                        material,
                        tangent: tangents
                            .get(i as usize)
                            .copied()
                            .unwrap_or(generated)
                            .into(),
                        color: color(i as usize),
                    });
                }
                mesh.indices.extend([base, base + 1, base + 2]);
            }
        } else {
            let normals: Vec<Vec3> = normals.iter().map(|n| n.normalize_or_zero()).collect();
            let vertex_tangents: Vec<Vec4> = if !tangents.is_empty() {
                tangents.to_vec()
            } else if wants_tangents {
                vertex_tangents(positions, &normals, tangent_uvs, indices)
            } else {
                vec![Vec4::ZERO; positions.len()]
            };
            mesh.vertices = (0..positions.len())
                .map(|i| Vertex {
                    position: positions[i].into(),
                    normal: normals[i].into(),
                    uv: uv(i),
                    material,
                    tangent: vertex_tangents[i].into(),
                    color: color(i),
                })
                .collect();
            mesh.indices = indices.to_vec();
        }
        self.meshes.push(mesh);
        Ok(self.meshes.len() - 1)
    }

    /// Adds `object` and returns its index; its mesh and material must
    /// exist, its transform be finite and invertible, and the world stay
    /// within [`MAX_TRIANGLES`].
    pub fn add_object(&mut self, object: Object) -> Result<usize> {
        self.check_object(&object)?;
        let added = self.meshes[object.mesh].triangle_count();
        if object.visible && self.triangle_count() + added > MAX_TRIANGLES {
            return Err(Error::scene(
                &self.name,
                format!("more than {MAX_TRIANGLES} triangles in the world"),
            ));
        }
        let index = self.objects.len();
        // The numbering grows by the new object (no renumbering: a file of
        // a million nodes loads in linear time).
        if let Some(instances) = self.instances.get_mut() {
            instances.push(index, &object, &self.meshes[object.mesh]);
        }
        self.objects.push(object);
        Ok(index)
    }

    /// Moves object `index` to `transform` (object to world).
    pub fn set_transform(&mut self, index: usize, transform: Mat4) -> Result<()> {
        check_transform(&transform)?;
        self.object_mut(index)?.transform = transform;
        Ok(())
    }

    /// Shows or hides object `index`.
    pub fn set_visible(&mut self, index: usize, visible: bool) -> Result<()> {
        let mesh = self.object(index)?.mesh;
        let added = self.meshes[mesh].triangle_count();
        if visible && !self.objects[index].visible && self.triangle_count() + added > MAX_TRIANGLES
        {
            return Err(Error::scene(
                &self.name,
                format!("more than {MAX_TRIANGLES} triangles in the world"),
            ));
        }
        self.object_mut(index)?.visible = visible;
        Ok(())
    }

    /// Draws object `index` with `material` instead of its mesh's (None:
    /// the mesh's own).
    pub fn set_object_material(&mut self, index: usize, material: Option<u32>) -> Result<()> {
        if let Some(m) = material.filter(|&m| m as usize >= self.materials.len()) {
            return Err(Error::InvalidParameter(format!(
                "material {m} does not exist ({} materials)",
                self.materials.len()
            )));
        }
        self.object_mut(index)?.material = material;
        Ok(())
    }

    /// Removes object `index` (later objects move down by one).
    pub fn remove_object(&mut self, index: usize) -> Result<Object> {
        self.object(index)?;
        self.instances = Default::default();
        Ok(self.objects.remove(index))
    }

    /// Object `index`, or an error naming the range.
    pub fn object(&self, index: usize) -> Result<&Object> {
        self.objects
            .get(index)
            .ok_or_else(|| out_of_range("object", index, self.objects.len()))
    }

    fn object_mut(&mut self, index: usize) -> Result<&mut Object> {
        self.instances = Default::default();
        let count = self.objects.len();
        self.objects
            .get_mut(index)
            .ok_or_else(|| out_of_range("object", index, count))
    }

    fn check_object(&self, o: &Object) -> Result<()> {
        if o.mesh >= self.meshes.len() {
            return Err(out_of_range("mesh", o.mesh, self.meshes.len()));
        }
        if let Some(m) = o.material.filter(|&m| m as usize >= self.materials.len()) {
            return Err(out_of_range("material", m as usize, self.materials.len()));
        }
        check_transform(&o.transform)
    }

    /// The visible objects numbered by triangle: how world triangles map to
    /// meshes (kept until meshes or objects change).
    pub fn instances(&self) -> &Instances {
        self.instances
            .get_or_init(|| Instances::new(&self.meshes, &self.objects))
    }

    /// World triangle `t`'s vertices in world space (`t` below
    /// [`Scene::triangle_count`]).
    pub fn triangle(&self, t: u32) -> [Vertex; 3] {
        let (instance, local) = self.instances().locate(t);
        let mesh = &self.meshes[instance.mesh as usize];
        let i = local as usize * 3;
        [0, 1, 2].map(|k| {
            instance
                .placement
                .vertex(&mesh.vertices[mesh.indices[i + k] as usize])
        })
    }

    /// Every world triangle's vertices in world space, in triangle order.
    pub fn world_triangles(&self) -> impl Iterator<Item = [Vertex; 3]> + '_ {
        self.instances().list.iter().flat_map(move |instance| {
            let mesh = &self.meshes[instance.mesh as usize];
            mesh.indices.chunks_exact(3).map(move |tri| {
                [0, 1, 2].map(|k| instance.placement.vertex(&mesh.vertices[tri[k] as usize]))
            })
        })
    }

    /// World triangle `t`'s corner positions in world space.
    pub fn triangle_positions(&self, t: u32) -> [Vec3; 3] {
        let (instance, local) = self.instances().locate(t);
        let mesh = &self.meshes[instance.mesh as usize];
        let i = local as usize * 3;
        [0, 1, 2].map(|k| {
            let p = mesh.vertices[mesh.indices[i + k] as usize].position;
            instance.placement.transform.transform_point3(Vec3::from(p))
        })
    }

    /// Bounds of every visible object (a unit box around the origin when
    /// there is none).
    pub fn bounds(&self) -> Bounds {
        let mut b: Option<Bounds> = None;
        for i in &self.instances().list {
            for v in &self.meshes[i.mesh as usize].vertices {
                let p = i
                    .placement
                    .transform
                    .transform_point3(Vec3::from(v.position));
                b = Some(b.map_or(Bounds { min: p, max: p }, |b| b.including(p)));
            }
        }
        b.unwrap_or(Bounds {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        })
    }

    /// Bytes the scene's meshes and textures take (each mesh once).
    pub fn memory_bytes(&self) -> u64 {
        (self
            .meshes
            .iter()
            .map(|m| m.vertices.len() * std::mem::size_of::<Vertex>() + m.indices.len() * 4)
            .sum::<usize>()
            + self.objects.len() * std::mem::size_of::<Object>()
            + self.textures.iter().map(|t| t.rgba8.len()).sum::<usize>()) as u64
    }

    /// Number of triangles in the world (every visible object's).
    pub fn triangle_count(&self) -> usize {
        self.instances().triangle_count as usize
    }

    /// Unit geometric normal of world triangle `t` on its front, the side
    /// its vertex normals point to (summed, so that smooth normals averaged
    /// over a box's corners still pick the face's side); zero if degenerate.
    /// A per-triangle answer: an interpolated normal may tilt past the face
    /// near an edge, the plane may not.
    pub fn front_normal(&self, t: usize) -> Vec3 {
        let (instance, local) = self.instances().locate(t as u32);
        let mesh = &self.meshes[instance.mesh as usize];
        let v = |k: usize| &mesh.vertices[mesh.indices[local as usize * 3 + k] as usize];
        let place = &instance.placement;
        let p = |k: usize| place.transform.transform_point3(Vec3::from(v(k).position));
        let normal = (p(1) - p(0)).cross(p(2) - p(0)).normalize_or_zero();
        let interpolated =
            place.normal_matrix * (0..3).map(|k| Vec3::from(v(k).normal)).sum::<Vec3>();
        if normal.dot(interpolated) < 0.0 {
            -normal
        } else {
            normal
        }
    }

    /// Camera `index`, or one framing the scene's bounds when there is none
    /// ([`Camera::framing`] for a [`DEFAULT_ASPECT`] image).
    pub fn camera(&self, index: Option<usize>) -> Result<Camera> {
        match index {
            Some(i) => self.cameras.get(i).cloned().ok_or_else(|| {
                Error::InvalidParameter(format!(
                    "camera index {i}: the scene has {} camera(s)",
                    self.cameras.len()
                ))
            }),
            None => Ok(self
                .cameras
                .first()
                .cloned()
                .unwrap_or_else(|| Camera::framing(&self.bounds(), DEFAULT_ASPECT))),
        }
    }

    /// Checks the scene is renderable.
    pub fn validate(&self) -> Result<()> {
        for (i, mesh) in self.meshes.iter().enumerate() {
            let bad = |what: &str| Err(Error::scene(&self.name, format!("mesh {i}: {what}")));
            if mesh.indices.len() % 3 != 0 {
                return bad("index count is not a multiple of 3");
            }
            if mesh
                .indices
                .iter()
                .any(|&k| k as usize >= mesh.vertices.len())
            {
                return bad("an index is out of range");
            }
            if mesh
                .vertices
                .iter()
                .any(|v| !Vec3::from(v.position).is_finite())
            {
                return bad("a vertex position is not finite");
            }
            if mesh
                .vertices
                .iter()
                .any(|v| v.material as usize >= self.materials.len())
            {
                return bad("a vertex names a material that does not exist");
            }
        }
        for (i, o) in self.objects.iter().enumerate() {
            self.check_object(o)
                .map_err(|e| Error::scene(&self.name, format!("object {i}: {e}")))?;
        }
        let world: usize = self
            .objects
            .iter()
            .filter(|o| o.visible)
            .map(|o| self.meshes[o.mesh].triangle_count())
            .sum();
        if world > MAX_TRIANGLES {
            return Err(Error::scene(
                &self.name,
                format!("{world} triangles in the world, more than {MAX_TRIANGLES}"),
            ));
        }
        if world == 0 {
            return Err(Error::scene(&self.name, "the scene has no triangles"));
        }
        for l in &self.lights {
            if !l.intensity.is_finite() || l.intensity.min_element() < 0.0 {
                return Err(Error::scene(
                    &self.name,
                    "a light has a negative or non-finite intensity",
                ));
            }
        }
        for (i, m) in self.materials.iter().enumerate() {
            self.check_material(m)
                .map_err(|what| Error::scene(&self.name, format!("material {i}: {what}")))?;
        }
        Ok(())
    }

    /// What is wrong with material `m`, if anything.
    fn check_material(&self, m: &Material) -> std::result::Result<(), String> {
        if !m.base_color.is_finite() || m.base_color.min_element() < 0.0 {
            return Err("base colour is negative or not finite".into());
        }
        if !m.emission.is_finite() || m.emission.min_element() < 0.0 {
            return Err(format!("emission {} is negative or not finite", m.emission));
        }
        if let AlphaMode::Mask(c) = m.alpha {
            if !(0.0..=1.0).contains(&c) {
                return Err(format!("alpha cutoff {c} is outside [0, 1]"));
            }
        }
        if !m.normal_scale.is_finite() {
            return Err("normal scale is not finite".into());
        }
        let mut reflectance_texture = None;
        if let Reflectance::MetallicRoughness {
            metallic,
            roughness,
            texture,
        } = m.reflectance
        {
            for (name, v) in [("metallic", metallic), ("roughness", roughness)] {
                if !(0.0..=1.0).contains(&v) {
                    return Err(format!("{name} {v} is outside [0, 1]"));
                }
            }
            reflectance_texture = texture.map(|t| t.index);
        }
        let textures = [
            m.texture,
            m.emissive_texture.map(|t| t.index),
            m.normal_texture.map(|t| t.index),
            reflectance_texture,
        ];
        if let Some(t) = textures
            .into_iter()
            .flatten()
            .find(|&t| t >= self.textures.len())
        {
            return Err(format!("texture {t} does not exist"));
        }
        Ok(())
    }
}

/// An error for `index` outside `0..count` of the `what`s.
fn out_of_range(what: &str, index: usize, count: usize) -> Error {
    Error::InvalidParameter(format!(
        "{what} {index} does not exist (the scene has {count})"
    ))
}

/// Fails unless `transform` is finite and invertible.
fn check_transform(transform: &Mat4) -> Result<()> {
    let det = Mat3::from_mat4(*transform).determinant();
    if !transform.is_finite() {
        return Err(Error::InvalidParameter(format!(
            "an object transform is not finite: {transform}"
        )));
    }
    if det.abs() < 1e-18 || !det.is_finite() {
        return Err(Error::InvalidParameter(format!(
            "an object transform is not invertible (determinant {det:e})"
        )));
    }
    // Rays, normals and bounds assume an affine map (glTF's node
    // transforms are): a projective bottom row is refused.
    if transform.row(3) != Vec4::W {
        return Err(Error::InvalidParameter(format!(
            "an object transform is not affine (bottom row {})",
            transform.row(3)
        )));
    }
    Ok(())
}

/// Loads a scene: a built-in name (`cornell`, `tori`) or a `.gltf`/`.glb`
/// path. glTF files are untrusted input: nothing outside the scene's
/// folder is read, and malformed files are errors, never panics.
///
/// ```
/// let scene = ssbc::scene::load("cornell").unwrap();
/// assert!(scene.triangle_count() > 0);
/// assert!(ssbc::scene::load("/nonexistent.gltf").is_err());
/// ```
pub fn load(name_or_path: &str) -> Result<Scene> {
    if let Some(scene) = builtin::by_name(name_or_path) {
        return Ok(scene);
    }
    gltf_loader::load(existing_file(name_or_path)?, None)
}

/// `name_or_path` as a path that exists (else the error `load` gives).
fn existing_file(name_or_path: &str) -> Result<&std::path::Path> {
    let path = std::path::Path::new(name_or_path);
    if !path.exists() {
        return Err(Error::scene(
            name_or_path,
            format!(
                "no such file, and not a built-in scene ({})",
                builtin::NAMES.join(", ")
            ),
        ));
    }
    Ok(path)
}

/// [`load`] with the file's first glTF animation played to `time` seconds
/// (node translation, rotation and scale; step, linear and cubic-spline
/// keyframes; clamped to the animation's span). Built-in scenes do not
/// move.
///
/// ```
/// let scene = ssbc::scene::load_at("cornell", 1.5).unwrap();
/// assert!(ssbc::scene::load_at("cornell", f32::NAN).is_err());
/// ```
pub fn load_at(name_or_path: &str, time: f32) -> Result<Scene> {
    if !time.is_finite() {
        return Err(Error::InvalidParameter(format!(
            "the animation time {time} is not a finite number"
        )));
    }
    if let Some(scene) = builtin::by_name(name_or_path) {
        return Ok(scene);
    }
    gltf_loader::load(existing_file(name_or_path)?, Some(time))
}

/// Parses a glTF or GLB file already in memory (`name` names it in errors);
/// external buffers and images are looked up in the folder `base`, and
/// nothing outside it is read.
pub fn load_gltf_bytes(name: &str, bytes: &[u8], base: &std::path::Path) -> Result<Scene> {
    gltf_loader::load_guarded(name, bytes, base, None)
}

/// [`load_gltf_bytes`] with the first animation played to `time` (see
/// [`load_at`]).
pub fn load_gltf_bytes_at(
    name: &str,
    bytes: &[u8],
    base: &std::path::Path,
    time: f32,
) -> Result<Scene> {
    gltf_loader::load_guarded(name, bytes, base, Some(time))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Flat normals follow the front face, which a mirroring transform
    /// turns clockwise (glTF: the determinant decides the winding): a quad
    /// facing +y mirrored in x still faces +y.
    #[test]
    fn flat_normals_of_a_mirrored_mesh_face_its_front() {
        let quad = [
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::new(-1.0, 0.0, -1.0),
        ];
        for transform in [
            Mat4::IDENTITY,
            Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
            Mat4::from_scale(Vec3::new(2.0, 1.0, -3.0)),
        ] {
            let mut s = Scene::new("quad");
            let m = s.add_material(Vec3::ONE, None);
            s.add_mesh(&quad, &[], &[], &[0, 1, 2, 0, 2, 3], transform, m)
                .unwrap();
            for t in 0..2 {
                for v in s.triangle(t) {
                    assert_eq!(v.normal, [0.0, 1.0, 0.0], "{transform}");
                }
            }
        }
    }
}
