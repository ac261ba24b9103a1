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
        }
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

/// A texel of the CPU twin of the geometry pyramid (`GeoTexel` + `GeoAux`
/// in shaders/include/ssbc.glsl).
#[derive(Clone, Copy, Debug, Default)]
pub struct TwinTexel {
    /// Area-weighted mean position.
    pub position: Vec3,
    /// Slab half-thickness along the mean normal (< 0: no geometry).
    pub thickness: f32,
    /// Area-weighted mean of unit normals.
    pub normal: Vec3,
    /// Bounding radius around the mean position.
    pub radius: f32,
    /// Summed area.
    pub area: f32,
    /// One smooth surface.
    pub continuous: bool,
}

/// The CPU twin of the geometry pyramid and the hierarchical traversal (for
/// tests and tuning: the GPU kernels do the same in the same order).
pub struct HierarchyTwin {
    /// Level 0 size (padded).
    pub size: (u32, u32),
    /// Image size.
    pub image: (u32, u32),
    /// Levels.
    pub levels: Vec<Vec<TwinTexel>>,
}

impl HierarchyTwin {
    /// Builds the pyramid like `ssbc_geometry_mips.comp`.
    pub fn new(
        g: &GBufferView<'_>,
        camera: TwinCamera,
        levels: u32,
        max_normal_spread: f32,
        max_thickness: f32,
    ) -> Self {
        let align = 1u32 << (levels - 1);
        let size = (g.width.div_ceil(align) * align, g.height.div_ceil(align) * align);
        let mut pyramid = Vec::new();
        let mut level0 = vec![
            TwinTexel {
                thickness: -1.0,
                ..Default::default()
            };
            (size.0 * size.1) as usize
        ];
        for y in 0..g.height {
            for x in 0..g.width {
                let i = (y * g.width + x) as usize;
                if g.position[i * 4 + 3] == 0.0 {
                    continue;
                }
                let (p, n) = (vec3_at(g.position, i), vec3_at(g.normal, i));
                level0[(y * size.0 + x) as usize] = TwinTexel {
                    position: p,
                    thickness: 0.0,
                    normal: n,
                    radius: 0.0,
                    area: pixel_area(
                        p,
                        n,
                        camera.position,
                        camera.forward,
                        camera.pixel_side,
                        camera.min_cos_view,
                    ),
                    continuous: true,
                };
            }
        }
        pyramid.push(level0);
        for l in 1..levels {
            let (w, h) = (size.0 >> l, size.1 >> l);
            let below = &pyramid[l as usize - 1];
            let bw = size.0 >> (l - 1);
            let mut level = Vec::with_capacity((w * h) as usize);
            for y in 0..h {
                for x in 0..w {
                    let kids: Vec<TwinTexel> = (0..4)
                        .map(|k| below[((2 * y + (k >> 1)) * bw + 2 * x + (k & 1)) as usize])
                        .collect();
                    let area: f32 = kids.iter().map(|c| c.area).sum();
                    if area <= 0.0 {
                        level.push(TwinTexel {
                            thickness: -1.0,
                            ..Default::default()
                        });
                        continue;
                    }
                    let position = kids.iter().map(|c| c.area * c.position).sum::<Vec3>() / area;
                    let normal = kids.iter().map(|c| c.area * c.normal).sum::<Vec3>() / area;
                    let axis = normal.try_normalize().unwrap_or(Vec3::Z);
                    let (mut radius, mut thickness) = (0.0f32, 0.0f32);
                    for c in kids.iter().filter(|c| c.area > 0.0) {
                        let offset = c.position - position;
                        let a = c
                            .normal
                            .try_normalize()
                            .map_or(0.0, |n| axis.dot(n).clamp(-1.0, 1.0));
                        radius = radius.max(offset.length() + c.radius);
                        thickness = thickness.max(
                            axis.dot(offset).abs()
                                + a.abs() * c.thickness
                                + (1.0 - a * a).sqrt() * c.radius,
                        );
                    }
                    let continuous = kids.iter().all(|c| c.continuous)
                        && normal.length() >= max_normal_spread
                        && thickness <= max_thickness * radius;
                    level.push(TwinTexel {
                        position,
                        thickness,
                        normal,
                        radius,
                        area,
                        continuous,
                    });
                }
            }
            pyramid.push(level);
        }
        Self {
            size,
            image: (g.width, g.height),
            levels: pyramid,
        }
    }

