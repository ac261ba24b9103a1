//! Meshes and the objects that draw them: a mesh's vertices are stored once
//! in object space; an object places a mesh in the world with a transform
//! (and may override its material or hide it). Everything that needs world
//! space (ray casting, point sampling, emitters) goes through
//! [`Instances`], the visible objects numbered by their triangles.

use glam::{Mat3, Mat4, Vec3, Vec4};

use super::{Bounds, Vertex};

/// A triangle mesh in object space, stored once however many objects draw it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Object-space vertices.
    pub vertices: Vec<Vertex>,
    /// Triangle-list indices into `vertices`.
    pub indices: Vec<u32>,
}

impl Mesh {
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len() / 3
    }

    /// Object-space bounds (None without vertices).
    pub fn bounds(&self) -> Option<Bounds> {
        let first = Vec3::from(self.vertices.first()?.position);
        let mut b = Bounds {
            min: first,
            max: first,
        };
        for v in &self.vertices {
            b = b.including(Vec3::from(v.position));
        }
        Some(b)
    }
}

/// An instance of a mesh in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    /// Index into [`Scene::meshes`](super::Scene::meshes).
    pub mesh: usize,
    /// Object to world (finite and invertible).
    pub transform: Mat4,
    /// A material drawn instead of the mesh's own (index into
    /// [`Scene::materials`](super::Scene::materials)).
    pub material: Option<u32>,
    /// Hidden objects cast, receive and reflect nothing.
    pub visible: bool,
    /// The glTF node it came from (animations move it).
    pub node: Option<usize>,
}

impl Object {
    /// A visible object drawing `mesh` with its own materials.
    pub fn new(mesh: usize, transform: Mat4) -> Self {
        Self {
            mesh,
            transform,
            material: None,
            visible: true,
            node: None,
        }
    }
}

impl Object {
    /// The object glTF node `node` makes of `mesh` with its world
    /// transform: hidden (at the identity) while that transform collapses
    /// it to nothing (a zero scale: glTF's way to hide a node, often
    /// animated).
    pub fn at_node(mesh: usize, world: Mat4, node: usize) -> Self {
        let invertible = Mat3::from_mat4(world).determinant().abs() >= 1e-18;
        Self {
            node: Some(node),
            visible: invertible,
            ..Self::new(mesh, if invertible { world } else { Mat4::IDENTITY })
        }
    }
}

/// How an object's vertices reach world space.
#[derive(Clone, Copy, Debug)]
pub struct Placement {
    /// Object to world.
    pub transform: Mat4,
    /// The inverse transpose of its linear part (for normals).
    pub normal_matrix: Mat3,
    /// -1 for a mirroring transform (it flips tangent frames), else 1.
    pub handedness: f32,
    /// The object's material override.
    pub material: Option<u32>,
}

impl Placement {
    /// The placement of `object`.
    pub fn new(object: &Object) -> Self {
        let linear = Mat3::from_mat4(object.transform);
        Self {
            transform: object.transform,
            normal_matrix: linear.inverse().transpose(),
            handedness: if linear.determinant() < 0.0 {
                -1.0
            } else {
                1.0
            },
            material: object.material,
        }
    }

    /// `v` in world space: the position transformed, the normal by the
    /// inverse transpose, the tangent by the linear part (its handedness
    /// flipped by a mirror), the material overridden.
    pub fn vertex(&self, v: &Vertex) -> Vertex {
        let tangent = Vec4::from(v.tangent);
        let world_tangent = if tangent == Vec4::ZERO {
            Vec4::ZERO
        } else {
            let xyz = self
                .transform
                .transform_vector3(tangent.truncate())
                .normalize_or_zero();
            xyz.extend(if tangent.w < 0.0 {
                -self.handedness
            } else {
                self.handedness
            })
        };
        Vertex {
            position: self
                .transform
                .transform_point3(Vec3::from(v.position))
                .into(),
            normal: (self.normal_matrix * Vec3::from(v.normal))
                .normalize_or_zero()
                .into(),
            uv: v.uv,
            material: self.material.unwrap_or(v.material),
            tangent: world_tangent.into(),
            color: v.color,
        }
    }
}

/// One visible object as [`Instances`] numbers it.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index into `Scene::objects`.
    pub object: u32,
    /// Index into `Scene::meshes`.
    pub mesh: u32,
    /// Its first triangle in the world numbering.
    pub first_triangle: u32,
    /// How its vertices reach world space.
    pub placement: Placement,
}

/// The visible objects, their triangles numbered consecutively (object by
/// object, in object order): the world's triangle `t` is triangle
/// `t - first_triangle` of the instance holding it.
#[derive(Clone, Debug, Default)]
pub struct Instances {
    /// Visible objects in object order.
    pub list: Vec<Instance>,
    /// Triangles of all of them.
    pub triangle_count: u32,
}

impl Instances {
    /// Numbers the visible objects of `objects` (their meshes must exist).
    pub fn new(meshes: &[Mesh], objects: &[Object]) -> Self {
        let mut instances = Self::default();
        for (i, o) in objects.iter().enumerate() {
            if let Some(mesh) = meshes.get(o.mesh) {
                instances.push(i, o, mesh);
            }
        }
        instances
    }

    /// Numbers object `index` (drawing `mesh`) after the others, if it is
    /// visible and has triangles.
    pub(crate) fn push(&mut self, index: usize, object: &Object, mesh: &Mesh) {
        if !object.visible || mesh.indices.len() < 3 {
            return;
        }
        self.list.push(Instance {
            object: index as u32,
            mesh: object.mesh as u32,
            first_triangle: self.triangle_count,
            placement: Placement::new(object),
        });
        // Scenes hold at most MAX_TRIANGLES world triangles (add_object).
        self.triangle_count = self
            .triangle_count
            .saturating_add(mesh.triangle_count().min(u32::MAX as usize) as u32);
    }

    /// The instance holding world triangle `t`, and its index in the mesh.
    pub fn locate(&self, t: u32) -> (&Instance, u32) {
        let i = self.list.partition_point(|x| x.first_triangle <= t) - 1;
        let instance = &self.list[i];
        (instance, t - instance.first_triangle)
    }
}
