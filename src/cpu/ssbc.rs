//! A CPU twin of one brute-force SSBC step, on a read-back G-buffer: the
//! reference the GPU's residual pass is tested against.

use glam::Vec3;
use rayon::prelude::*;

/// The G-buffer as read back (RGBA per pixel, rows top to bottom).
pub struct GBufferView<'a> {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// xyz position, w = 1 on geometry.
    pub position: &'a [f32],
    /// xyz normal.
    pub normal: &'a [f32],
    /// rgb albedo.
    pub albedo: &'a [f32],
}

/// World-space area seen through pixel (x, y):
/// t² s² cos³α / max(cos θ_view, `min_cos_view`).
pub fn pixel_area(
    position: Vec3,
    normal: Vec3,
    camera_position: Vec3,
    camera_forward: Vec3,
    pixel_side: f32,
    min_cos_view: f32,
) -> f32 {
    let v = position - camera_position;
    let t = v.length();
    let dir = v / t;
    let cos_alpha = dir.dot(camera_forward);
    let cos_view = normal.dot(dir).abs().max(min_cos_view);
    t * t * pixel_side * pixel_side * cos_alpha.powi(3) / cos_view
}

/// One step over every pixel pair closer than 1/sqrt(b):
/// `S(x) = albedo(x)/pi * sum_y max(G - b, 0) A_y S_prev(y)`. Returns RGBA.
pub fn brute_force_step(
    g: &GBufferView<'_>,
    s_prev: &[f32],
    camera_position: Vec3,
    camera_forward: Vec3,
    pixel_side: f32,
    min_cos_view: f32,
    bound: f32,
) -> Vec<f32> {
    let n = (g.width * g.height) as usize;
    let at = |buf: &[f32], i: usize| Vec3::new(buf[i * 4], buf[i * 4 + 1], buf[i * 4 + 2]);
    let geometry: Vec<usize> = (0..n).filter(|&i| g.position[i * 4 + 3] != 0.0).collect();
    let area: Vec<f32> = (0..n)
        .map(|i| {
            if g.position[i * 4 + 3] == 0.0 {
                0.0
            } else {
                pixel_area(
                    at(g.position, i),
                    at(g.normal, i),
                    camera_position,
                    camera_forward,
                    pixel_side,
                    min_cos_view,
                )
            }
        })
        .collect();
    let r2 = 1.0 / bound;
    (0..n)
        .into_par_iter()
        .flat_map_iter(|i| {
            if g.position[i * 4 + 3] == 0.0 || !bound.is_finite() {
                return [0.0, 0.0, 0.0, g.position[i * 4 + 3]];
            }
            let (x, nx) = (at(g.position, i), at(g.normal, i));
            let mut sum = Vec3::ZERO;
            for &j in &geometry {
                let d = at(g.position, j) - x;
                let d2 = d.length_squared();
                if d2 >= r2 || d2 < 1e-12 {
                    continue;
                }
                let w = d / d2.sqrt();
                let gterm = nx.dot(w).max(0.0) * (-at(g.normal, j).dot(w)).max(0.0) / d2;
                sum += (gterm - bound).max(0.0) * area[j] * at(s_prev, j);
            }
            let s = at(g.albedo, i) / std::f32::consts::PI * sum;
            [s.x, s.y, s.z, 1.0]
        })
        .collect()
}
