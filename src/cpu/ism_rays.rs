//! The coarse ray-cast layer of each VPL's imperfect shadow map.
//!
//! Scene points are spread by area, so an occluder close to a VPL gets few
//! of them although it covers much of the VPL's view: a lamp's shade, the
//! ceiling 1 cm above an emissive quad, the inside of a thin box. Pull-push
//! then fills the holes with the far surfaces behind it, and the VPL lights
//! the room through the occluder. Each VPL's tile therefore starts from
//! exact distances on a coarse grid of its tile ([`projected_local`]), [`BASE_GRID`]²
//! blocks, cast on the CPU with the BVH: a block holds the farthest of the
//! distances at its four corners (so along an occluder's silhouette it errs
//! towards visibility, as pull-push does), and the splatted points add the
//! detail finer than a block (atomicMin keeps the nearest). A block also
//! says how squarely the surface it holds faces the VPL (the ISM test's
//! tolerance, `ism_tolerance` in shaders/include/ism.glsl), and where its
//! four corners met one plane (a wall, a floor), that plane: each texel
//! then starts from the plane's own distance along its centre ray and
//! the plane's normal, which the ISM test follows, instead of the
//! farthest corner.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::bvh::SceneBvh;
use super::sampling::basis;
use super::vpl::Vpl;
use crate::scene::Bounds;

/// Blocks per side of a tile's ray-cast layer.
pub const BASE_GRID: u32 = 8;

/// Rays a VPL casts for its layer: the corners of the blocks.
pub const RAYS_PER_VPL: u32 = (BASE_GRID + 1) * (BASE_GRID + 1);

/// How the splat and the layer combine in a tile of side `tile`: 0 where a
/// block spans at most 4x4 texels (the block starts its texels and the
/// splat's atomicMin keeps the nearer); in finer tiles, the fill keeps a
/// splatted surface up to this fraction of its block's distance behind
/// the block (`with_layer` in shaders/include/ism_fill.glsl). A block holds
/// its farthest corner, and where its surface lies beyond all four (a
/// concave crease, a curve) that shadowed it. Replayed at 64 texels and
/// 4096 points with back-face maps, 0, 0.2, 0.3, 0.5 and 1 passed 0.9877,
/// 0.9898, 0.9912, 0.9920 and 0.9924 of the open box's visible light and
/// leaked 0.024, 0.025, 0.027, 0.028 and 0.029; its 64 frames against
/// the path tracer (relMSE on 4x4 blocks) 0.00054 (0), 0.00033 (0.3),
/// 0.00031 (0.5 and 1), while the slab rooms leak more with more (0.134,
/// 0.137, 0.139 at 0.3, 0.5, 1): docs/accuracy.md, "Finer ISMs for frames
/// that converge". In 32-texel tiles 0.3 changed little either way
/// (`spheres` 0.963 / 0.099 -> 0.964 / 0.103).
pub fn layer_slack(tile: u32) -> f32 {
    if tile > 4 * BASE_GRID {
        0.5
    } else {
        0.0
    }
}

/// How far from the tile's centre a corner ray leaves (a fraction of the
/// inscribed disc's radius: 75.6 degrees from the VPL's normal), the
/// corners beyond it moved in to it. The map's last ring of blocks spans 49
/// to 90 degrees, and a block holds its farthest corner: with its outer
/// corners at the horizon, a quad 1 cm under a ceiling VPL, which hides
/// the room up to 88 degrees, vanished from that whole ring, and the room
/// was lit through it (a fixture 1 cm under the ceiling 1.13x the path
/// tracer's mean, relMSE on 4x4 blocks 0.115).
pub const CORNER_MAX_RADIUS: f32 = 1.0 - 1.0 / (4 * BASE_GRID) as f32;

/// Where one corner ray of a VPL's layer stops: its distance, |cos|
/// between the ray and the normal of the surface it met (-1: it met
/// nothing, or that is not known), and that normal (for the block's plane,
/// [`LayerBlock`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Corner {
    /// Distance (m).
    pub t: f32,
    /// |cos| between the ray and the surface's normal, or -1.
    pub facing: f32,
    /// The surface's unit geometric normal turned towards the VPL (zero
    /// where the ray met nothing).
    pub normal: Vec3,
}

