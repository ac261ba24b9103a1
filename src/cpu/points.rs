//! Scene point sampling for imperfect shadow maps: points distributed over all
//! triangles in proportion to area, a separate low-discrepancy subset per VPL.
//! Cut-out parts of alpha-masked materials get no points (they cast no
//! shadow).

use glam::{Vec2, Vec3};
use rayon::prelude::*;

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
    /// Points in a block.
    pub points_per_block: usize,
    /// World radius one point stands for: sqrt(area / (pi * points_per_vpl)).
    pub point_radius: f32,
    /// Total surface area of the scene (m^2).
    pub total_area: f32,
}

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
        let p = p(0) * (1.0 - w1 - w2) + p(1) * w1 + p(2) * w2;
        kept.then_some([p.x, p.y, p.z, f32::from_bits(instance.object)])
    };
    let masked = scene
        .materials
        .iter()
        .any(|m| matches!(m.alpha, AlphaMode::Mask(_)));
    let mut positions: Vec<[f32; 4]> = if masked {
        // Points on cut-out texels are drawn again (up to 16 draws a point).
        (0..16 * count as u64)
            .filter_map(point)
            .take(count)
            .collect()
    } else {
        // Every draw is kept: the points are independent (2048 VPLs' worth,
        // 2M points: 143 ms on one thread).
        (0..count as u64)
            .into_par_iter()
            .filter_map(point)
            .collect()
    };
    // A scene almost entirely cut out: repeat the points found (every VPL
    // block must be full), or a vertex if there were none.
    let found = positions.len();
    for i in found..count {
        let p = if found > 0 {
            positions[i % found]
        } else {
            let (instance, v) = tri(0);
            let a = v[0].position;
            [a[0], a[1], a[2], f32::from_bits(instance.object)]
        };
        positions.push(p);
    }
    // Consecutive Halton points are well spread, so each VPL's block of
    // consecutive points is itself a good area sampling.
    let point_radius =
        (total as f32 / (std::f32::consts::PI * points_per_vpl.max(1) as f32)).sqrt();
    IsmPoints {
        positions,
        points_per_block: points_per_vpl,
        point_radius,
        total_area: total as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
