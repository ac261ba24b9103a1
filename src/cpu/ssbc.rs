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

/// The camera quantities of [`pixel_area`].
#[derive(Clone, Copy, Debug)]
pub struct TwinCamera {
    /// Eye position.
    pub position: Vec3,
    /// Unit optical axis.
    pub forward: Vec3,
    /// Pixel side on the image plane at distance 1.
    pub pixel_side: f32,
    /// Lower clamp of cos(theta_view).
    pub min_cos_view: f32,
}

/// One brute-force step, `S(x) = albedo(x)/pi * sum_y max(G - b, 0) A_y
/// S_prev(y)` over every geometry pixel y closer than 1/sqrt(b), evaluated
/// at the pixels asked for.
pub struct BruteForceTwin<'a> {
    g: &'a GBufferView<'a>,
    s_prev: &'a [f32],
    bound: f32,
    geometry: Vec<usize>,
    area: Vec<f32>,
    /// Sources only: a second G-buffer layer, its term, and its pixels'
    /// (position, normal, area x term).
    hidden: Vec<(Vec3, Vec3, Vec3)>,
}

fn vec3_at(buf: &[f32], i: usize) -> Vec3 {
    Vec3::new(buf[i * 4], buf[i * 4 + 1], buf[i * 4 + 2])
}

impl<'a> BruteForceTwin<'a> {
    /// Prepares the pixel areas of `g` for the term `s_prev` (RGBA).
    pub fn new(g: &'a GBufferView<'a>, s_prev: &'a [f32], camera: TwinCamera, bound: f32) -> Self {
        let n = (g.width * g.height) as usize;
        let geometry: Vec<usize> = (0..n).filter(|&i| g.position[i * 4 + 3] != 0.0).collect();
        let area = (0..n)
            .map(|i| {
                if g.position[i * 4 + 3] == 0.0 {
                    return 0.0;
                }
                pixel_area(
                    vec3_at(g.position, i),
                    vec3_at(g.normal, i),
                    camera.position,
                    camera.forward,
                    camera.pixel_side,
                    camera.min_cos_view,
                )
            })
            .collect();
        Self {
            g,
            s_prev,
            bound,
            geometry,
            area,
            hidden: Vec::new(),
        }
    }

    /// Adds the pixels of a second G-buffer layer at half resolution (a
    /// deep G-buffer's, as `SsbcPostProcess` takes it) as sources: each
    /// stands for 2 x 2 pixels of the image (four times the area).
    pub fn with_second_layer(
        mut self,
        g: &GBufferView<'_>,
        s_prev: &[f32],
        camera: TwinCamera,
    ) -> Self {
        let n = (g.width * g.height) as usize;
        self.hidden = (0..n)
            .filter(|&i| g.position[i * 4 + 3] != 0.0)
            .map(|i| {
                let (p, normal) = (vec3_at(g.position, i), vec3_at(g.normal, i));
                let area = pixel_area(
                    p,
                    normal,
                    camera.position,
                    camera.forward,
                    2.0 * camera.pixel_side,
                    camera.min_cos_view,
                );
                (p, normal, area * vec3_at(s_prev, i))
            })
            .collect();
        self
    }

    /// The residual (RGB) at pixel index `i` (row-major).
    pub fn residual(&self, i: usize) -> Vec3 {
        let g = self.g;
        if g.position[i * 4 + 3] == 0.0 || !self.bound.is_finite() {
            return Vec3::ZERO;
        }
        let r2 = 1.0 / self.bound;
        let (x, nx) = (vec3_at(g.position, i), vec3_at(g.normal, i));
        let mut sum = Vec3::ZERO;
        for &j in &self.geometry {
            let d = vec3_at(g.position, j) - x;
            let d2 = d.length_squared();
            if d2 >= r2 || d2 < 1e-12 {
                continue;
            }
            let w = d / d2.sqrt();
            let gterm = nx.dot(w).max(0.0) * (-vec3_at(g.normal, j).dot(w)).max(0.0) / d2;
            sum += (gterm - self.bound).max(0.0) * self.area[j] * vec3_at(self.s_prev, j);
        }
        for &(y, ny, area_s) in &self.hidden {
            let d = y - x;
            let d2 = d.length_squared();
            if d2 >= r2 || d2 < 1e-12 {
                continue;
            }
            let w = d / d2.sqrt();
            let gterm = nx.dot(w).max(0.0) * (-ny.dot(w)).max(0.0) / d2;
            sum += (gterm - self.bound).max(0.0) * area_s;
        }
        vec3_at(g.albedo, i) / std::f32::consts::PI * sum
    }

    /// The residual at every pixel, RGBA (alpha 1 on geometry).
    pub fn image(&self) -> Vec<f32> {
        let n = (self.g.width * self.g.height) as usize;
        (0..n)
            .into_par_iter()
            .flat_map_iter(|i| {
                let s = self.residual(i);
                [s.x, s.y, s.z, self.g.position[i * 4 + 3]]
            })
            .collect()
    }
}

/// One step over every pixel pair closer than 1/sqrt(b):
/// `S(x) = albedo(x)/pi * sum_y max(G - b, 0) A_y S_prev(y)`. Returns RGBA.
pub fn brute_force_step(
    g: &GBufferView<'_>,
    s_prev: &[f32],
    camera: TwinCamera,
    bound: f32,
) -> Vec<f32> {
    BruteForceTwin::new(g, s_prev, camera, bound).image()
}

/// How a GPU residual compares with the brute-force twin on a set of pixels.
#[derive(Clone, Copy, Debug, Default, serde::Serialize)]
pub struct TwinComparison {
    /// Pixels compared (geometry pixels of the sample).
    pub pixels: usize,
    /// sqrt(sum |gpu - twin|^2 / sum |twin|^2) over RGB.
    pub relative_rmse: f64,
    /// sum gpu / sum twin over RGB.
    pub mean_ratio: f64,
}

/// Compares `gpu` (RGBA residual of one step) with the twin at every
/// `stride`-th pixel (stride 1: all of them; a stride coprime with the width
/// spreads the sample over the image).
pub fn compare_with_twin(twin: &BruteForceTwin<'_>, gpu: &[f32], stride: usize) -> TwinComparison {
    let n = (twin.g.width * twin.g.height) as usize;
    let sample: Vec<usize> = (0..n)
        .step_by(stride.max(1))
        .filter(|&i| twin.g.position[i * 4 + 3] != 0.0)
        .collect();
    let (num, den, sum_gpu, sum_twin) = sample
        .par_iter()
        .map(|&i| {
            let t = twin.residual(i);
            let g = vec3_at(gpu, i);
            let (t, g) = (t.as_dvec3(), g.as_dvec3());
            (
                (g - t).length_squared(),
                t.length_squared(),
                g.element_sum(),
                t.element_sum(),
            )
        })
        .reduce(
            || (0.0, 0.0, 0.0, 0.0),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3),
        );
    TwinComparison {
        pixels: sample.len(),
        relative_rmse: (num / den.max(1e-300)).sqrt(),
        mean_ratio: sum_gpu / sum_twin.max(1e-300),
    }
}
