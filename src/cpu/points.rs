//! Scene point sampling for imperfect shadow maps: points distributed over all
//! triangles in proportion to area, a separate low-discrepancy subset per VPL.
//! Cut-out parts of alpha-masked materials get no points (they cast no
//! shadow).

use glam::{Vec2, Vec3};

use super::sampling::Halton;
use super::shading;
use crate::scene::{AlphaMode, Scene};

/// Points for every VPL, `points_per_vpl` each, stored consecutively.
#[derive(Clone, Debug)]
pub struct IsmPoints {
    /// `vpl_count * points_per_vpl` positions (xyz, w = 1).
    pub positions: Vec<[f32; 4]>,
    /// World radius one point stands for: sqrt(area / (pi * points_per_vpl)).
    pub point_radius: f32,
    /// Total surface area of the scene (m^2).
    pub total_area: f32,
}

/// Samples `points_per_vpl` area-uniform points for each of `vpl_count` VPLs.
pub fn sample_points(
    scene: &Scene,
    vpl_count: usize,
    points_per_vpl: usize,
    seed: u64,
) -> IsmPoints {
    let tri = |t: usize| {
        let i = &scene.indices[t * 3..t * 3 + 3];
        let p = |k: usize| Vec3::from(scene.vertices[i[k] as usize].position);
        (p(0), p(1), p(2))
    };
    let mut cdf = Vec::with_capacity(scene.triangle_count());
    let mut total = 0.0f64;
    for t in 0..scene.triangle_count() {
        let (a, b, c) = tri(t);
        total += 0.5 * (b - a).cross(c - a).length() as f64;
        cdf.push(total);
    }
    let halton = Halton::new(seed ^ 0x15A);
    let count = vpl_count * points_per_vpl;
    let mut positions = Vec::with_capacity(count);
    let masked = scene
        .materials
        .iter()
        .any(|m| matches!(m.alpha, AlphaMode::Mask(_)));
    // Points on cut-out texels are drawn again (up to 16 draws per point).
    let mut k = 0u64;
    while positions.len() < count && k < 16 * count as u64 {
        let target = halton.sample(k, 0) as f64 * total;
        let t = cdf.partition_point(|&c| c < target).min(cdf.len() - 1);
        let (a, b, c) = tri(t);
        let u = Vec2::new(halton.sample(k, 1), halton.sample(k, 2));
        k += 1;
        let su = u.x.sqrt();
        let (w1, w2) = (su * (1.0 - u.y), su * u.y);
        if masked {
            let i = &scene.indices[t * 3..t * 3 + 3];
            let v = |n: usize| &scene.vertices[i[n] as usize];
            let material = &scene.materials[v(0).material as usize];
            let uv = Vec2::from(v(0).uv) * (1.0 - w1 - w2)
                + Vec2::from(v(1).uv) * w1
                + Vec2::from(v(2).uv) * w2;
            if !shading::opaque(scene, material, uv) {
                continue;
            }
        }
        let p = a * (1.0 - w1 - w2) + b * w1 + c * w2;
        positions.push([p.x, p.y, p.z, 1.0]);
    }
    // A scene almost entirely cut out: repeat the points found (every VPL
    // block must be full), or a vertex if there were none.
    let found = positions.len();
    for i in found..count {
        let p = if found > 0 {
            positions[i % found]
        } else {
            let (a, _, _) = tri(0);
            [a.x, a.y, a.z, 1.0]
        };
        positions.push(p);
    }
    // Consecutive Halton points are well spread, so each VPL's block of
    // consecutive points is itself a good area sampling.
    let point_radius =
        (total as f32 / (std::f32::consts::PI * points_per_vpl.max(1) as f32)).sqrt();
    IsmPoints {
        positions,
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
