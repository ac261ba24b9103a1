//! Ray casting against the scene's triangles with a BVH from `obvhs`
//! (compressed wide BVH8), plus surface interactions at hits.

use std::time::Duration;

use glam::{Vec2, Vec3, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::{Ray, RayHit};
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::scene::{Scene, Texture};

/// A closest hit.
#[derive(Clone, Copy, Debug)]
pub struct Hit {
    /// Distance along the (unit) ray.
    pub t: f32,
    /// Triangle index into the scene's index list / 3.
    pub triangle: u32,
    /// Barycentric coordinates (of vertices 1 and 2).
    pub barycentric: Vec2,
}

/// Everything about a surface point the light transport needs.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// World position.
    pub position: Vec3,
    /// Interpolated shading normal, flipped to the side `toward` came from.
    pub normal: Vec3,
    /// Geometric normal, on the same side as `normal`.
    pub geometric_normal: Vec3,
    /// Linear albedo (base colour x texture).
    pub albedo: Vec3,
}

/// A BVH over every triangle of a scene.
pub struct SceneBvh {
    bvh: CwBvh,
    triangles: Vec<Triangle>,
}

/// Relative offset used to leave surfaces without self-intersection.
pub const RAY_EPSILON: f32 = 1e-4;

impl SceneBvh {
    /// Builds the BVH (medium-quality PLOC build).
    pub fn new(scene: &Scene) -> Self {
        let triangles: Vec<Triangle> = scene
            .indices
            .chunks_exact(3)
            .map(|t| {
                let p = |i: u32| Vec3A::from(scene.vertices[i as usize].position);
                Triangle {
                    v0: p(t[0]),
                    v1: p(t[1]),
                    v2: p(t[2]),
                }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(
            &triangles,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        Self { bvh, triangles }
    }

    /// Closest hit along `origin + t * dir` for t in (tmin, tmax).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let ray = Ray::new(origin.into(), robust_direction(dir), tmin, tmax);
        let mut hit = RayHit::none();
        let found = self.bvh.ray_traverse(ray, &mut hit, |r, id| {
            self.triangles[self.bvh.primitive_indices[id] as usize].intersect(r)
        });
        if !found {
            return None;
        }
        let triangle = self.bvh.primitive_indices[hit.primitive_id as usize];
        let tri = &self.triangles[triangle as usize];
        let p = Vec3::from(ray.origin + ray.direction * hit.t);
        Some(Hit {
            t: hit.t,
            triangle,
            barycentric: barycentric(tri, p),
        })
    }

    /// Whether anything blocks the segment between `a` and `b` (endpoints excluded
    /// by a small relative margin).
    pub fn occluded(&self, a: Vec3, b: Vec3) -> bool {
        let d = b - a;
        let len = d.length();
        if len <= 0.0 {
            return false;
        }
        let dir = d / len;
        let eps = RAY_EPSILON * (1.0 + len);
        let ray = Ray::new(a.into(), robust_direction(dir), eps, len - eps);
        !self.bvh.ray_traverse_miss(ray, |r, id| {
            self.triangles[self.bvh.primitive_indices[id] as usize].intersect(r)
        })
    }

    /// The surface at `hit`, with normals facing `toward` (a direction from the
    /// surface, e.g. back along the incoming ray).
    pub fn surface(&self, scene: &Scene, hit: &Hit, toward: Vec3) -> Surface {
        let t = &scene.indices[hit.triangle as usize * 3..hit.triangle as usize * 3 + 3];
        let v = |k: usize| &scene.vertices[t[k] as usize];
        let (u, w) = (hit.barycentric.x, hit.barycentric.y);
        let b0 = 1.0 - u - w;
        let p = |k: usize| Vec3::from(v(k).position);
        let n = |k: usize| Vec3::from(v(k).normal);
        let position = p(0) * b0 + p(1) * u + p(2) * w;
        let mut geometric_normal = (p(1) - p(0)).cross(p(2) - p(0)).normalize_or_zero();
        let mut normal = (n(0) * b0 + n(1) * u + n(2) * w)
            .try_normalize()
            .unwrap_or(geometric_normal);
        if geometric_normal.dot(toward) < 0.0 {
            geometric_normal = -geometric_normal;
        }
        if normal.dot(toward) < 0.0 {
            normal = -normal;
        }
        let uv = Vec2::from(v(0).uv) * b0 + Vec2::from(v(1).uv) * u + Vec2::from(v(2).uv) * w;
        let material = &scene.materials[v(0).material as usize];
        let mut albedo = material.base_color.truncate();
        if let Some(tex) = material.texture {
            albedo *= sample_bilinear(&scene.textures[tex], uv);
        }
        Surface {
            position,
            normal,
            geometric_normal,
            albedo,
        }
    }
}

/// Replaces exact zeros in a direction by a tiny value: the wide BVH's slab
/// test computes 0 x inf = NaN for axis-parallel rays on flat boxes.
fn robust_direction(d: Vec3) -> Vec3A {
    let fix = |c: f32| if c == 0.0 { 1e-20 } else { c };
    Vec3A::new(fix(d.x), fix(d.y), fix(d.z))
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

/// sRGB-decoded, bilinearly filtered, repeating texture lookup (as the GPU's
/// sRGB format and linear sampler do).
pub fn sample_bilinear(tex: &Texture, uv: Vec2) -> Vec3 {
    let decode = |c: u8| {
        let s = c as f32 / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    };
    let (w, h) = (tex.width as i64, tex.height as i64);
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let texel = |xi: i64, yi: i64| {
        let (xi, yi) = (xi.rem_euclid(w), yi.rem_euclid(h));
        let i = ((yi * w + xi) * 4) as usize;
        Vec3::new(
            decode(tex.rgba8[i]),
            decode(tex.rgba8[i + 1]),
            decode(tex.rgba8[i + 2]),
        )
    };
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
    let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
    top.lerp(bottom, fy)
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
