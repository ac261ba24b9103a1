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
mod loading;
mod material;
mod mesh;
mod objects;
mod placement;
mod tangents;
unstable_pub! {
    mod gltf_loader;
}

use glam::{Affine2, Mat3, Mat4, Vec2, Vec3, Vec4};

use crate::error::{Error, Result};
pub use camera::{Camera, Perspective, DEFAULT_ASPECT};
pub use light::{Light, LightKind};
pub use loading::{load, load_at, load_gltf_bytes, load_gltf_bytes_at};
pub use material::{AlphaMode, Material, Reflectance, Texture, TextureRef, TextureSampler, Wrap};
pub use mesh::{MeshData, Vertex};
pub use objects::{Instance, Instances, Mesh, Object, Placement};
use tangents::{handedness, triangle_tangent, vertex_tangents};

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

/// Largest coordinate a scene's geometry may reach, in object space and in
/// world space, in metres (2.6 times the Moon's distance). Beyond it `f32`
/// geometry breaks: a triangle's normal and area come from the cross
/// product of its edges, whose squared length is infinite for edges over
/// about 4e9 m (VPLs got NaN positions, and each ISM ray visited every
/// triangle: 64 s a frame), and boxes 1e20 m wide made the BVH builder's
/// area costs infinite (its build overflowed the stack or indexed out of
/// bounds). Images are the same at every scale only in a narrower range
/// (docs/development.md, "Scale").
pub const MAX_COORDINATE: f32 = 1e9;

/// Why bounds `b` are not a place for geometry, if they are not: a
/// coordinate beyond [`MAX_COORDINATE`] or not a number.
pub(crate) fn out_of_reach(b: &Bounds) -> Option<String> {
    let reach = b.min.abs().max(b.max.abs()).max_element();
    // A NaN reach is out too.
    let within = reach <= MAX_COORDINATE;
    (!within).then(|| {
        format!("its geometry reaches {reach:e} m from the origin, beyond the {MAX_COORDINATE:e} m ssbc takes")
    })
}

impl Scene {
    /// Whether any material is glossy (not Lambertian): SSBC's receivers
    /// may then need their BRDF.
    pub fn has_glossy_materials(&self) -> bool {
        self.materials
            .iter()
            .any(|m| m.reflectance != Reflectance::Lambertian)
    }

    /// Whether any material has a normal map.
    pub fn has_normal_maps(&self) -> bool {
        self.materials.iter().any(|m| m.normal_texture.is_some())
    }

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
        let mut mesh_bounds = Vec::with_capacity(self.meshes.len());
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
            let bounds = mesh.bounds();
            if let Some(why) = bounds.as_ref().and_then(out_of_reach) {
                return bad(&why);
            }
            mesh_bounds.push(bounds);
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
            // Its mesh's box moved (a little larger than the object's own
            // bounds where it turns, and O(1) an object).
            let world = mesh_bounds[o.mesh].map(|b| b.transformed(o.transform));
            if let Some(why) = world.as_ref().filter(|_| o.visible).and_then(out_of_reach) {
                return Err(Error::scene(&self.name, format!("object {i}: {why}")));
            }
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
