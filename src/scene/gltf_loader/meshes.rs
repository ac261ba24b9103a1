//! Meshes: primitives triangulated into ssbc's vertices, with morph
//! targets and skins applied.

use super::*;

/// Triangle list indices for a triangle list, strip or fan.
pub(super) fn triangulate(mode: json::mesh::Mode, idx: &[u32]) -> Vec<u32> {
    use json::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .flat_map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .flat_map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx[..idx.len() / 3 * 3].to_vec(),
    }
}

/// A primitive's vertex attributes, as read.
struct Attributes {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<[f32; 2]>,
    tangents: Vec<Vec4>,
    colors: Vec<Vec4>,
}

impl Loader<'_> {
    /// Adds glTF mesh `index`'s triangle primitives as scene meshes (object
    /// space) and returns their indices.
    /// Mesh `index`'s triangle primitives as scene meshes, with its morph
    /// targets at `weights` and, with `joints` (see skinned_mesh), skinned.
    pub(super) fn mesh(
        &mut self,
        index: usize,
        weights: &[f32],
        joints: Option<(&[Mat4], Mat4)>,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<Vec<usize>> {
        let mut made = Vec::new();
        use json::mesh::Mode;
        let root = self.root;
        let mesh = root
            .meshes
            .get(index)
            .ok_or_else(|| self.err(format!("mesh index {index} out of range")))?;
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let mode = checked(&prim.mode).ok_or_else(|| self.err("invalid primitive mode"))?;
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                log::warn!(
                    "{}: mesh {index} primitive {pi} is not triangles; skipped",
                    self.name
                );
                continue;
            }
            let Attributes {
                mut positions,
                mut normals,
                uvs,
                mut tangents,
                colors,
            } = self.attributes(prim, index, pi)?;
            let at = format!("mesh {index} primitive {pi}");
            self.morph(&at, prim, weights, &mut positions, &mut normals, &mut tangents)?;
            if let Some(joints) = joints {
                self.skin(&at, prim, joints, &mut positions, &mut normals, &mut tangents)?;
            }
            let raw_indices = match prim.indices {
                Some(a) => self.read_indices(a.value())?,
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = raw_indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(self.err(format!(
                    "mesh {index} primitive {pi}: index {bad} out of range ({} vertices)",
                    positions.len()
                )));
            }
            let indices = triangulate(mode, &raw_indices);
            let material = match prim.material {
                Some(m) => *materials.get(m.value()).ok_or_else(|| {
                    self.err(format!("material index {} out of range", m.value()))
                })?,
                None => default_material,
            };
            if indices.len() / 3 > MAX_TRIANGLES {
                return Err(self.err(format!("more than {MAX_TRIANGLES} triangles")));
            }
            // Flat normals unshare vertices: three a triangle.
            let vertices = if normals.is_empty() {
                indices.len()
            } else {
                positions.len()
            };
            self.check_budget(
                (vertices * std::mem::size_of::<crate::scene::Vertex>() + indices.len() * 4) as u64,
            )?;
            made.push(scene.new_mesh(
                crate::scene::MeshData {
                    positions: &positions,
                    normals: &normals,
                    uvs: &uvs,
                    tangents: &tangents,
                    colors: &colors,
                    indices: &indices,
                },
                material,
            )?);
        }
        Ok(made)
    }

    /// Primitive `pi` of mesh `index`'s vertex attributes (object space,
    /// texture coordinates through their material's transform), every one
    /// present as long as the positions.
    fn attributes(
        &mut self,
        prim: &json::mesh::Primitive,
        index: usize,
        pi: usize,
    ) -> Result<Attributes> {
        use json::mesh::Semantic;
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
        let pos_acc = attr(Semantic::Positions)
            .ok_or_else(|| self.err(format!("mesh {index} primitive {pi} has no POSITION")))?;
        let positions: Vec<Vec3> = self
            .read_floats(pos_acc, 3)?
            .chunks_exact(3)
            .map(Vec3::from_slice)
            .collect();
        let normals: Vec<Vec3> = match attr(Semantic::Normals) {
            Some(a) => self
                .read_floats(a, 3)?
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect(),
            None => Vec::new(),
        };
        let uv_maps = match prim.material {
            Some(m) => self.uv_maps.get(m.value()).copied().unwrap_or_default(),
            None => MaterialUvMaps::default(),
        };
        let uv_map = uv_maps.mesh;
        let uvs: Vec<[f32; 2]> = match attr(Semantic::TexCoords(uv_map.set)) {
            Some(a) => self
                .read_floats(a, 2)?
                .chunks_exact(2)
                .map(|c| uv_map.transform.transform_point2(Vec2::new(c[0], c[1])))
                .map(|uv| uv.is_finite().then_some(uv.into()))
                .collect::<Option<_>>()
                .ok_or_else(|| {
                    self.err(format!(
                        "mesh {index} primitive {pi}: KHR_texture_transform takes texture coordinates past the largest float"
                    ))
                })?,
            None => {
                if uv_map.set != 0 {
                    log::warn!(
                        "{}: mesh {index} primitive {pi} has no TEXCOORD_{} for its material's textures",
                        self.name,
                        uv_map.set
                    );
                }
                Vec::new()
            }
        };
        let mut tangents: Vec<Vec4> = match attr(Semantic::Tangents) {
            Some(a) => self
                .read_floats(a, 4)?
                .chunks_exact(4)
                .map(Vec4::from_slice)
                .collect(),
            None => Vec::new(),
        };
        let colors = match attr(Semantic::Colors(0)) {
            Some(a) => self.read_colors(a, index, pi)?,
            None => Vec::new(),
        };
        if !normals.is_empty() && normals.len() != positions.len()
            || !uvs.is_empty() && uvs.len() != positions.len()
            || !tangents.is_empty() && tangents.len() != positions.len()
            || !colors.is_empty() && colors.len() != positions.len()
        {
            return Err(self.err(format!(
                "mesh {index} primitive {pi}: attribute counts differ"
            )));
        }
        if !uvs.is_empty() && normals.len() == tangents.len() {
            // The normal map's own map of the TEXCOORD set.
            let normal_map = uv_maps.normal * uv_map.transform;
            follow_texture_transform(&mut tangents, &normals, normal_map.matrix2);
        }
        Ok(Attributes {
            positions,
            normals,
            uvs,
            tangents,
            colors,
        })
    }

    /// Displaces a primitive's vertices by its morph targets at `weights`
    /// (a missing weight is 0). Each target read adds a pass over the
    /// vertices: at most MAX_MORPH_READS vertex reads in all per primitive.
    pub(super) fn morph(
        &mut self,
        at: &str,
        prim: &json::mesh::Primitive,
        weights: &[f32],
        positions: &mut [Vec3],
        normals: &mut [Vec3],
        tangents: &mut [Vec4],
    ) -> Result<()> {
        let targets = prim.targets.as_deref().unwrap_or_default();
        let applied = targets.iter().zip(weights).filter(|(_, w)| **w != 0.0);
        if applied.clone().count().saturating_mul(positions.len()) > MAX_MORPH_READS {
            return Err(self.err(format!(
                "{at}: more morph-target work than {MAX_MORPH_READS} vertex reads"
            )));
        }
        let n = positions.len();
        for (k, (target, &w)) in applied.enumerate() {
            let read = |loader: &mut Self, a: Option<json::Index<json::Accessor>>| -> Result<Option<Vec<f32>>> {
                let Some(a) = a else { return Ok(None) };
                let d = loader.read_floats(a.value(), 3)?;
                if d.len() != 3 * n {
                    return Err(loader.err(format!("{at}: morph target {k} has {} vertices, not {n}", d.len() / 3)));
                }
                Ok(Some(d))
            };
            if let Some(d) = read(self, target.positions)? {
                deform::add_displacements(positions, &d, w);
            }
            if let Some(d) = read(self, target.normals)? {
                deform::add_displacements(normals, &d, w);
            }
            if let Some(d) = read(self, target.tangents)? {
                deform::add_tangent_displacements(tangents, &d, w);
            }
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(self.err(format!("{at}: morph targets move a vertex past the largest float")));
        }
        deform::renormalize(normals, Vec3::Z);
        Ok(())
    }

    /// Skins a primitive's vertices by `joints` (deform::skin) with its
    /// JOINTS_n / WEIGHTS_n sets; without any, transforms them by `node`,
    /// its node's world transform, as if it were not skinned.
    pub(super) fn skin(
        &mut self,
        at: &str,
        prim: &json::mesh::Primitive,
        (mut joints, node): (&[Mat4], Mat4),
        positions: &mut [Vec3],
        normals: &mut [Vec3],
        tangents: &mut [Vec4],
    ) -> Result<()> {
        use json::mesh::Semantic;
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
        let n = positions.len();
        let unposed = [node];
        let (mut joint_sets, mut weight_sets) = (Vec::new(), Vec::new());
        for set in 0.. {
            let (Some(j), Some(w)) = (attr(Semantic::Joints(set)), attr(Semantic::Weights(set))) else {
                break;
            };
            let (j, w) = (self.read_floats(j, 4)?, self.read_floats(w, 4)?);
            if j.len() != 4 * n || w.len() != 4 * n {
                return Err(self.err(format!("{at}: JOINTS_{set} / WEIGHTS_{set} counts differ from its vertices'")));
            }
            if let Some(bad) = j.iter().find(|&&j| !(j >= 0.0 && j.fract() == 0.0 && (j as usize) < joints.len())) {
                return Err(self.err(format!("{at}: joint {bad} is not one of the skin's {} joints", joints.len())));
            }
            joint_sets.push(j);
            weight_sets.push(w);
        }
        if joint_sets.is_empty() {
            // Drawn as if not skinned: by its node's transform.
            log::warn!(
                "{}: {at} is skinned but has no JOINTS_0 / WEIGHTS_0; drawn at its node",
                self.name
            );
            joint_sets.push(vec![0.0; 4 * n]);
            weight_sets.push([1.0, 0.0, 0.0, 0.0].repeat(n));
            joints = &unposed;
        }
        // Vertex-major, as deform::Influences wants.
        let sets = joint_sets.len();
        let mut joint_indices = Vec::with_capacity(4 * sets * n);
        let mut weights = Vec::with_capacity(4 * sets * n);
        for v in 0..n {
            for (j, w) in joint_sets.iter().zip(&weight_sets) {
                joint_indices.extend(j[4 * v..4 * v + 4].iter().map(|&j| j as u32));
                weights.extend(&w[4 * v..4 * v + 4]);
            }
        }
        let influences = deform::Influences { sets, joints: &joint_indices, weights: &weights };
        deform::skin(joints, &influences, positions, normals, tangents);
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(self.err(format!("{at}: skinning moves a vertex past the largest float")));
        }
        Ok(())
    }
}