    /// Texel `t` of level `l`.
    pub fn texel(&self, x: i32, y: i32, l: usize) -> &TwinTexel {
        &self.levels[l][(y as u32 * (self.size.0 >> l) + x as u32) as usize]
    }

    /// Texels read by `integrate_hierarchical` for a receiver at `x` with
    /// normal `nx` seen at pixel `center`, per level (finest first) and by
    /// what happened to them: empty, behind the tangent plane, too far,
    /// refined, added.
    #[allow(clippy::too_many_arguments)]
    pub fn traversal_reads(
        &self,
        x: Vec3,
        nx: Vec3,
        center: glam::Vec2,
        radius_px: f32,
        bound: f32,
        refine_ratio: f32,
    ) -> Vec<[u32; 5]> {
        let r_world = 1.0 / bound.sqrt();
        let top = self.levels.len() as i32 - 1;
        let root = ((radius_px.max(1.0) * 0.5).log2().ceil() as i32).clamp(0, top);
        let lsize = |l: i32| ((self.size.0 >> l) as i32, (self.size.1 >> l) as i32);
        let lo = (
            ((center.x - radius_px).floor() as i32 >> root).max(0),
            ((center.y - radius_px).floor() as i32 >> root).max(0),
        );
        let hi = (
            ((center.x + radius_px).ceil() as i32 >> root).min(lsize(root).0 - 1),
            ((center.y + radius_px).ceil() as i32 >> root).min(lsize(root).1 - 1),
        );
        // Per level: [empty, behind, far, refined, added].
        let mut reads = vec![[0u32; 5]; self.levels.len()];
        for ry in lo.1..=hi.1 {
            for rx in lo.0..=hi.0 {
                let (mut tx, mut ty, mut tz) = (rx, ry, root);
                loop {
                    let g = self.texel(tx, ty, tz as usize);
                    let mut refine = false;
                    let mut kind = 0;
                    if g.thickness >= 0.0 {
                        let d = g.position - x;
                        let dist = d.length();
                        let d_min = dist - g.radius;
                        let ny_len = g.normal.length();
                        let a = if ny_len > 0.0 {
                            (nx.dot(g.normal) / ny_len).clamp(-1.0, 1.0)
                        } else {
                            0.0
                        };
                        let reach = nx.dot(d) + a.abs() * g.thickness + (1.0 - a * a).sqrt() * g.radius;
                        let behind = reach <= 1e-3 * g.radius;
                        let far = d_min >= r_world
                            || (d_min > 0.0 && (reach / d_min).min(1.0) <= bound * d_min * d_min);
                        kind = if behind { 1 } else if far { 2 } else { 4 };
                        if !behind && !far {
                            refine = tz > 0 && g.radius > refine_ratio * dist;
                            if refine {
                                kind = 3;
                            }
                        }
                    }
                    reads[tz as usize][kind] += 1;
                    if refine {
                        (tx, ty, tz) = (tx * 2, ty * 2, tz - 1);
                        continue;
                    }
                    while tz < root && (tx & ty & 1) == 1 {
                        (tx, ty, tz) = (tx >> 1, ty >> 1, tz + 1);
                    }
                    if tz == root {
                        break;
                    }
                    if tx & 1 == 0 {
                        tx += 1;
                    } else {
                        tx -= 1;
                        ty += 1;
                    }
                }
            }
        }
        reads
    }
}