impl Corner {
    /// A ray that met nothing within `miss` (m).
    fn missed(miss: f32) -> Corner {
        Corner {
            t: miss,
            facing: -1.0,
            normal: Vec3::ZERO,
        }
    }
}

/// One block of a VPL's layer as `ism_base.comp` reads it (`LayerBlock` in
/// shaders/include/ism.glsl), in 8 bytes (a slot holds one per block and
/// VPL: 4 MiB at 8192 VPLs): its farthest corner and, where all four
/// corners met one plane, that plane.
///
/// - No plane: `d` is the farthest corner's distance (m), `bits` holds
///   that corner's facing code (`ism_facing_code`) in its top 8 bits.
/// - A plane: `d` is minus its distance from the VPL (m), `bits` its unit
///   normal turned towards the VPL (its octahedral map, 12 bits a
///   coordinate, x in the low bits) and, in the top 8 bits, the farthest
///   corner's distance over the plane's, `ceil(32 log2)` of it.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LayerBlock {
    /// The farthest corner's distance, or minus the plane's (m).
    pub d: f32,
    /// A facing code, or a normal and a distance ratio.
    pub bits: u32,
}

impl LayerBlock {
    /// A block that holds nothing nearer than the atlas's far distance
    /// (a layer of no VPLs is one of these: a buffer is never empty).
    pub const NONE: LayerBlock = LayerBlock { d: 0.0, bits: 0 };

    /// The block of farthest corner `far` and `plane` (distance from the
    /// VPL, unit normal towards it), if the corners met one.
    fn new(far: Corner, plane: Option<(f32, Vec3)>) -> LayerBlock {
        if let Some((d, m)) = plane.filter(|&(d, _)| d > 0.0) {
            let ratio = (32.0 * (far.t / d).log2()).ceil().max(0.0);
            if ratio <= 255.0 {
                let e = super::points::octahedral(m).unwrap_or(Vec2::ZERO);
                let q = ((e * 0.5 + 0.5).clamp(Vec2::ZERO, Vec2::ONE) * 4095.0).round();
                return LayerBlock {
                    d: -d,
                    bits: q.x as u32 | (q.y as u32) << 12 | (ratio as u32) << 24,
                };
            }
        }
        LayerBlock {
            d: far.t,
            bits: facing_code(far.facing) << 24,
        }
    }

    /// The farthest corner's distance (m): for a plane, as the GPU decodes
    /// it (at most 2.2% beyond).
    pub fn far(&self) -> f32 {
        if self.d >= 0.0 {
            self.d
        } else {
            -self.d * ((self.bits >> 24) as f32 / 32.0).exp2()
        }
    }

    /// The plane's distance from the VPL (m) and unit normal towards it,
    /// as the GPU decodes them, if the block holds one.
    pub fn plane(&self) -> Option<(f32, Vec3)> {
        (self.d < 0.0).then(|| {
            let q = Vec2::new((self.bits & 0xFFF) as f32, (self.bits >> 12 & 0xFFF) as f32);
            let m = super::points::from_octahedral(q / 4095.0 * 2.0 - Vec2::ONE);
            (-self.d, m)
        })
    }
}

/// `ism_facing_code` in shaders/include/ism.glsl: 0 where `facing` is not
/// known (negative), else 1-255.
fn facing_code(facing: f32) -> u32 {
    if facing >= 0.0 {
        1 + (facing.min(1.0) * 254.0).round() as u32
    } else {
        0
    }
}

/// How close four corners' planes must lie to be one: the same normal
/// within 0.8 degrees (|cos| 0.9999) and the same distance from the VPL
/// within this share of the farthest corner's. A sphere's facets that pass
/// sag by under 1e-4 of its radius between the corners, far within the ISM
/// test's relative tolerance.
pub const COPLANAR: f32 = 1e-4;

/// See [`COPLANAR`].
const SAME_NORMAL_COS: f32 = 0.9999;

