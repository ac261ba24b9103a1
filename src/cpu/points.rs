//! Scene point sampling for imperfect shadow maps: points distributed over all
//! triangles in proportion to area, a separate low-discrepancy subset per VPL.
//! Cut-out parts of alpha-masked materials get no points (they cast no
//! shadow).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::point_discs;
use super::sampling::Halton;
use super::shading;
use crate::scene::{AlphaMode, Scene};

/// Blocks of points, `points_per_block` each, stored consecutively; each VPL
/// splats one block. Points lie on objects and move with them: each is
/// stored in its object's space with the object's index, and the GPU
/// places it with the object's current transform (so moving an object
/// samples nothing again).
#[derive(Clone, Debug)]
pub struct IsmPoints {
    /// `blocks * points_per_block` points: xyz in object space, w the
    /// object's index (`f32::from_bits`).
    pub positions: Vec<[f32; 4]>,
    /// Each point's surface normal (its triangle's, in object space),
    /// [`pack_normal`]ed: the ISM test's tolerance needs how the surface a
    /// VPL sees faces it.
    pub normals: Vec<u32>,
    /// Points in a block.
    pub points_per_block: usize,
    /// Each point's disc ([`point_discs`]): its radius and where it ends
    /// at an edge of its surface, in its object's space
    /// ([`point_discs::pack_disc`]).
    pub discs: Vec<u32>,
    /// World radius one point stands for: sqrt(area / (pi * points_per_vpl)).
    pub point_radius: f32,
    /// Total surface area of the scene (m^2).
    pub total_area: f32,
}

impl IsmPoints {
    /// No points: for frames whose ISMs are not splatted (traced texels,
    /// exact visibility).
    pub fn none() -> Self {
        Self {
            positions: Vec::new(),
            normals: Vec::new(),
            points_per_block: 0,
            discs: Vec::new(),
            point_radius: 0.0,
            total_area: 0.0,
        }
    }
}

/// A sampled point: its object-space position and object (w, as bits),
/// its packed normal, its world triangle.
type SampledPoint = ([f32; 4], u32, u32);

