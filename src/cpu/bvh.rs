//! Ray casting against the scene's triangles with a BVH from `obvhs`
//! (compressed wide BVH8), plus surface interactions at hits. Alpha-masked
//! materials are tested at every candidate hit, so rays pass through their
//! cut-out parts like the GPU's rasterised passes.

use std::time::Duration;

use std::sync::Arc;

use glam::{Mat4, Vec2, Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use super::brdf::Brdf;
use super::shading;
use rayon::prelude::*;

use crate::scene::{AlphaMode, Bounds, Mesh, Scene, Texture, TextureSampler, MAX_COORDINATE};
use crate::{Error, Result};

/// A closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// World triangle index ([`Scene::instances`] numbers them).
    pub triangle: u32,
    /// Barycentric coordinates (of vertices 1 and 2).
    pub barycentric: Vec2,
}

/// Everything about a surface point the light transport needs.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// World position.
    pub position: Vec3,
    /// Shading normal (interpolated, normal-mapped), flipped to the side
    /// `toward` came from.
    pub normal: Vec3,
    /// Geometric normal, on the same side as `normal`.
    pub geometric_normal: Vec3,
    /// Linear base colour (factor x texture): the albedo of a Lambertian
    /// surface.
    pub albedo: Vec3,
    /// The BRDF there.
    pub brdf: Brdf,
    /// Unit direction it is seen from (`toward`).
    pub wo: Vec3,
    /// Radiance emitted towards `toward` (W/(m² sr)); zero seen from behind
    /// a one-sided emitter.
    pub emission: Vec3,
    /// Whether `toward` is on the front side (where the vertex normals point).
    pub front: bool,
    /// Whether the material is seen from both sides.
    pub double_sided: bool,
}

/// A texture an alpha-masked material uses (only its alpha is kept).
struct AlphaTexture {
    width: u32,
    height: u32,
    rgba8: Vec<u8>,
}

/// What decides whether a point of a masked triangle exists.
struct Mask {
    cutoff: f32,
    alpha_factor: f32,
    texture: Option<(usize, TextureSampler)>,
}

/// The alpha masks of a scene's materials.
struct Masks {
    /// Per material, its mask (index into `masks`).
    of_material: Vec<Option<u32>>,
    masks: Vec<Mask>,
    alpha_textures: Vec<AlphaTexture>,
}

impl Masks {
    /// The masks of `scene`'s materials and the alpha of their textures.
    fn new(scene: &Scene) -> Self {
        let mut alpha_textures = Vec::new();
        let mut texture_slot = std::collections::HashMap::new();
        let mut of_material = vec![None; scene.materials.len()];
        let mut masks = Vec::new();
        for (i, m) in scene.materials.iter().enumerate() {
            if let AlphaMode::Mask(cutoff) = m.alpha {
                let texture = m.texture.map(|t| {
                    let slot = *texture_slot.entry(t).or_insert_with(|| {
                        let tex: &Texture = &scene.textures[t];
                        alpha_textures.push(AlphaTexture {
                            width: tex.width,
                            height: tex.height,
                            rgba8: tex
                                .rgba8
                                .chunks_exact(4)
                                .flat_map(|c| [0, 0, 0, c[3]])
                                .collect(),
                        });
                        alpha_textures.len() - 1
                    });
                    (slot, m.sampler)
                });
                of_material[i] = Some(masks.len() as u32);
                masks.push(Mask {
                    cutoff,
                    alpha_factor: m.base_color.w,
                    texture,
                });
            }
        }
        Self {
            of_material,
            masks,
            alpha_textures,
        }
    }

    /// Whether the point of a triangle of `material` with texture
    /// coordinate and vertex alpha `at()` exists.
    fn exists(&self, material: u32, at: impl FnOnce() -> (Vec2, f32)) -> bool {
        let Some(Some(mask)) = self.of_material.get(material as usize) else {
            return true;
        };
        let mask = &self.masks[*mask as usize];
        let (uv, vertex_alpha) = at();
        let alpha = match mask.texture {
            None => mask.alpha_factor,
            Some((slot, sampler)) => {
                let tex = &self.alpha_textures[slot];
                mask.alpha_factor
                    * shading::sample_rgba8(tex.width, tex.height, &tex.rgba8, sampler, uv, false).w
            }
        };
        alpha * vertex_alpha >= mask.cutoff
    }

    fn any(&self) -> bool {
        !self.masks.is_empty()
    }
}

/// A BVH over one mesh's triangles in object space (built once per mesh).
struct MeshBvh {
    bvh: CwBvh,
    triangles: Vec<Triangle>,
    /// Per triangle: its material and its vertices' UVs and colours'
    /// alphas (alpha masks; no alphas where every vertex is opaque).
    material: Vec<u32>,
    uvs: Vec<[Vec2; 3]>,
    alphas: Vec<[f32; 3]>,
    bounds: Bounds,
}

impl MeshBvh {
    fn new(mesh: &Mesh) -> Self {
        let corner = |t: &[u32], k: usize| &mesh.vertices[t[k] as usize];
        let triangles: Vec<Triangle> = mesh
            .indices
            .chunks_exact(3)
            .map(|t| {
                let p = |k: usize| Vec3A::from(corner(t, k).position);
                Triangle {
                    v0: p(0),
                    v1: p(1),
                    v2: p(2),
                }
            })
            .collect();
        // Exact copies of an earlier triangle stay out of the BVH: no box
        // separates a stack, so a ray tested all of it (a file of a million
        // copies of one triangle took 400 s to trace 2048 VPLs).
        let firsts = first_copies(mesh);
        let boxes: Vec<Aabb> = firsts
            .iter()
            .map(|&i| padded(triangles[i as usize].aabb(), i as usize))
            .collect();
        let mut bvh = build_cwbvh(&boxes, BvhBuildParams::medium_build(), &mut Duration::default());
        // Its primitives numbered as the mesh's triangles.
        for p in &mut bvh.primitive_indices {
            *p = firsts[*p as usize];
        }
        let material = mesh
            .indices
            .chunks_exact(3)
            .map(|t| corner(t, 0).material)
            .collect();
        let uvs = mesh
            .indices
            .chunks_exact(3)
            .map(|t| [0, 1, 2].map(|k| Vec2::from(corner(t, k).uv)))
            .collect();
        let alphas = if mesh.vertices.iter().all(|v| v.color[3] == u16::MAX) {
            Vec::new()
        } else {
            let alphas = mesh.indices.chunks_exact(3);
            alphas.map(|t| [0, 1, 2].map(|k| corner(t, k).color().w)).collect()
        };
        Self {
            bvh,
            triangles,
            material,
            uvs,
            alphas,
            bounds: mesh.bounds().unwrap_or(Bounds {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
            }),
        }
    }
}