/// Tile coordinates in `[-1, 1]²` of the unit direction `l` given in its
/// VPL's frame (x, y along [`basis`]'s tangents, z along the normal;
/// z >= 0): its projection onto the VPL's plane (Nusselt's analogue: the
/// unit disc inscribed in the tile, every texel the same projected solid
/// angle, so the same share of a Lambertian VPL's flux), `ism_map` in
/// shaders/include/ism.glsl.
pub fn projected_coords(l: Vec3) -> Vec2 {
    Vec2::new(l.x, l.y)
}

/// The unit direction in its VPL's frame through projected coordinates
/// `a` in `[-1, 1]²` ([`projected_coords`] inverted, `ism_projected_local`
/// in shaders/include/ism.glsl); beyond the inscribed disc (the horizon)
/// it is moved onto it, at most 0.06 degrees above the horizon.
pub fn projected_local(a: Vec2) -> Vec3 {
    let r2 = a.length_squared();
    let a = if r2 > 0.999999 { a * (0.999999 / r2).sqrt() } else { a };
    a.extend((1.0 - a.length_squared()).max(0.0).sqrt())
}

/// The layer of every VPL, in their order: [`BASE_GRID`]² blocks per VPL,
/// row by row along the tile's v then u ([`blocks`]); distance
/// `miss` where every corner ray of a block leaves the scene.
pub fn coarse_depths(bvh: &SceneBvh, vpls: &[Vpl], miss: f32) -> Vec<LayerBlock> {
    blocks(&corner_depths(bvh, vpls, miss, None))
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
    let mut out = vec![Corner::missed(0.0); vpls.len() * n];
    out.par_chunks_mut(n)
        .zip(vpls.par_iter())
        .for_each(|(corners, v)| {
            let origin = v.position + v.normal * bvh.surface_offset(v.position);
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
            let (t, b) = basis(v.normal);
            for (k, c) in corners.iter_mut().enumerate() {
                // The corner in tile coordinates [-1, 1]², moved in to
                // CORNER_MAX_RADIUS.
                let a = Vec2::new((k % (g + 1)) as f32, (k / (g + 1)) as f32) * (2.0 / g as f32)
                    - Vec2::ONE;
                let l = projected_local(a * (CORNER_MAX_RADIUS / a.length().max(CORNER_MAX_RADIUS)));
                let dir = (t * l.x + b * l.y + v.normal * l.z).normalize();
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
                *c = hit.map_or(Corner::missed(miss), |hit| {
                    let m = bvh.triangle_normal(hit.triangle);
                    let cos = m.dot(dir);
                    Corner {
                        t: hit.t,
                        facing: cos.abs(),
                        normal: if cos > 0.0 { -m } else { m },
                    }
                });
            }
        });
    out
}

/// Each VPL's [`BASE_GRID`]² blocks from its corners: a block holds the
/// farthest of its four corners (and how that one's surface faces the
/// ray), and the plane all four met, if they met one ([`COPLANAR`]).
pub fn blocks(corners: &[Corner]) -> Vec<LayerBlock> {
    let g = BASE_GRID as usize;
    corners
        .chunks_exact(RAYS_PER_VPL as usize)
        .flat_map(|c| {
            (0..g * g).map(move |k| {
                let (x, y) = (k % g, k / g);
                let corner = |dx: usize, dy: usize| c[(y + dy) * (g + 1) + x + dx];
                let four = [corner(0, 0), corner(1, 0), corner(0, 1), corner(1, 1)];
                let far = four[1..]
                    .iter()
                    .fold(four[0], |far, &c| if c.t > far.t { c } else { far });
                LayerBlock::new(far, one_plane(&four, far.t))
            })
        })
        .collect()
}