/// Samples `blocks` blocks of `points_per_vpl` points, uniform over the
/// visible objects' world area (as placed when sampled).
pub fn sample_points(scene: &Scene, blocks: usize, points_per_vpl: usize, seed: u64) -> IsmPoints {
    let instances = scene.instances();
    // World triangle t in its object's space: the object and the corners.
    let tri = |t: usize| {
        let (instance, local) = instances.locate(t as u32);
        let mesh = &scene.meshes()[instance.mesh as usize];
        let i = &mesh.indices[local as usize * 3..local as usize * 3 + 3];
        let v = [0, 1, 2].map(|k| &mesh.vertices[i[k] as usize]);
        (instance, v)
    };
    let mut cdf = Vec::with_capacity(scene.triangle_count());
    let mut total = 0.0f64;
    for t in 0..scene.triangle_count() {
        let [a, b, c] = scene.triangle_positions(t as u32);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cdf.push(total);
    }
    let halton = Halton::new(seed ^ 0x15A);
    let bounds = scene.bounds();
    let morton = |p: Vec3| morton_code(p, bounds.min, bounds.max);
    let count = blocks * points_per_vpl;
    // Point k of the sequence: a triangle in proportion to area, a uniform
    // point on it (and whether it lies on a cut-out texel).
    let point = |k: u64| {
        let target = halton.sample(k, 0) as f64 * total;
        let t = cdf.partition_point(|&c| c < target).min(cdf.len() - 1);
        let (instance, v) = tri(t);
        let u = Vec2::new(halton.sample(k, 1), halton.sample(k, 2));
        let su = u.x.sqrt();
        let (w1, w2) = (su * (1.0 - u.y), su * u.y);
        let material =
            &scene.materials[instance.placement.material.unwrap_or(v[0].material) as usize];
        let kept = !matches!(material.alpha, AlphaMode::Mask(_)) || {
            let (uv, color) = shading::interpolated_uv_color(v, [1.0 - w1 - w2, w1, w2]);
            shading::opaque(scene, material, uv, color)
        };
        let p = |k: usize| Vec3::from(v[k].position);
        let normal = pack_normal((p(1) - p(0)).cross(p(2) - p(0)));
        let p = p(0) * (1.0 - w1 - w2) + p(1) * w1 + p(2) * w2;
        let world = instance.placement.transform.transform_point3(p);
        let point = ([p.x, p.y, p.z, f32::from_bits(instance.object)], normal, t as u32);
        kept.then_some((point, morton(world)))
    };
    let masked = scene
        .materials
        .iter()
        .any(|m| matches!(m.alpha, AlphaMode::Mask(_)));
    let points: Vec<(SampledPoint, u32)> = if masked {
        // Points on cut-out texels are drawn again (up to 16 draws a point).
        (0..16 * count as u64)
            .filter_map(point)
            .take(count)
            .collect()
    } else {
        // Every draw is kept: the points are independent.
        (0..count as u64)
            .into_par_iter()
            .filter_map(point)
            .collect()
    };
    // A scene almost entirely cut out: repeat the points found (every VPL
    // block must be full), or a vertex if there were none.
    let found = points.len();
    let (mut points, mut keys): (Vec<_>, Vec<u32>) = points.into_iter().unzip();
    for i in found..count {
        let p = if found > 0 {
            points[i % found]
        } else {
            let (instance, v) = tri(0);
            let a = v[0].position;
            ([a[0], a[1], a[2], f32::from_bits(instance.object)], pack_normal(Vec3::Z), 0)
        };
        points.push(p);
        keys.push(keys.get(i % found.max(1)).copied().unwrap_or(0));
    }
    let points = order_blocks(points, &keys, points_per_vpl);
    // Consecutive Halton points are well spread, so each VPL's block of
    // consecutive points is itself a good area sampling (in any order).
    let point_radius =
        (total as f32 / (std::f32::consts::PI * points_per_vpl.max(1) as f32)).sqrt();
    let discs = point_discs(scene, &points, point_radius);
    let (positions, normals) = points.into_iter().map(|(p, n, _)| (p, n)).unzip();
    IsmPoints {
        positions,
        normals,
        discs,
        points_per_block: points_per_vpl,
        point_radius,
        total_area: total as f32,
    }
}

/// Orders each block's points along a Morton curve of their world positions.
/// A block stays the same set of points (the same area sampling); its order
/// only decides which points the splat's SIMD lanes take together, and
/// nearby points have discs of similar size in the same VPL's tile, so a
/// group's loop runs about as long as its points need rather than as long
/// as the largest disc among points spread over the whole scene.
fn order_blocks(points: Vec<SampledPoint>, keys: &[u32], block: usize) -> Vec<SampledPoint> {
    if block < 2 {
        return points;
    }
    let mut order: Vec<(u32, u32)> = keys.iter().enumerate().map(|(i, &k)| (k, i as u32)).collect();
    order.par_chunks_mut(block).for_each(|c| c.sort_unstable());
    order.into_par_iter().map(|(_, i)| points[i as usize]).collect()
}

/// A position's 30-bit Morton code (10 bits an axis) in the box `lo`..`hi`.
fn morton_code(p: Vec3, lo: Vec3, hi: Vec3) -> u32 {
    let spread = |v: u32| {
        let mut x = v & 0x3FF;
        x = (x | (x << 16)) & 0x030000FF;
        x = (x | (x << 8)) & 0x0300F00F;
        x = (x | (x << 4)) & 0x030C30C3;
        (x | (x << 2)) & 0x09249249
    };
    let scale = 1023.0 / (hi - lo).max_element().max(1e-30);
    let c = ((p - lo) * scale).clamp(Vec3::ZERO, Vec3::splat(1023.0)).as_uvec3();
    spread(c.x) | spread(c.y) << 1 | spread(c.z) << 2
}

