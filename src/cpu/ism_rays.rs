//! The coarse ray-cast layer of each VPL's imperfect shadow map.
//!
//! Scene points are spread by area, so an occluder close to a VPL gets few
//! of them although it covers much of the VPL's view: a lamp's shade, the
//! ceiling 1 cm above an emissive quad, the inside of a thin box. Pull-push
//! then fills the holes with the far surfaces behind it, and the VPL lights
//! the room through the occluder. Each VPL's tile therefore starts from
//! exact surfaces on a coarse grid of its paraboloid, [`BASE_GRID`]²
//! blocks, cast on the CPU with the BVH: each texel takes the plane of the
//! surface its nearest corner ray met (exact wherever one flat surface
//! covers the texel and that corner; along an occluder's silhouette it
//! errs either way by half a block), and the splatted points add the detail
//! finer than a block (atomicMin keeps the nearest). `ism_base.comp`
//! evaluates the plane at each texel's centre ray. (Each block taking its
//! farthest corner, as before planes, erred towards visibility only: on the
//! slab room a quarter of the occluded VPL light came through.)

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::bvh::{SceneBvh, RAY_EPSILON};
use super::points::pack_normal;
use super::sampling::basis;
use super::vpl::Vpl;
use crate::scene::Bounds;

/// CornerPlanes per side of a tile's ray-cast layer.
pub const BASE_GRID: u32 = 8;

/// Rays a VPL casts for its layer: the corners of the blocks.
pub const RAYS_PER_VPL: u32 = (BASE_GRID + 1) * (BASE_GRID + 1);

/// Where one corner ray of a VPL's layer stops: its distance and the plane
/// of the surface it met.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Distance (m).
    pub t: f32,
    /// The plane's offset from the VPL along `normal`: dot(normal, hit -
    /// VPL) (m).
    pub offset: f32,
    /// The surface's normal ([`pack_normal`]), 0 where the ray met nothing.
    pub normal: u32,
}

/// One block of a VPL's layer as the GPU reads it (`ism_base.comp`): the
/// plane of the surface its farthest corner ray met.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct CornerPlane {
    /// The plane's offset from the VPL along its normal (m); without a
    /// plane, the corner's distance.
    pub plane: f32,
    /// The plane's normal ([`pack_normal`]), 0: none (the rays met nothing).
    pub normal: u32,
}

/// Unit direction leaving a VPL with normal `n` through paraboloid
/// coordinate `uv` in `[0, 1]²` (the inverse of `ism_paraboloid` in
/// shaders/include/ism.glsl); points outside the unit disc are moved onto
/// it, just above the horizon.
pub fn paraboloid_direction(n: Vec3, uv: Vec2) -> Vec3 {
    let mut p = uv * 2.0 - 1.0;
    let r2 = p.length_squared();
    if r2 > 0.998 {
        p *= (0.998 / r2).sqrt();
    }
    let r2 = p.length_squared();
    let z = (1.0 - r2) / (1.0 + r2);
    let xy = p * (1.0 + z);
    let (t, b) = basis(n);
    (t * xy.x + b * xy.y + n * z).normalize()
}

/// The layer of every VPL, in their order: [`RAYS_PER_VPL`] corner planes
/// per VPL, row by row along the paraboloid's v then u ([`corner_planes`]); distance
/// `miss` where every corner ray of a block leaves the scene.
pub fn coarse_depths(bvh: &SceneBvh, vpls: &[Vpl], miss: f32) -> Vec<CornerPlane> {
    corner_planes(&corner_depths(bvh, vpls, miss, None))
}

/// Corner rays of earlier VPLs: their VPLs and [`corner_depths`], and the
/// world boxes where objects moved from and to since.
pub struct KnownCorners<'a> {
    /// The earlier VPLs.
    pub vpls: &'a [Vpl],
    /// Their corners.
    pub depths: &'a [Corner],
    /// Where moved objects were and are.
    pub moved: &'a [Bounds],
}