/// One visible object in the top level: its mesh and transforms.
#[derive(Clone, Copy)]
struct TopInstance {
    mesh: u32,
    first_triangle: u32,
    to_world: Mat4,
    to_object: Mat4,
    material: Option<u32>,
    /// Whether object space is world space (rays need no transform).
    identity: bool,
}

/// Ray casting against a scene's visible objects: a BVH per mesh in
/// object space (built once, shared by every object drawing it and kept
/// while only transforms change) under a top-level BVH over the objects'
/// world bounds (rebuilt when an object moves: [`SceneBvh::moved`]).
/// Triangles are numbered as [`Scene::instances`] numbers them.
pub struct SceneBvh {
    meshes: Arc<Vec<MeshBvh>>,
    masks: Arc<Masks>,
    top: CwBvh,
    instances: Vec<TopInstance>,
    /// Per triangle, its connected surface ([`SceneBvh::connected_surfaces`]).
    surfaces: std::sync::OnceLock<Vec<u32>>,
    /// [`length_floor`] of the visible objects' bounds.
    floor: f32,
}

/// The 14 directions of [`SceneBvh::enclosed_fraction`] and the winding
/// test of [`super::enclosure`]: the 6 axes and the 8 diagonals, turned off
/// the axes (modelled geometry is axis-aligned and symmetric, and rays along
/// its edges may slip between triangles).
pub static ENCLOSURE_DIRECTIONS: std::sync::LazyLock<[Vec3; 14]> = std::sync::LazyLock::new(|| {
    let turn = glam::Quat::from_euler(glam::EulerRot::XYZ, 0.11, 0.23, 0.37);
    let axes = [
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
        [1.0, 1.0, 1.0],
        [1.0, 1.0, -1.0],
        [1.0, -1.0, 1.0],
        [1.0, -1.0, -1.0],
        [-1.0, 1.0, 1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
        [-1.0, -1.0, -1.0],
    ];
    axes.map(|d| turn * Vec3::from(d).normalize())
});

/// Relative offset used to leave surfaces without self-intersection (see
/// [`SceneBvh::surface_offset`]).
pub const RAY_EPSILON: f32 = 1e-4;

/// The length below which offsets scale with the scene rather than stop at
/// a fixed floor: a scene's diagonal, at most a metre (scenes larger than
/// that keep the floor of `RAY_EPSILON` m they were tuned with; a 2 mm box
/// of 0.13 mm slabs was lit through them by a 0.1 mm floor).
pub fn length_floor(diagonal: f32) -> f32 {
    if diagonal.is_finite() && diagonal > 0.0 {
        diagonal.min(1.0)
    } else {
        1.0
    }
}


impl SceneBvh {
    /// Builds a BVH per mesh (medium-quality PLOC builds, in parallel) and
    /// the top level.
    pub fn new(scene: &Scene) -> Self {
        let meshes: Vec<MeshBvh> = scene.meshes().par_iter().map(MeshBvh::new).collect();
        Self::with(Arc::new(meshes), Arc::new(Masks::new(scene)), scene)
    }

    /// This BVH with the objects of `scene` where they are now: only the
    /// top level is rebuilt (the scene's meshes and materials must be those
    /// this BVH was built for).
    pub fn moved(&self, scene: &Scene) -> Self {
        Self::with(self.meshes.clone(), self.masks.clone(), scene)
    }

    /// [`SceneBvh::moved`], or an error naming the first visible object
    /// whose mesh's box, moved, reaches beyond [`MAX_COORDINATE`] (the
    /// rule [`Scene::validate`] applies, checked in O(1) an object).
    pub fn try_moved(&self, scene: &Scene) -> Result<Self> {
        for i in &scene.instances().list {
            let world = self.meshes[i.mesh as usize].bounds.transformed(i.placement.transform);
            if let Some(why) = crate::scene::out_of_reach(&world) {
                return Err(Error::scene(&scene.name, format!("object {}: {why}", i.object)));
            }
        }
        Ok(self.moved(scene))
    }

    fn with(meshes: Arc<Vec<MeshBvh>>, masks: Arc<Masks>, scene: &Scene) -> Self {
        let instances: Vec<TopInstance> = scene
            .instances()
            .list
            .iter()
            .map(|i| TopInstance {
                mesh: i.mesh,
                first_triangle: i.first_triangle,
                to_world: i.placement.transform,
                to_object: i.placement.transform.inverse(),
                material: i.placement.material,
                identity: i.placement.transform == Mat4::IDENTITY,
            })
            .collect();
        // Objects that repeat an earlier one exactly (its mesh, transform
        // and material) stay out of the top level, as a mesh's copies do.
        let firsts = first_of_each(instances.len(), |k| {
            let i = &instances[k];
            let t = i.to_world.to_cols_array().map(f32::to_bits);
            let material = i.material.map_or([0, 0], |m| [1, m]);
            std::array::from_fn::<u32, 19, _>(|j| match j {
                0..16 => t[j],
                16 => i.mesh,
                _ => material[j - 17],
            })
        });
        let boxes: Vec<Aabb> = firsts
            .iter()
            .map(|&k| {
                let i = &instances[k as usize];
                let b = meshes[i.mesh as usize].bounds.transformed(i.to_world);
                padded(Aabb::new(b.min.into(), b.max.into()), k as usize)
            })
            .collect();
        let mut top = build_cwbvh(
            &boxes,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        for p in &mut top.primitive_indices {
            *p = firsts[*p as usize];
        }
        let mut bvh = Self {
            meshes,
            masks,
            top,
            instances,
            surfaces: std::sync::OnceLock::new(),
            floor: 1.0,
        };
        bvh.floor = length_floor(bvh.bounds().map_or(1.0, |b| (b.max - b.min).length()));
        bvh
    }

    /// How far a ray leaving a surface at `p` starts off it: `RAY_EPSILON`
    /// of its coordinates' size, plus of the scene's up to a metre
    /// ([`length_floor`]).
    pub fn surface_offset(&self, p: Vec3) -> f32 {
        RAY_EPSILON * (self.floor + p.abs().max_element())
    }

    /// How far a ray that leaves a known triangle (which it skips) starts
    /// off it: a few ulps of the coordinates (and of the scene's size up to
    /// a metre), far below any modelled thickness.
    pub fn lift(&self, p: Vec3) -> f32 {
        8.0 * f32::EPSILON * (self.floor + p.abs().max_element())
    }

    /// [`length_floor`] of this scene.
    pub fn length_floor(&self) -> f32 {
        self.floor
    }

    /// The world bounds of the visible objects (their meshes' bounds
    /// moved), None without any.
    pub fn bounds(&self) -> Option<Bounds> {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh as usize].bounds.transformed(i.to_world))
            .reduce(Bounds::union)
    }

    /// The instance holding world triangle `t`, and its index in the mesh.
    fn locate(&self, t: u32) -> (&TopInstance, usize) {
        let i = self.instances.partition_point(|x| x.first_triangle <= t) - 1;
        (
            &self.instances[i],
            (t - self.instances[i].first_triangle) as usize,
        )
    }

    /// World triangle `t`'s corners in world space.
    fn world_triangle(&self, t: u32) -> [Vec3; 3] {
        let (instance, local) = self.locate(t);
        let tri = &self.meshes[instance.mesh as usize].triangles[local];
        [tri.v0, tri.v1, tri.v2].map(|v| instance.to_world.transform_point3(v.into()))
    }

    /// The unit geometric normal of world triangle `t` (either side; zero
    /// for a degenerate one).
    pub fn triangle_normal(&self, t: u32) -> Vec3 {
        let v = self.world_triangle(t);
        (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero()
    }

    /// Number of world triangles.
    fn triangle_count(&self) -> u32 {
        self.instances.last().map_or(0, |i| {
            i.first_triangle + self.meshes[i.mesh as usize].triangles.len() as u32
        })
    }

    /// Per triangle, the connected surface it belongs to: triangles joined
    /// by world vertex positions they share exactly (a closed box of 24
    /// vertices is one surface). Worked out on first use.
    pub fn connected_surfaces(&self) -> &[u32] {
        self.surfaces.get_or_init(|| {
            let mut ids = std::collections::HashMap::new();
            let mut parent: Vec<u32> = Vec::new();
            let mut id = |p: Vec3| {
                *ids.entry(p.to_array().map(f32::to_bits))
                    .or_insert_with(|| {
                        parent.push(parent.len() as u32);
                        parent.len() as u32 - 1
                    })
            };
            let corners: Vec<[u32; 3]> = (0..self.triangle_count())
                .map(|t| self.world_triangle(t).map(&mut id))
                .collect();
            fn root(parent: &mut [u32], mut i: u32) -> u32 {
                while parent[i as usize] != i {
                    parent[i as usize] = parent[parent[i as usize] as usize];
                    i = parent[i as usize];
                }
                i
            }
            for c in &corners {
                for &k in &c[1..] {
                    let (a, b) = (root(&mut parent, c[0]), root(&mut parent, k));
                    parent[a.max(b) as usize] = a.min(b);
                }
            }
            corners.iter().map(|c| root(&mut parent, c[0])).collect()
        })
    }

    /// The world ray `r` in the space of the object that is top-level
    /// primitive `id`, with how its t map to the world ray's
    /// ([`ObjectT::world`]), that object and its mesh.
    fn object_ray(&self, r: &Ray, id: usize) -> (Ray, ObjectT, &TopInstance, &MeshBvh) {
        let instance = &self.instances[self.top.primitive_indices[id] as usize];
        let mesh = &self.meshes[instance.mesh as usize];
        if instance.identity {
            return (*r, ObjectT { per_world: 1.0, backup: 0.0 }, instance, mesh);
        }
        let to_object = instance.to_object;
        let origin = to_object.transform_point3(Vec3::from(r.origin));
        let direction = to_object.transform_vector3(Vec3::from(r.direction));
        // Unit again: obvhs takes the inverse of a direction component
        // under f32::EPSILON as 1 / EPSILON, so a direction an object's
        // scale shrank (a component of 0.1 in an object scaled 10^7)
        // missed boxes it crosses. Its t are then in the object's lengths,
        // so it starts BACKUP of those further back too (obvhs's node test,
        // see BACKUP); `ObjectT::world` turns them back into the world ray's.
        let per_world = direction.length();
        let per_world = if per_world.is_finite() && per_world > 0.0 { per_world } else { 1.0 };
        let unit = direction / per_world;
        let local = Ray::new(
            (origin - unit * BACKUP).into(),
            robust_direction(unit),
            r.tmin * per_world + BACKUP,
            r.tmax * per_world + BACKUP,
        );
        let object_t = ObjectT { per_world, backup: BACKUP };
        (local, object_t, instance, mesh)
    }

    /// Distance to a candidate hit of the mesh's triangle `id` (a BVH
    /// primitive index) that exists there and is not `skip` (the world
    /// triangle a ray leaves), and that triangle's local index.
    fn candidate(
        &self,
        r: &Ray,
        instance: &TopInstance,
        mesh: &MeshBvh,
        id: usize,
        skip: Option<u32>,
    ) -> (f32, usize) {
        let local = mesh.bvh.primitive_indices[id] as usize;
        if skip == Some(instance.first_triangle + local as u32) {
            return (f32::INFINITY, local);
        }
        let tri = &mesh.triangles[local];
        let d = watertight_intersect(tri, r);
        if d.is_finite() && self.masks.any() {
            let material = instance.material.unwrap_or(mesh.material[local]);
            let at = || {
                let b = barycentric(tri, Vec3::from(r.origin + r.direction * d));
                let b = [1.0 - b.x - b.y, b.x, b.y];
                let uvs = &mesh.uvs[local];
                let alpha = mesh.alphas.get(local).map_or(1.0, |a| {
                    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
                });
                (uvs[0] * b[0] + uvs[1] * b[1] + uvs[2] * b[2], alpha)
            };
            if !self.masks.exists(material, at) {
                return (f32::INFINITY, local);
            }
        }
        (d, local)
    }

    /// The closest hit along `dir` (unit) from `origin` within (tmin, tmax).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        self.closest(origin, dir, tmin, tmax, None)
    }

    /// The closest hit of a ray that leaves triangle `leaving` at `origin`
    /// (on it): that triangle is skipped instead of offsetting the origin by
    /// a distance that could jump through a fixture thinner than it; hits
    /// count from a few ulps ([`SceneBvh::lift`]) along the ray.
    pub fn intersect_leaving(&self, origin: Vec3, dir: Vec3, leaving: u32) -> Option<Hit> {
        self.closest(origin, dir, self.lift(origin), f32::INFINITY, Some(leaving))
    }

    fn closest(
        &self,
        origin: Vec3,
        dir: Vec3,
        tmin: f32,
        tmax: f32,
        skip: Option<u32>,
    ) -> Option<Hit> {
        let ray = backed_up_ray(origin, dir, tmin, tmax);
        let mut hit = RayHit::none();
        // The nearest triangle so far: (instance index, local triangle, t).
        let mut nearest: Option<(usize, usize)> = None;
        let found = self.top.ray_traverse(ray, &mut hit, |r, id| {
            let (local_ray, object_t, instance, mesh) = self.object_ray(r, id);
            let mut local_hit = RayHit::none();
            let mut triangle = 0;
            let found = mesh.bvh.ray_traverse(local_ray, &mut local_hit, |lr, lid| {
                let (d, local) = self.candidate(lr, instance, mesh, lid, skip);
                if d < lr.tmax {
                    triangle = local;
                }
                d
            });
            if found {
                nearest = Some((self.top.primitive_indices[id] as usize, triangle));
                object_t.world(local_hit.t)
            } else {
                f32::INFINITY
            }
        });
        let (instance, local) = nearest.filter(|_| found)?;
        let top = &self.instances[instance];
        let tri = &self.meshes[top.mesh as usize].triangles[local];
        let p = top
            .to_object
            .transform_point3(Vec3::from(ray.origin + ray.direction * hit.t));
        Some(Hit {
            t: hit.t - BACKUP,
            triangle: top.first_triangle + local as u32,
            barycentric: barycentric(tri, p),
        })
    }

    /// The closest hit the camera sees: like [`SceneBvh::intersect`], but
    /// one-sided surfaces seen from behind are passed through (as the
    /// G-buffer culls them).
    pub fn intersect_camera(&self, scene: &Scene, origin: Vec3, dir: Vec3) -> Option<Hit> {
        let mut tmin = 0.0;
        for _ in 0..64 {
            let hit = self.intersect(origin, dir, tmin, f32::INFINITY)?;
            let s = self.surface(scene, &hit, -dir);
            if s.front || s.double_sided {
                return Some(hit);
            }
            tmin = hit.t + RAY_EPSILON * (self.floor + hit.t);
        }
        None
    }

    /// Whether the segment from `a` to `b` is blocked. Both ends must be
    /// off any surface already (offset points, lights, the camera): only a
    /// few ulps ([`SceneBvh::lift`]) at each end are left out, so that the segment
    /// cannot slip past the edge of a thin wall beside its start.
    pub fn occluded(&self, a: Vec3, b: Vec3) -> bool {
        self.segment_blocked(a, b, None)
    }

    /// Whether the segment from `a` to `b` is blocked by a triangle other
    /// than `on`, the one an end lies on: skipped, that end needs no offset
    /// that could cross a fixture thinner than it.
    pub fn occluded_except(&self, a: Vec3, b: Vec3, on: u32) -> bool {
        self.segment_blocked(a, b, Some(on))
    }

    fn segment_blocked(&self, a: Vec3, b: Vec3, skip: Option<u32>) -> bool {
        let d = b - a;
        let len = d.length();
        let (tmin, tmax) = (self.lift(a), len - self.lift(b));
        // (A zero or non-finite length leaves nothing to block.)
        if tmax.is_nan() || tmax <= tmin {
            return false;
        }
        let ray = backed_up_ray(a, d / len, tmin, tmax);
        !self.top.ray_traverse_miss(ray, |r, id| {
            let (local_ray, _, instance, mesh) = self.object_ray(r, id);
            let blocked = !mesh.bvh.ray_traverse_miss(local_ray, |lr, lid| {
                self.candidate(lr, instance, mesh, lid, skip).0
            });
            if blocked {
                r.tmin
            } else {
                f32::INFINITY
            }
        })
    }

    /// Whether a ray along `dir` that meets triangle `t` meets its back (the
    /// side its vertex normals do not point to, judged per triangle:
    /// [`Scene::front_normal`]).
    pub fn meets_back(scene: &Scene, t: u32, dir: Vec3) -> bool {
        scene.front_normal(t as usize).dot(dir) > 0.0
    }

    /// The share of the 14 rays from `p` (the 6 axes and the 8 diagonals,
    /// turned) that meet the back of a surface ([`SceneBvh::meets_back`]):
    /// 1 deep inside a closed mesh whose normals point out, 0 in a room
    /// whose walls face in. Rays that meet nothing count as outside.
    pub fn enclosed_fraction(&self, scene: &Scene, p: Vec3) -> f32 {
        let back = ENCLOSURE_DIRECTIONS
            .iter()
            .filter(|&&dir| {
                self.intersect(p, dir, 0.0, f32::INFINITY)
                    .is_some_and(|hit| Self::meets_back(scene, hit.triangle, dir))
            })
            .count();
        back as f32 / ENCLOSURE_DIRECTIONS.len() as f32
    }

    /// Calls `crossing(triangle, t)` for every triangle that the ray from
    /// `p` along `dir` (unit) crosses beyond `tmin`, in no particular order.
    pub fn crossings(&self, p: Vec3, dir: Vec3, tmin: f32, mut crossing: impl FnMut(u32, f32)) {
        let ray = backed_up_ray(p, dir, tmin, f32::INFINITY);
        self.top.ray_traverse_anyhit(ray, |r, id| {
            let (local_ray, object_t, instance, mesh) = self.object_ray(r, id);
            mesh.bvh.ray_traverse_anyhit(local_ray, |lr, lid| {
                let (t, local) = self.candidate(lr, instance, mesh, lid, None);
                if t.is_finite() {
                    crossing(instance.first_triangle + local as u32, object_t.world(t) - BACKUP);
                }
            });
        });
    }

    /// The point of `hit` moved, if need be, to at least `d` from every edge
    /// of its triangle (to its incentre if the triangle is narrower): a
    /// point on an edge of a thin box lies in the plane of the next face,
    /// where no offset along its own normal separates it from that face.
    pub fn inset(&self, hit: &Hit, d: f32) -> Vec3 {
        let v = self.world_triangle(hit.triangle);
        let area2 = (v[1] - v[0]).cross(v[2] - v[0]).length();
        // Edge i is opposite vertex i; b_i = (distance to it) |edge i| / (2A).
        let edge = [
            (v[2] - v[1]).length(),
            (v[0] - v[2]).length(),
            (v[1] - v[0]).length(),
        ];
        let (u, w) = (hit.barycentric.x, hit.barycentric.y);
        let b = [1.0 - u - w, u, w];
        let least = edge.map(|e| d * e / area2.max(1e-30));
        let least_sum: f32 = least.iter().sum();
        let b = if least_sum.is_nan() || least_sum >= 1.0 {
            let perimeter: f32 = edge.iter().sum();
            edge.map(|e| e / perimeter.max(1e-30))
        } else {
            let raised = [0, 1, 2].map(|i| b[i].max(least[i]));
            let excess = raised.iter().sum::<f32>() - 1.0;
            let free: f32 = (0..3).map(|i| raised[i] - least[i]).sum();
            [0, 1, 2].map(|i| raised[i] - excess * (raised[i] - least[i]) / free.max(1e-30))
        };
        v[0] * b[0] + v[1] * b[1] + v[2] * b[2]
    }

    /// The surface at `hit`, seen from direction `toward` (unit, pointing
    /// away from the surface).
    pub fn surface(&self, scene: &Scene, hit: &Hit, toward: Vec3) -> Surface {
        // Interpolated in object space, then moved to the world once (not
        // each corner: a third of the path tracer's time went there).
        let (instance, local) = scene.instances().locate(hit.triangle);
        let mesh = &scene.meshes()[instance.mesh as usize];
        let corner = &mesh.indices[local as usize * 3..local as usize * 3 + 3];
        let v = |k: usize| &mesh.vertices[corner[k] as usize];
        let place = &instance.placement;
        let (u, w) = (hit.barycentric.x, hit.barycentric.y);
        let b0 = 1.0 - u - w;
        let p = |k: usize| Vec3::from(v(k).position);
        let n = |k: usize| Vec3::from(v(k).normal);
        let position = place.transform.transform_point3(p(0) * b0 + p(1) * u + p(2) * w);
        // (Its sign is set below: a mirror's flips it.)
        let mut geometric_normal =
            (place.normal_matrix * (p(1) - p(0)).cross(p(2) - p(0))).normalize_or_zero();
        let interpolated = (place.normal_matrix * (n(0) * b0 + n(1) * u + n(2) * w))
            .try_normalize()
            .unwrap_or(geometric_normal);
        let uv = Vec2::from(v(0).uv) * b0 + Vec2::from(v(1).uv) * u + Vec2::from(v(2).uv) * w;
        let color = v(0).color() * b0 + v(1).color() * u + v(2).color() * w;
        let object_tangent = Vec4::from(v(0).tangent) * b0
            + Vec4::from(v(1).tangent) * u
            + Vec4::from(v(2).tangent) * w;
        let tangent = if object_tangent == Vec4::ZERO {
            Vec4::ZERO
        } else {
            place
                .transform
                .transform_vector3(object_tangent.truncate())
                .normalize_or_zero()
                .extend(object_tangent.w * place.handedness)
        };
        let material = &scene.materials[place.material.unwrap_or(v(0).material) as usize];
        let front = interpolated.dot(toward) >= 0.0;
        let mut normal = shading::shading_normal(scene, material, uv, interpolated, tangent);
        if geometric_normal.dot(toward) < 0.0 {
            geometric_normal = -geometric_normal;
        }
        if !front {
            normal = -normal;
        }
        let brdf = shading::brdf(scene, material, uv, color);
        let emission = if front || material.double_sided {
            shading::emission(scene, material, uv)
        } else {
            Vec3::ZERO
        };
        Surface {
            position,
            normal,
            geometric_normal,
            albedo: brdf.base,
            brdf,
            wo: toward.normalize_or_zero(),
            emission,
            front,
            double_sided: material.double_sided,
        }
    }
}