/// What the discs of a triangle's points share: its mesh, its unit normal
/// and the disc's reach (object space), the disc's width in point radii
/// (from the surface's curvature) and the feature edges they may meet.
struct DiscSurface {
    mesh: usize,
    normal: Vec3,
    reach: f32,
    width: f32,
    near: Vec<u32>,
}

/// Each point's disc ([`IsmPoints::discs`]) for points of radius `radius`
/// (world metres): `points` are (object-space position and object, packed
/// normal, world triangle).
fn point_discs(scene: &Scene, points: &[SampledPoint], radius: f32) -> Vec<u32> {
    let instances = scene.instances();
    // An instance's mesh and its transform's mean scale.
    let placed = |t: u32| {
        let (instance, local) = instances.locate(t);
        let m = instance.placement.transform;
        let scale = glam::Mat3::from_mat4(m).determinant().abs().cbrt().max(1e-30);
        (instance.mesh as usize, local, scale)
    };
    let reach = point_discs::MAX_DISC_SCALE * radius;
    // Edges of the meshes that have points, in cells of the first such
    // instance's reach (object space).
    let mut cell_of_mesh: Vec<Option<f32>> = vec![None; scene.meshes().len()];
    for &(_, _, t) in points {
        let (mesh, _, scale) = placed(t);
        cell_of_mesh[mesh].get_or_insert(reach / scale);
    }
    let edges: Vec<Option<point_discs::MeshEdges>> = cell_of_mesh
        .par_iter()
        .enumerate()
        .map(|(m, cell)| cell.map(|c| point_discs::MeshEdges::new(&scene.meshes()[m], c)))
        .collect();
    // Per triangle with points, the edges its points' discs may meet.
    let mut triangles: Vec<u32> = points.iter().map(|&(_, _, t)| t).collect();
    triangles.sort_unstable();
    triangles.dedup();
    let surfaces: std::collections::HashMap<u32, DiscSurface> = triangles
        .par_iter()
        .map(|&t| {
            let (mesh, local, scale) = placed(t);
            let m = &scene.meshes()[mesh];
            let i = &m.indices[local as usize * 3..local as usize * 3 + 3];
            let v = [0, 1, 2].map(|k| &m.vertices[i[k] as usize]);
            let positions = v.map(|v| Vec3::from(v.position));
            let normals = v.map(|v| Vec3::from(v.normal));
            let n = (positions[1] - positions[0])
                .cross(positions[2] - positions[0])
                .normalize_or_zero();
            let object_reach = reach / scale;
            let near = edges[mesh]
                .as_ref()
                .map_or(Vec::new(), |e| e.near_triangle(positions, n, object_reach));
            let curvature = point_discs::curvature(positions, normals) / scale;
            let surface = DiscSurface {
                mesh,
                normal: n,
                reach: object_reach,
                width: point_discs::disc_scale(curvature, radius),
                near,
            };
            (t, surface)
        })
        .collect();
    points
        .par_iter()
        .map(|&(p, _, t)| {
            let s = &surfaces[&t];
            let clip = edges[s.mesh]
                .as_ref()
                .and_then(|e| e.clip(&s.near, Vec3::new(p[0], p[1], p[2]), s.normal, s.reach));
            point_discs::pack_disc(clip, s.reach, s.width)
        })
        .collect()
}

/// A direction (any length but zero; zero gives +z) in 32 bits for the GPU
/// (`ism_unpack_normal` in shaders/include/ism.glsl): its octahedral map,
/// 15 bits a coordinate, and the top bit set, so that no normal packs to
/// 0, a hidden object's point.
pub fn pack_normal(n: Vec3) -> u32 {
    let e = octahedral(n).unwrap_or(Vec2::ZERO);
    let q = ((e * 0.5 + 0.5).clamp(Vec2::ZERO, Vec2::ONE) * 32767.0).round();
    0x8000_0000 | (q.x as u32) << 15 | q.y as u32
}