/// Where every VPL's [`RAYS_PER_VPL`] corner rays stop (distances capped
/// at `miss`). A VPL that `known` already had (same path and bounce, same
/// place and normal) casts again only the rays that meet a moved box
/// before their earlier hit: the others hit what they hit before.
pub fn corner_depths(
    bvh: &SceneBvh,
    vpls: &[Vpl],
    miss: f32,
    known: Option<KnownCorners<'_>>,
) -> Vec<Corner> {
    let n = RAYS_PER_VPL as usize;
    let g = BASE_GRID as usize;
    let earlier: std::collections::HashMap<(u64, u32), usize> = known
        .as_ref()
        .map(|k| {
            k.vpls
                .iter()
                .enumerate()
                .map(|(i, v)| ((v.path, v.bounce), i))
                .collect()
        })
        .unwrap_or_default();
    let none = Corner {
        t: 0.0,
        offset: 0.0,
        normal: 0,
    };
    let mut out = vec![none; vpls.len() * n];
    out.par_chunks_mut(n)
        .zip(vpls.par_iter())
        .for_each(|(corners, v)| {
            let origin =
                v.position + v.normal * RAY_EPSILON * (1.0 + v.position.abs().max_element());
            // Only the moved boxes in front of the VPL can meet its rays.
            let in_front = |b: &&Bounds| {
                (0..8).any(|i| {
                    let pick = |bit: u32, lo: f32, hi: f32| if i & bit == 0 { lo } else { hi };
                    let corner = Vec3::new(
                        pick(1, b.min.x, b.max.x),
                        pick(2, b.min.y, b.max.y),
                        pick(4, b.min.z, b.max.z),
                    );
                    (corner - origin).dot(v.normal) > 0.0
                })
            };
            let before = known.as_ref().and_then(|k| {
                let &i = earlier.get(&(v.path, v.bounce))?;
                let old = &k.vpls[i];
                let seen: Vec<&Bounds> = k.moved.iter().filter(in_front).collect();
                (old.position == v.position && old.normal == v.normal)
                    .then(|| (&k.depths[i * n..(i + 1) * n], seen))
            });
            if let Some((old, _)) = before.as_ref().filter(|(_, seen)| seen.is_empty()) {
                corners.copy_from_slice(old);
                return;
            }
            for (k, c) in corners.iter_mut().enumerate() {
                let uv = Vec2::new((k % (g + 1)) as f32, (k / (g + 1)) as f32) / g as f32;
                let dir = paraboloid_direction(v.normal, uv);
                if let Some((old, seen)) = &before {
                    if !seen
                        .iter()
                        .any(|b| super::vpl::ray_meets_box(origin, dir, old[k].t, b))
                    {
                        *c = old[k];
                        continue;
                    }
                }
                let hit = bvh
                    .intersect(origin, dir, 0.0, f32::INFINITY)
                    .filter(|hit| hit.t < miss);
                let missed = Corner {
                    t: miss,
                    offset: miss,
                    normal: 0,
                };
                *c = hit.map_or(missed, |hit| {
                    let normal = bvh.triangle_normal(hit.triangle);
                    let at = origin + dir * hit.t - v.position;
                    Corner {
                        t: hit.t,
                        offset: normal.dot(at),
                        normal: pack_normal(normal),
                    }
                });
            }
        });
    out
}

/// Each VPL's corner planes as the GPU reads them: [`RAYS_PER_VPL`] per
/// VPL, the plane each corner ray met (without one, its distance). Each
/// texel of the layer takes its nearest corner's.
pub fn corner_planes(corners: &[Corner]) -> Vec<CornerPlane> {
    corners
        .iter()
        .map(|c| CornerPlane {
            plane: if c.normal == 0 { c.t } else { c.offset },
            normal: c.normal,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mirror of `ism_paraboloid` (shaders/include/ism.glsl).
    fn paraboloid(w: Vec3, n: Vec3) -> Vec2 {
        let (t, b) = basis(n);
        let l = Vec3::new(w.dot(t), w.dot(b), w.dot(n));
        Vec2::new(l.x, l.y) / (1.0 + l.z) * 0.5 + 0.5
    }

    #[test]
    fn inverts_the_paraboloid() {
        for n in [Vec3::Y, -Vec3::Z, Vec3::new(0.3, -0.8, 0.52).normalize()] {
            for uv in [
                Vec2::new(0.5, 0.5),
                Vec2::new(0.2, 0.7),
                Vec2::new(0.9, 0.45),
            ] {
                let w = paraboloid_direction(n, uv);
                assert!(w.dot(n) > 0.0);
                assert!((paraboloid(w, n) - uv).length() < 1e-4, "{n} {uv}");
            }
        }
    }

    #[test]
    fn a_vpl_under_a_slab_sees_it_above_and_the_room_at_the_horizon() {
        // A VPL on the ceiling of the Cornell box looking down at a quad 1 cm
        // below it: the centre blocks hold 1 cm (the quad facing the VPL),
        // the rim blocks the walls.
        let mut scene = crate::scene::builtin::cornell();
        let m = scene.materials.len() as u32 - 1;
        let p = [
            Vec3::new(-0.3, 1.99, -0.3),
            Vec3::new(0.3, 1.99, -0.3),
            Vec3::new(0.3, 1.99, 0.3),
            Vec3::new(-0.3, 1.99, 0.3),
        ];
        scene
            .add_mesh(&p, &[], &[], &[0, 1, 2, 0, 2, 3], glam::Mat4::IDENTITY, m)
            .unwrap();
        let bvh = SceneBvh::new(&scene);
        let vpl = Vpl {
            position: Vec3::new(0.01, 2.0, 0.02),
            normal: -Vec3::Y,
            brdf: crate::cpu::brdf::Brdf::lambertian(Vec3::ONE),
            incident: -Vec3::Y,
            shading_normal: Vec3::ZERO,
            flux: Vec3::ONE,
            radius: 0.0,
            bounce: 1,
            path: 0,
        };
        let d = coarse_depths(&bvh, &[vpl], 100.0);
        let g = BASE_GRID as usize + 1;
        // The centre corner holds the quad's plane, 1 cm below the VPL (its
        // offset along the quad's normal, which may point either way).
        let centre = d[(g / 2) * g + g / 2];
        assert_ne!(centre.normal, 0, "centre block {centre:?}");
        assert!(
            (centre.plane.abs() - 0.01).abs() < 1e-4,
            "centre block {centre:?}"
        );
        // The rim corners hold the walls, farther away.
        let rim = d[(g / 2) * g];
        assert!(rim.plane.abs() > 0.5, "rim block {rim:?}");
    }
}
