//! Meshes as a scene takes them in: vertices as uploaded, a host's mesh
//! data, and the checks and tangents a new mesh gets.

use super::*;

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

impl Scene {
    /// The meshes (object space).
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
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
        if data.positions.iter().any(|p| !p.is_finite()) {
            return bad("a vertex position is not finite");
        }
        let bounds = data
            .positions
            .iter()
            .map(|&p| Bounds { min: p, max: p })
            .reduce(Bounds::union);
        if let Some(why) = bounds.as_ref().and_then(super::out_of_reach) {
            return bad(&why);
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
}