/// The octahedral map of a direction (any length but zero) in [-1, 1]^2
/// (`octahedral` in shaders/include/octahedral.glsl); `None` for zero or
/// one that is not finite.
pub(crate) fn octahedral(n: Vec3) -> Option<Vec2> {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    if !n.is_finite() {
        return None;
    }
    let sign = |v: f32| if v >= 0.0 { 1.0 } else { -1.0 };
    Some(if n.z < 0.0 {
        Vec2::new((1.0 - n.y.abs()) * sign(n.x), (1.0 - n.x.abs()) * sign(n.y))
    } else {
        Vec2::new(n.x, n.y)
    })
}

/// The unit direction whose octahedral map is `e` in [-1, 1]^2
/// (`from_octahedral` in shaders/include/octahedral.glsl).
pub(crate) fn from_octahedral(e: Vec2) -> Vec3 {
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `ism_unpack_normal` in shaders/include/ism.glsl.
    fn unpack_normal(bits: u32) -> Vec3 {
        let e = Vec2::new(((bits >> 15) & 32767) as f32, (bits & 32767) as f32) * (2.0 / 32767.0) - 1.0;
        from_octahedral(e)
    }

    #[test]
    fn normals_pack_to_32_bits_and_back() {
        let mut worst = 0.0f32;
        for i in 0..2000 {
            // A spiral over the sphere, and the axes (the octahedron's corners).
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / 2000.0;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            let n = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            for n in [n, Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
                let bits = pack_normal(n * 3.0);
                assert_ne!(bits, 0, "0 is a hidden object's point");
                worst = worst.max(unpack_normal(bits).cross(n).length());
            }
        }
        assert!(worst < 2e-4, "worst angle {worst} rad");
        assert!((unpack_normal(pack_normal(Vec3::ZERO)) - Vec3::Z).length() < 1e-4);
    }

    #[test]
    fn points_follow_area() {
        let scene = crate::scene::builtin::cornell();
        let pts = sample_points(&scene, 4, 4096, 1);
        assert_eq!(pts.positions.len(), 4 * 4096);
        // Floor share of all points matches its share of the area.
        let floor = pts.positions.iter().filter(|p| p[1].abs() < 1e-5).count() as f32
            / pts.positions.len() as f32;
        let floor_area = 4.0 + 0.36 + 0.36; // floor plus the two blocks' bottoms
        let expected = floor_area / pts.total_area;
        assert!(
            (floor - expected).abs() < 0.01,
            "floor share {floor} vs {expected}"
        );
    }

    #[test]
    fn blocks_keep_their_points_in_a_spatial_order() {
        let scene = crate::scene::builtin::cornell();
        let (blocks, per) = (3, 1024);
        let pts = sample_points(&scene, blocks, per, 1);
        // The same points as the sequence gives unordered: each block's
        // floor share is its area share, so every block still samples the
        // whole scene (points_follow_area for one block).
        let floor_area = 4.0 + 0.36 + 0.36;
        for b in pts.positions.chunks(per) {
            let floor = b.iter().filter(|p| p[1].abs() < 1e-5).count() as f32 / per as f32;
            assert!((floor - floor_area / pts.total_area).abs() < 0.03, "floor share {floor}");
        }
        // Consecutive points are near each other: the mean step along a
        // block is a small fraction of the mean distance between two
        // points of the scene (about 1.3 m in this box).
        let at = |i: usize| Vec3::new(pts.positions[i][0], pts.positions[i][1], pts.positions[i][2]);
        let mut step = 0.0;
        let mut apart = 0.0;
        for b in 0..blocks {
            for i in b * per..(b + 1) * per - 1 {
                step += at(i).distance(at(i + 1));
                apart += at(i).distance(at((i * 7919 + 13) % (blocks * per)));
            }
        }
        assert!(step < 0.25 * apart, "mean step {} vs {}", step, apart);
    }
}