/// How an object ray's t ([`SceneBvh::object_ray`]) map to its world
/// ray's: it runs `per_world` object lengths per world length and starts
/// `backup` of them further back (none for objects without a transform,
/// whose rays are the world's).
#[derive(Clone, Copy)]
struct ObjectT {
    per_world: f32,
    backup: f32,
}

impl ObjectT {
    /// The world ray's t of the object ray's `t`.
    fn world(self, t: f32) -> f32 {
        (t - self.backup) / self.per_world
    }
}

/// How far behind its origin every ray starts: obvhs's wide-BVH traversal
/// skips boxes nearer than 1e-4 along a ray (a fixed epsilon in its node
/// test, whatever the ray's tmin), which would let a ray that starts less
/// than 0.1 mm from a wall pass through it.
const BACKUP: f32 = 2e-4;

/// The ray from `origin` along `dir` (unit) over (tmin, tmax), started
/// [`BACKUP`] behind its origin with the interval shifted to match.
fn backed_up_ray(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Ray {
    Ray::new(
        (origin - dir * BACKUP).into(),
        robust_direction(dir),
        tmin + BACKUP,
        tmax + BACKUP,
    )
}

/// A ray direction without exact zeros (the BVH's slab test divides by them).
fn robust_direction(d: Vec3) -> Vec3A {
    let fix = |c: f32| if c == 0.0 { 1e-20 } else { c };
    Vec3A::new(fix(d.x), fix(d.y), fix(d.z))
}

/// The triangles of `mesh` that are not exact copies of an earlier one:
/// the same corners in the same winding (from any corner), with the same
/// UVs and alphas (the alpha test's inputs) and material. A copy changes
/// no ray's hit, only which of two equal triangles it names.
fn first_copies(mesh: &Mesh) -> Vec<u32> {
    // A corner as bits, and a triangle from its least corner on.
    let corner = |i: u32| {
        let v = &mesh.vertices[i as usize];
        let [x, y, z] = v.position.map(f32::to_bits);
        let [u, w] = v.uv.map(f32::to_bits);
        [x, y, z, u, w, v.color[3] as u32, v.material]
    };
    first_of_each(mesh.indices.len() / 3, |t| {
        let c = [0, 1, 2].map(|k| corner(mesh.indices[3 * t + k]));
        let first = (0..3).min_by_key(|&k| c[k]).unwrap_or(0);
        std::array::from_fn::<u32, 21, _>(|j| c[(first + j / 7) % 3][j % 7])
    })
}

/// Of `count` items, those whose `key` no earlier item has, in order:
/// sorted by the keys' hashes (in parallel), then each run of one hash
/// compared key by key (a mesh of 980,000 triangles' BVH took 0.07 s
/// more on 2 cores, 1.09x; with a hash map, 0.35 s).
fn first_of_each<const N: usize>(count: usize, key: impl Fn(usize) -> [u32; N] + Sync) -> Vec<u32> {
    // Keys one hash shares that are told apart before the rest of its run
    // counts as distinct (only crafted keys collide).
    const DISTINCT_PER_HASH: usize = 8;
    let hash = |k: &[u32; N]| {
        k.chunks(2).fold(0u64, |h, pair| {
            let word = pair[0] as u64 | (pair.get(1).copied().unwrap_or(0) as u64) << 32;
            super::sampling::hash64(h ^ word)
        })
    };
    let mut order: Vec<(u64, u32)> = (0..count as u32)
        .into_par_iter()
        .map(|t| (hash(&key(t as usize)), t))
        .collect();
    order.par_sort_unstable();
    let mut copy = vec![false; count];
    for run in order.chunk_by(|a, b| a.0 == b.0).filter(|run| run.len() > 1) {
        // In index order: an item equal to one kept before it is a copy.
        let mut kept: Vec<[u32; N]> = Vec::new();
        for &(_, t) in run {
            let k = key(t as usize);
            if kept.contains(&k) {
                copy[t as usize] = true;
            } else if kept.len() < DISTINCT_PER_HASH {
                kept.push(k);
            }
        }
    }
    (0..count as u32).filter(|&t| !copy[t as usize]).collect()
}

/// Box `b` of primitive `i` widened by a few ulps of its coordinates: a
/// flat triangle's or object's box (a wall's) has no thickness, and a ray
/// through its edge or corner failed the slab test by a rounding error
/// (rays slipped through a room's corners). Each face moves by 1-2 such
/// pads, as `i` picks: obvhs's PLOC merges mutual nearest neighbours, and
/// boxes that tie in every merge cost (copies of one triangle or object
/// stacked in one place, nested boxes) merged one pair a pass, quadratic
/// in their number (40 000 such boxes took 35 s to build, 0.04-0.13 s
/// with the pads told apart; `stacked_copies_build_in_linear_time`).
///
/// Boxes are also held within twice [`MAX_COORDINATE`] (a coordinate that
/// is not a number goes to that limit): scenes beyond it are refused
/// ([`Scene::validate`]), but a BVH may be built before that check (a
/// default light is placed by ray casts), and obvhs's builder overflowed
/// its stack on boxes whose area is infinite in `f32`.
fn padded(b: Aabb, i: usize) -> Aabb {
    let reach = Vec3A::splat(2.0 * MAX_COORDINATE);
    // `select` rather than `clamp`: a NaN compares false and takes the limit.
    let held = |v: Vec3A, limit: Vec3A| Vec3A::select(v.abs().cmple(reach), v, limit);
    let (min, max) = (held(b.min, -reach), held(b.max, reach));
    let pad = 1e-5 * min.abs().max(max.abs()).max_element() + 1e-12;
    let hash = super::sampling::hash64(i as u64);
    // Six factors in [1, 2), 10 bits each.
    let f = |k: u32| 1.0 + ((hash >> (10 * k)) & 1023) as f32 / 1024.0;
    Aabb::new(
        min - Vec3A::new(f(0), f(1), f(2)) * pad,
        max + Vec3A::new(f(3), f(4), f(5)) * pad,
    )
}

/// The distance along `r` to `tri` within the ray's (tmin, tmax), or
/// infinity: Woop, Benthin and Wald's watertight test (JCGT 2013). Edge
/// functions in a frame sheared so the ray runs along +z have the same
/// sign for a point on an edge shared by two triangles whichever of them is
/// tested, so no ray slips between them; obvhs's Möller–Trumbore test let
/// rays through seams (a Cornell room's corners, a quad's diagonal).
fn watertight_intersect(tri: &Triangle, r: &Ray) -> f32 {
    let d = r.direction;
    let a = d.abs();
    let kz = if a.x > a.y {
        if a.x > a.z { 0 } else { 2 }
    } else if a.y > a.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    // Keeps the sheared frame right-handed (the winding of the edge
    // functions) whichever way the ray runs along z.
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let sz = 1.0 / d[kz];
    let (sx, sy) = (d[kx] * sz, d[ky] * sz);
    let (va, vb, vc) = (tri.v0 - r.origin, tri.v1 - r.origin, tri.v2 - r.origin);
    let shear = |v: Vec3A| (v[kx] - sx * v[kz], v[ky] - sy * v[kz]);
    let ((ax, ay), (bx, by), (cx, cy)) = (shear(va), shear(vb), shear(vc));
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    // On an edge in f32: decide it in f64, as the paper does.
    if u == 0.0 || v == 0.0 || w == 0.0 {
        let e = |px: f32, py: f32, qx: f32, qy: f32| (px as f64 * qy as f64 - py as f64 * qx as f64) as f32;
        u = e(cx, cy, bx, by);
        v = e(ax, ay, cx, cy);
        w = e(bx, by, ax, ay);
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return f32::INFINITY;
    }
    let det = u + v + w;
    if det == 0.0 {
        return f32::INFINITY;
    }
    let t = (u * sz * va[kz] + v * sz * vb[kz] + w * sz * vc[kz]) / det;
    if t >= r.tmin && t <= r.tmax {
        t
    } else {
        f32::INFINITY
    }
}

/// Barycentric coordinates (of v1, v2) of point `p` in the triangle's plane.
fn barycentric(t: &Triangle, p: Vec3) -> Vec2 {
    let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
    let (e1, e2, ep) = (b - a, c - a, p - a);
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (dp1, dp2) = (ep.dot(e1), ep.dot(e2));
    let denom = d11 * d22 - d12 * d12;
    if denom.abs() < 1e-30 {
        return Vec2::ZERO;
    }
    let v = (d22 * dp1 - d12 * dp2) / denom;
    let w = (d11 * dp2 - d12 * dp1) / denom;
    Vec2::new(v, w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Object;

    #[test]
    fn hits_the_cornell_floor_and_sees_the_blocks_shadow() {
        let scene = crate::scene::builtin::cornell();
        let bvh = SceneBvh::new(&scene);
        let hit = bvh
            .intersect(Vec3::new(0.9, 1.0, 0.9), -Vec3::Y, 0.0, 10.0)
            .expect("floor");
        assert!((hit.t - 1.0).abs() < 1e-4);
        let b = hit.barycentric;
        assert!(
            b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0,
            "barycentrics {b}"
        );
        let s = bvh.surface(&scene, &hit, Vec3::Y);
        assert!((s.normal - Vec3::Y).length() < 1e-5);
        assert!((s.albedo - Vec3::splat(0.73)).length() < 1e-5);
        // The tall block stands between the floor behind it and the light.
        assert!(bvh.occluded(Vec3::new(-0.6, 0.001, -0.7), Vec3::new(0.0, 1.9, 0.0)));
        assert!(!bvh.occluded(Vec3::new(0.9, 0.01, 0.9), Vec3::new(0.0, 1.9, 0.0)));
        assert!(bvh.occluded(Vec3::new(-0.35, -0.5, -0.3), Vec3::new(-0.35, 1.9, -0.3)));
    }

    /// Triangles that share one box, and objects stacked on one another,
    /// build their BVHs: their boxes tied in every merge cost
    /// and PLOC merged one pair a pass (200 000 would take about 15
    /// minutes each; a hostile scene hung). The deadline, 120 s, is 150
    /// times what both builds take on 2 cores (0.8 s); with equal pads the
    /// test fails. It finds hangs, it times nothing.
    #[test]
    fn stacked_copies_build_in_linear_time() {
        let build = || {
            let mut scene = Scene::new("stacked");
            let white = scene.add_material(Vec3::splat(0.7), None);
            // 200 000 different triangles with one box: (0, 0), (1, 1) and
            // a third corner within.
            let n = 200_000;
            let mut corners = vec![Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0)];
            corners.extend((0..n).map(|i| {
                let f = (i as f32 + 0.5) / n as f32;
                Vec3::new(f, 1.0 - f * f, 0.0)
            }));
            let indices: Vec<u32> = (0..n as u32).flat_map(|i| [0, 1, i + 2]).collect();
            let normals = vec![Vec3::Z; corners.len()];
            scene.add_mesh(&corners, &normals, &[], &indices, Mat4::IDENTITY, white).unwrap();
            let one = [Vec3::ZERO, Vec3::X, Vec3::Y];
            let one = scene.add_mesh(&one, &[Vec3::Z; 3], &[], &[0, 1, 2], Mat4::IDENTITY, white);
            let mesh = scene.objects()[one.unwrap()].mesh;
            // Objects of one box, the flat triangle's: each scaled along z
            // its own way (exact copies would stay out of the top level).
            for k in 0..200_000 {
                let scale = Mat4::from_scale(Vec3::new(1.0, 1.0, 1.0 + k as f32 * 1e-3));
                scene.add_object(Object::new(mesh, scale)).unwrap();
            }
            let bvh = SceneBvh::new(&scene);
            bvh.intersect(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 0.0, 10.0).map(|h| h.t)
        };
        let (done, result) = std::sync::mpsc::channel();
        std::thread::spawn(move || done.send(build()));
        let hit = result.recv_timeout(Duration::from_secs(120)).expect("the BVHs build");
        assert!(hit.is_some_and(|t| (t - 1.0).abs() < 1e-5), "{hit:?}");
    }

    /// Exact copies of a triangle, and of an object, stay out of the BVH
    /// (a ray through a stack tested every copy); one wound the other way,
    /// or with another UV, or moved, stays in, and rays still hit the
    /// stack.
    #[test]
    fn exact_copies_stay_out_of_the_bvh() {
        let mut scene = Scene::new("copies");
        let white = scene.add_material(Vec3::splat(0.7), None);
        let corners = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO];
        let uvs = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.5]];
        let mut indices: Vec<u32> = Vec::new();
        for k in 0..1000 {
            // The same triangle from each of its corners in turn.
            indices.extend([[0, 1, 2], [1, 2, 0], [2, 0, 1]][k % 3]);
        }
        indices.extend([0, 2, 1]); // wound the other way
        indices.extend([3, 1, 2]); // another UV at one corner
        let normals = [Vec3::Z; 4];
        let o = scene.add_mesh(&corners, &normals, &uvs, &indices, Mat4::IDENTITY, white);
        let mesh = scene.objects()[o.unwrap()].mesh;
        assert_eq!(first_copies(&scene.meshes()[mesh]), vec![0, 1000, 1001]);
        // Objects too: 100 copies of the first and one moved stay 2.
        for _ in 0..100 {
            scene.add_object(Object::new(mesh, Mat4::IDENTITY)).unwrap();
        }
        let moved = Mat4::from_translation(Vec3::new(0.0, 0.0, -1e-3));
        scene.add_object(Object::new(mesh, moved)).unwrap();
        let bvh = SceneBvh::new(&scene);
        assert_eq!(bvh.top.primitive_indices.len(), 2);
        let hit = bvh.intersect(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z, 0.0, 10.0);
        assert!(hit.is_some_and(|h| (h.t - 1.0).abs() < 1e-5), "{:?}", hit.map(|h| h.t));
        assert!(bvh.occluded(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.2, 0.2, -1.0)));
    }

    /// Rays aimed exactly at the seams of an empty Cornell room (its
    /// corners, the edges where walls meet, each wall's diagonal, shared by
    /// its two triangles) hit it: a test that let such a ray through both
    /// triangles at an edge left holes in the path tracer's images.
    #[test]
    fn rays_through_shared_edges_and_corners_hit() {
        let mut scene = Scene::new("room");
        let white = scene.add_material(Vec3::splat(0.7), None);
        // Floor, ceiling, back, left and right walls: corner, u, v (u x v
        // into the room), as the built-in rooms.
        let walls = [
            (Vec3::new(-1.0, 0.0, 1.0), Vec3::X * 2.0, -Vec3::Z * 2.0),
            (Vec3::new(-1.0, 2.0, -1.0), Vec3::X * 2.0, Vec3::Z * 2.0),
            (Vec3::new(-1.0, 0.0, -1.0), Vec3::X * 2.0, Vec3::Y * 2.0),
            (Vec3::new(-1.0, 0.0, 1.0), -Vec3::Z * 2.0, Vec3::Y * 2.0),
            (Vec3::new(1.0, 0.0, -1.0), Vec3::Z * 2.0, Vec3::Y * 2.0),
        ];
        for (c, u, v) in walls {
            let n = u.cross(v).normalize();
            scene
                .add_mesh(&[c, c + u, c + u + v, c + v], &[n; 4], &[], &[0, 1, 2, 0, 2, 3], Mat4::IDENTITY, white)
                .unwrap();
        }
        let bvh = SceneBvh::new(&scene);
        let origins = [
            Vec3::new(0.0, 1.0, 0.9),
            Vec3::new(0.3, 0.7, 0.5),
            Vec3::new(-0.45, 1.3, 0.2),
            Vec3::new(0.0, 1.0, 3.5),
        ];
        let mut targets = Vec::new();
        for k in 0..=16 {
            let f = k as f32 / 16.0;
            let (a, b) = (2.0 * f - 1.0, 2.0 * f);
            // The back wall's edges and its diagonals.
            targets.extend([
                Vec3::new(-1.0, b, -1.0),
                Vec3::new(1.0, b, -1.0),
                Vec3::new(a, 0.0, -1.0),
                Vec3::new(a, 2.0, -1.0),
                Vec3::new(a, b, -1.0),
                Vec3::new(a, 2.0 - b, -1.0),
            ]);
            // The side walls' edges with the floor and the ceiling (short
            // of the open front, where a ray at the rim may pass outside).
            if k == 16 {
                continue;
            }
            targets.extend([
                Vec3::new(-1.0, 0.0, a),
                Vec3::new(1.0, 0.0, a),
                Vec3::new(-1.0, 2.0, a),
                Vec3::new(1.0, 2.0, a),
            ]);
        }
        let mut missed = Vec::new();
        for o in origins {
            for &t in &targets {
                let d = t - o;
                let hit = bvh.intersect(o, d.normalize(), 0.0, 100.0);
                if hit.is_none_or(|h| (h.t - d.length()).abs() > 1e-3) {
                    missed.push((o, t, hit.map(|h| h.t)));
                }
            }
        }
        assert!(missed.is_empty(), "{} of {} rays: {missed:?}", missed.len(), origins.len() * targets.len());
    }

    /// A ray into a scaled object meets what it crosses, near and far. Its
    /// direction in object space was the world's shrunk by the scale, and
    /// obvhs takes the inverse of components under f32::EPSILON as 1 /
    /// EPSILON, which narrows a box's slab: a quad scaled 2^20 or 10^7 was
    /// missed from 10 of its half-widths away, and the thin box scene
    /// scaled 2^20 had 3.8% of its emitter samples' enclosure rays miss a
    /// ceiling 1.2 m (scaled) away.
    #[test]
    fn rays_meet_scaled_objects() {
        for s in [1e-3f32, 1.0, 1e3, 1048576.0, 1e7] {
            let mut scene = Scene::new("scaled quad");
            let white = scene.add_material(Vec3::splat(0.7), None);
            let corners = [
                Vec3::new(-1.0, -1.0, 0.0),
                Vec3::new(1.0, -1.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(-1.0, 1.0, 0.0),
            ];
            scene
                .add_mesh(&corners, &[Vec3::Z; 4], &[], &[0, 1, 2, 0, 2, 3], Mat4::from_scale(Vec3::splat(s)), white)
                .unwrap();
            let bvh = SceneBvh::new(&scene);
            // From (0, 0, 10) towards (0.5, 0, 0) and (0.05, 0.01, 0) (object space).
            for target in [Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.05, 0.01, 0.0)] {
                let origin = Vec3::Z * 10.0 * s;
                let dir = (target * s - origin).normalize();
                let expected = (target * s - origin).length();
                let hit = bvh.intersect(origin, dir, 0.0, f32::INFINITY);
                let t = hit.map(|h| h.t);
                assert!(t.is_some_and(|t| (t / expected - 1.0).abs() < 1e-4), "scale {s}, to {target}: {t:?} for {expected}");
                let mut crossed = Vec::new();
                bvh.crossings(origin, dir, 0.0, |_, t| crossed.push(t / expected));
                assert!(crossed.len() == 1 && (crossed[0] - 1.0).abs() < 1e-4, "scale {s}, to {target}: {crossed:?}");
                assert!(bvh.occluded(origin, origin + dir * 2.0 * expected), "scale {s}, to {target}");
                // A hit a ten-thousandth of the way (obvhs skips boxes
                // nearer than 1e-4 of its rays' t).
                let near = Vec3::Z * 10.0 * s * 1e-4;
                let t = bvh.intersect(near, dir, 0.0, f32::INFINITY).map(|h| h.t / (1e-4 * expected));
                assert!(t.is_some_and(|t| (t - 1.0).abs() < 1e-3), "scale {s}, near, to {target}: {t:?}");
            }
        }
    }

    /// Geometry beyond MAX_COORDINATE is refused (`Scene::validate`,
    /// `SceneBvh::try_moved`), and a BVH built or moved there before the
    /// check (a default light is placed by ray casts) still builds: boxes
    /// 10^20 m wide made obvhs's area costs infinite, and its conversion
    /// overflowed the stack (10^22) or indexed out of bounds (10^20).
    #[test]
    fn geometry_out_of_reach_is_refused_and_builds_no_broken_bvh() {
        let mut scene = Scene::new("far");
        let white = scene.add_material(Vec3::splat(0.7), None);
        // A bumpy 150 x 150 grid, as a height field's triangles are.
        let n = 150;
        let corners: Vec<Vec3> = (0..(n + 1) * (n + 1))
            .map(|k| {
                let (i, j) = (k % (n + 1), k / (n + 1));
                let bump = ((i * 7 + j * 13) % 5) as f32 / (5 * n) as f32;
                Vec3::new(i as f32 / n as f32 - 0.5, bump, j as f32 / n as f32 - 0.5)
            })
            .collect();
        let indices: Vec<u32> = (0..n * n)
            .flat_map(|k| {
                let a = (k / n * (n + 1) + k % n) as u32;
                let c = a + n as u32 + 1;
                [a, c, a + 1, a + 1, c, c + 1]
            })
            .collect();
        let normals = vec![Vec3::Y; corners.len()];
        let grid = scene.add_mesh(&corners, &normals, &[], &indices, Mat4::IDENTITY, white).unwrap();
        assert!(scene.validate().is_ok());
        let bvh = SceneBvh::new(&scene);
        // Moved 10^20 m away: refused, naming the object.
        scene.set_transform(grid, Mat4::from_scale(Vec3::splat(1e10)) * Mat4::from_translation(Vec3::splat(1e10))).unwrap();
        let e = bvh.try_moved(&scene).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains("object 0") && e.contains("beyond the 1e9 m"), "{e}");
        assert!(scene.validate().is_err());
        let _ = bvh.moved(&scene);
        // Its mesh itself that far, or not a number: refused, and no panic.
        scene.set_transform(grid, Mat4::IDENTITY).unwrap();
        for far in [1e20, 1e22, f32::NAN] {
            let mut far_scene = scene.clone();
            for v in &mut far_scene.mesh_mut(0).unwrap().vertices {
                v.position = (Vec3::from(v.position) * far).into();
            }
            let e = far_scene.validate().expect_err("refused").to_string();
            assert!(e.contains("mesh 0"), "{far}: {e}");
            let _ = SceneBvh::new(&far_scene);
        }
        // Within the limit it stays a scene.
        scene.set_transform(grid, Mat4::from_translation(Vec3::splat(9e8))).unwrap();
        assert!(scene.validate().is_ok());
        assert!(bvh.try_moved(&scene).is_ok());
    }
}