/// The plane (distance from the VPL, unit normal towards it) that all of
/// `four` corner rays met, if they met one.
fn one_plane(four: &[Corner; 4], far: f32) -> Option<(f32, Vec3)> {
    // A corner's plane lies t x facing from the VPL along its normal.
    let (m, d) = (four[0].normal, four[0].t * four[0].facing);
    let within = COPLANAR * far;
    four.iter()
        .all(|c| {
            c.facing > 0.0
                && c.normal.dot(m) > SAME_NORMAL_COS
                && (c.t * c.facing - d).abs() <= within
        })
        .then_some((d, m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::bvh::RAY_EPSILON;

    #[test]
    fn inverts_the_map() {
        for n in [Vec3::Y, -Vec3::Z, Vec3::new(0.3, -0.8, 0.52).normalize()] {
            let (t, b) = basis(n);
            for uv in [
                Vec2::new(0.5, 0.5),
                Vec2::new(0.2, 0.7),
                Vec2::new(0.9, 0.45),
                Vec2::new(0.12, 0.75),
                Vec2::new(0.6, 0.05),
            ] {
                let l = projected_local(uv * 2.0 - Vec2::ONE);
                let w = (t * l.x + b * l.y + n * l.z).normalize();
                assert!(w.dot(n) > 0.0);
                let l = Vec3::new(w.dot(t), w.dot(b), w.dot(n));
                let back = projected_coords(l) * 0.5 + Vec2::splat(0.5);
                assert!((back - uv).length() < 1e-4, "{n} {uv} {back}");
                let a = uv * 2.0 - Vec2::ONE;
                let l = projected_local(a);
                assert!(l.z > 0.0 && (l.length() - 1.0).abs() < 1e-5);
                assert!((projected_coords(l) - a).length() < 1e-5, "projected {uv}");
            }
        }
    }

    #[test]
    fn every_texel_holds_the_same_share_of_a_lambertian_vpls_flux() {
        // A texel's projected solid angle (integral of cos(theta) over its
        // directions, the share of a Lambertian VPL's flux times pi) as 8x8
        // small quads, each two spherical triangles between its corners (Van
        // Oosterom and Strackee) times the cosine at its centre, over a
        // 32-texel tile: (2 / 32)^2 within 0.5% for every texel inside
        // radius 0.9 of the tile (steeper towards the horizon than this sum
        // resolves), and pi in all.
        let (tile, sub) = (32, 8);
        let at = |x: f32, y: f32| Vec2::new(x, y) * (2.0 / (tile * sub) as f32) - Vec2::ONE;
        let corner = |x: usize, y: usize| projected_local(at(x as f32, y as f32)).normalize();
        let triangle = |a: Vec3, b: Vec3, c: Vec3| {
            let num = a.dot(b.cross(c)).abs();
            let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
            2.0 * num.atan2(den)
        };
        let expected = (2.0 / tile as f32).powi(2);
        let mut total = 0.0;
        for y in 0..tile {
            for x in 0..tile {
                let mut omega = 0.0;
                for k in 0..sub * sub {
                    let (x, y) = (x * sub + k % sub, y * sub + k / sub);
                    let (c00, c10, c01, c11) =
                        (corner(x, y), corner(x + 1, y), corner(x, y + 1), corner(x + 1, y + 1));
                    let cos = projected_local(at(x as f32 + 0.5, y as f32 + 0.5)).z;
                    omega += (triangle(c00, c10, c11) + triangle(c00, c11, c01)) * cos;
                }
                let far = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)]
                    .map(|(x, y)| at((x * sub) as f32, (y * sub) as f32).length())
                    .into_iter()
                    .fold(0.0, f32::max);
                if far <= 0.9 {
                    assert!(
                        (omega / expected - 1.0).abs() < 0.005,
                        "texel ({x}, {y}): {omega}, {expected} expected"
                    );
                }
                total += omega;
            }
        }
        assert!((total / std::f32::consts::PI - 1.0).abs() < 0.01, "{total}");
    }

    /// A VPL at `position` facing `normal` (a Lambertian one of no flux).
    fn vpl_at(position: Vec3, normal: Vec3) -> Vpl {
        Vpl {
            position,
            normal,
            brdf: crate::cpu::brdf::Brdf::lambertian(Vec3::ONE),
            incident: -normal,
            shading_normal: Vec3::ZERO,
            flux: Vec3::ONE,
            radius: 0.0,
            bounce: 1,
            path: 0,
        }
    }

    #[test]
    fn a_block_whose_corners_meet_one_plane_holds_it() {
        // A VPL 1 m before a wall of two triangles, 2 m each way (it fills
        // the map out to 63 degrees), and a floor across the wall's foot 0.5
        // m below the VPL. The blocks that see only the wall hold its plane,
        // 1 m along its normal, whatever their corners' distances; those
        // that see only the floor, the floor's, 0.5 m along its normal; those
        // across the crease, and those that see past the wall's edges, hold
        // none (they keep their farthest corner).
        let mut scene = crate::scene::Scene::new("wall");
        let m = scene.add_material(Vec3::ONE, None);
        let wall = [
            Vec3::new(-2.0, -0.5, -1.0),
            Vec3::new(2.0, -0.5, -1.0),
            Vec3::new(2.0, 2.0, -1.0),
            Vec3::new(-2.0, 2.0, -1.0),
        ];
        let floor = [
            Vec3::new(-2.0, -0.5, -1.0),
            Vec3::new(-2.0, -0.5, 1.0),
            Vec3::new(2.0, -0.5, 1.0),
            Vec3::new(2.0, -0.5, -1.0),
        ];
        for quad in [wall, floor] {
            scene
                .add_mesh(&quad, &[], &[], &[0, 1, 2, 0, 2, 3], glam::Mat4::IDENTITY, m)
                .unwrap();
        }
        let bvh = SceneBvh::new(&scene);
        let blocks = coarse_depths(&bvh, &[vpl_at(Vec3::ZERO, -Vec3::Z)], 100.0);
        let corners = corner_depths(&bvh, &[vpl_at(Vec3::ZERO, -Vec3::Z)], 100.0, None);
        let g = BASE_GRID as usize;
        let planes: Vec<_> = blocks.iter().filter_map(|b| Some((b.plane()?, b.far()))).collect();
        assert!(planes.len() >= g * g / 4, "{} of {} blocks", planes.len(), g * g);
        for &((plane, n), far) in &planes {
            let (d, m) = if plane > 0.75 { (1.0, Vec3::Z) } else { (0.5, Vec3::Y) };
            assert!((plane - d).abs() < 1e-3, "{plane} {n}");
            assert!(n.dot(m) > 0.99999, "{n}");
            assert!(far >= d && far < 100.0, "{far}");
        }
        assert!(planes.iter().any(|p| p.0 .0 < 0.75), "no block holds the floor");
        // Each block's farthest corner as decoded: at most 2.2% beyond its
        // own, never nearer.
        for (k, b) in blocks.iter().enumerate() {
            let (x, y) = (k % g, k / g);
            let far = [(0, 0), (1, 0), (0, 1), (1, 1)]
                .map(|(dx, dy)| corners[(y + dy) * (g + 1) + x + dx].t)
                .into_iter()
                .fold(0.0, f32::max);
            assert!(b.far() >= far * 0.99999 && b.far() <= far * 1.022, "{b:?}: {far}");
        }
        // The centre blocks see the wall; along the floor's crease and past
        // the wall's edges (misses) no block holds a plane.
        assert!(blocks[(g / 2) * g + g / 2].plane().is_some());
        let crossing = blocks.iter().filter(|b| b.plane().is_none() && b.far() < 100.0);
        assert!(crossing.count() > 0, "no block straddles the crease");
    }

    #[test]
    fn a_vpl_under_a_slab_sees_it_out_to_the_rim() {
        // A VPL on the ceiling of the Cornell box looking down at a quad 1 cm
        // below it, 30 cm each way: the centre blocks hold 1 cm (the quad
        // facing the VPL), and so do the rim blocks (49-90 degrees from the
        // normal), where it hides the room up to 88 degrees: 4 cm at 75.6
        // degrees, their outer corners' (CORNER_MAX_RADIUS).
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
        let vpl = vpl_at(Vec3::new(0.01, 2.0, 0.02), -Vec3::Y);
        let d = coarse_depths(&bvh, &[vpl], 100.0);
        let g = BASE_GRID as usize;
        let centre = d[(g / 2) * g + g / 2];
        assert!((0.01..0.015).contains(&centre.far()), "centre block {centre:?}");
        // All four corners met the quad: the block holds its plane, the
        // height of the rays' origin above it away, facing up.
        let height = 2.0 - RAY_EPSILON * 3.0 - 1.99;
        let (plane, m) = centre.plane().expect("the quad's plane");
        assert!((plane - height).abs() < 1e-5 && m.dot(Vec3::Y) > 0.99999, "{centre:?}");
        let rim = d[(g / 2) * g].far();
        assert!((0.03..0.05).contains(&rim), "rim block {rim}");
    }
}
