//! A CPU twin of one brute-force SSBC step, on a read-back G-buffer: the
//! reference the GPU's residual pass is tested against.

use glam::Vec3;
use rayon::prelude::*;

use super::brdf::Brdf;
use crate::settings::LayerResolution;

/// The G-buffer as read back (RGBA per pixel, rows top to bottom).
pub struct GBufferView<'a> {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// xyz position, w = 1 on geometry.
    pub position: &'a [f32],
    /// xyz normal. The shading normal stands for the geometric one too
    /// (the GPU's step takes senders' geometry from the geometric normal
    /// where a normal map turned the shading normal; docs/ssbc-implementation.md).
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

/// What a source at y (unit normal ny) adds per unit of A_y S(y) to the
/// residual integral at x (unit normal nx): max(G - b, 0), with G =
/// cos θ_x cos θ_y / d² and no visibility (0 beyond 1/sqrt(b) and for
/// y at x).
pub fn residual_weight(x: Vec3, nx: Vec3, y: Vec3, ny: Vec3, bound: f32) -> f32 {
    let d = y - x;
    let d2 = d.length_squared();
    if d2 * bound >= 1.0 || d2 < 1e-12 {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let g = nx.dot(w).max(0.0) * (-ny.dot(w)).max(0.0) / d2;
    (g - bound).max(0.0)
}

/// How much a glossy receiver's GGX lobe (`alpha`) widens (added to α²)
/// for a source pixel seen over solid angle `omega` in direction `w`, its
/// lobe's mirror direction `mirror`: to the pixel's angular radius
/// (r² = ω / π; α² becomes max(α², r²)) where the chord to the mirror
/// direction is within r, fading linearly in the chord squared to nothing
/// at 2 r (a virtual spherical light around the peak; in the tail a
/// widened lobe is brighter than the narrow one's mean). As `add_glossy`
/// in ssbc_residual.glsl.
pub fn glossy_pixel_spread(omega: f32, alpha: f32, w: Vec3, mirror: Vec3) -> f32 {
    let r2 = omega / std::f32::consts::PI;
    let wider = r2 - alpha * alpha;
    if wider.is_nan() || wider <= 0.0 {
        return 0.0;
    }
    let near = ((4.0 * r2 - (w - mirror).length_squared()) / (3.0 * r2)).clamp(0.0, 1.0);
    near * wider
}

/// The camera quantities of a pixel's world-space area `A_y`.
#[derive(Clone, Copy, Debug)]
pub struct TwinCamera {
    /// Eye position.
    pub position: Vec3,
    /// Unit optical axis.
    pub forward: Vec3,
    /// Unit up vector of the image (orthogonal to `forward`).
    pub up: Vec3,
    /// Pixel side on the image plane at distance 1.
    pub pixel_side: f32,
    /// Lower clamp of cos(theta_view).
    pub min_cos_view: f32,
    /// Where the optical axis meets the image, from its centre, in pixels
    /// (x right, y down; a jittered or off-centre projection's).
    pub principal: glam::Vec2,
}

impl TwinCamera {
    /// The unnormalised ray through the image point `uv` (continuous pixel
    /// coordinates: pixel x spans [x, x + 1]; the optical axis at the
    /// image's centre plus `principal`) of a `width` x `height` image, as
    /// (ray at (0, 0), change per unit of u, change per unit of v).
    fn image_rays(&self, width: u32, height: u32) -> (Vec3, Vec3, Vec3) {
        let right = self.forward.cross(self.up).normalize();
        let (du, dv) = (right * self.pixel_side, -self.up * self.pixel_side);
        let axis = 0.5 * glam::Vec2::new(width as f32, height as f32) + self.principal;
        (self.forward - du * axis.x - dv * axis.y, du, dv)
    }
}

/// What a layer-0 source pixel stands for (ssbc_geometry_base.comp): its
/// own surface, and the neighbour's surface beyond a crease that crosses
/// its square.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    /// The area of its own surface seen through the pixel, A_y.
    pub own_area: f32,
    /// The part of the pixel on a neighbour's surface: (centroid, that
    /// surface's normal, area, the neighbour's pixel index).
    pub other: Option<(Vec3, Vec3, f32, usize)>,
}

/// Neighbours whose normals agree better are one flat surface.
const CREASE_COS: f32 = 0.95;

/// Offsets of the neighbours `footprint` looks at, in its order.
const NEIGHBOURS: [(i32, i32); 8] = [
    (-1, 0),
    (1, 0),
    (0, -1),
    (0, 1),
    (-1, -1),
    (1, -1),
    (-1, 1),
    (1, 1),
];

/// Sutherland–Hodgman: the part of a convex polygon where `side` >= 0.
fn clip(poly: &[glam::Vec2], side: impl Fn(glam::Vec2) -> f32) -> Vec<glam::Vec2> {
    let mut out = Vec::with_capacity(poly.len() + 1);
    for (i, &a) in poly.iter().enumerate() {
        let b = poly[(i + 1) % poly.len()];
        let (sa, sb) = (side(a), side(b));
        if sa >= 0.0 {
            out.push(a);
        }
        if (sa >= 0.0) != (sb >= 0.0) {
            out.push(a + (b - a) * (sa / (sa - sb)));
        }
    }
    out
}

/// The eye's rays through the image plane (pixel coordinates uv), for
/// lifting pixel polygons onto surfaces' tangent planes.
struct Rays {
    eye: Vec3,
    base: Vec3,
    du: Vec3,
    dv: Vec3,
}

impl Rays {
    /// Where the ray through uv meets the plane (c, n), if in front.
    fn on_plane(&self, uv: glam::Vec2, c: Vec3, n: Vec3) -> Option<Vec3> {
        let r = self.base + self.du * uv.x + self.dv * uv.y;
        let t = n.dot(c - self.eye) / n.dot(r);
        (t.is_finite() && t > 0.0).then(|| self.eye + r * t)
    }

    /// Area, centroid and size (largest distance of a vertex from the
    /// centroid) of the polygon lifted onto the plane (c, n).
    fn lift(&self, poly: &[glam::Vec2], c: Vec3, n: Vec3) -> Option<(f32, Vec3, f32)> {
        let v = poly
            .iter()
            .map(|&uv| self.on_plane(uv, c, n))
            .collect::<Option<Vec<Vec3>>>()?;
        let (mut cross, mut centroid, mut weight) = (Vec3::ZERO, Vec3::ZERO, 0.0);
        for k in 1..v.len().saturating_sub(1) {
            let t = (v[k] - v[0]).cross(v[k + 1] - v[0]);
            cross += t;
            centroid += (v[0] + v[k] + v[k + 1]) * (t.length() / 3.0);
            weight += t.length();
        }
        if v.len() < 3 || weight.is_nan() || weight <= 0.0 {
            return None;
        }
        let centroid = centroid / weight;
        let size = v
            .iter()
            .map(|p| (*p - centroid).length())
            .fold(0.0, f32::max);
        Some((0.5 * cross.length(), centroid, size))
    }

    /// An uncut pixel square lifted: the planar quad's area from its
    /// diagonals, its size from the corners' mean (as the GPU's fast path).
    fn lift_square(&self, square: &[glam::Vec2], c: Vec3, n: Vec3) -> Option<(f32, Vec3, f32)> {
        let v = square
            .iter()
            .map(|&uv| self.on_plane(uv, c, n))
            .collect::<Option<Vec<Vec3>>>()?;
        let area = 0.5 * (v[2] - v[0]).cross(v[3] - v[1]).length();
        let mean = (v[0] + v[1] + v[2] + v[3]) * 0.25;
        let size = v.iter().map(|p| (*p - mean).length()).fold(0.0, f32::max);
        Some((area, mean, size))
    }
}

/// The footprint of layer-0 pixel (x, y) on its tangent plane, split at
/// creases: where the line along which its tangent plane meets a
/// neighbour's passes between the two pixel centres, and the two are one
/// surface (close, the meeting point near both), the part of its square
/// beyond that line is the neighbour's surface. The largest such part is
/// kept. A pixel whose own part would lift far away (a plane seen edge-on)
/// keeps the clamped `pixel_area` and no other part.
pub fn footprint(g: &GBufferView<'_>, camera: &TwinCamera, x: u32, y: u32) -> Footprint {
    let (w, h) = (g.width as i32, g.height as i32);
    let index = |x: i32, y: i32| (y * w + x) as usize;
    let i = index(x as i32, y as i32);
    let (cp, np) = (vec3_at(g.position, i), vec3_at(g.normal, i));
    let clamped_area = |c: Vec3, n: Vec3| {
        pixel_area(
            c,
            n,
            camera.position,
            camera.forward,
            camera.pixel_side,
            camera.min_cos_view,
        )
    };
    let ap = clamped_area(cp, np);
    let (base, du, dv) = camera.image_rays(g.width, g.height);
    let eye = camera.position;
    let rays = Rays { eye, base, du, dv };
    let corner = glam::Vec2::new(x as f32, y as f32);
    let square: Vec<glam::Vec2> = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)]
        .iter()
        .map(|&(a, b)| corner + glam::Vec2::new(a, b))
        .collect();
    let centre_p = corner + 0.5;
    let mut own = square.clone();
    let mut cut = false;
    let mut other: Option<(Vec3, Vec3, f32, usize)> = None;
    for (dx, dy) in NEIGHBOURS {
        let (qx, qy) = (x as i32 + dx, y as i32 + dy);
        if qx < 0 || qy < 0 || qx >= w || qy >= h || g.position[index(qx, qy) * 4 + 3] == 0.0 {
            continue;
        }
        let j = index(qx, qy);
        let (cq, nq) = (vec3_at(g.position, j), vec3_at(g.normal, j));
        let aq = clamped_area(cq, nq);
        if np.dot(nq) > CREASE_COS || (cq - cp).length() > 3.0 * (ap.sqrt() + aq.sqrt()) {
            continue;
        }
        // Zero where both planes are at the same depth: k_p (n_q . r) - k_q (n_p . r).
        let (kp, kq) = (np.dot(cp - eye), nq.dot(cq - eye));
        let f = |d: Vec3| kp * nq.dot(d) - kq * np.dot(d);
        let (l0, lu, lv) = (f(base), f(du), f(dv));
        let line = |uv: glam::Vec2| l0 + lu * uv.x + lv * uv.y;
        let centre_q = glam::Vec2::new(qx as f32 + 0.5, qy as f32 + 0.5);
        let (fp, fq) = (line(centre_p), line(centre_q));
        let Some((offset, sign)) = crease_side(fp, fq) else {
            continue;
        };
        let fp = fp - offset;
        let m = centre_p + (centre_q - centre_p) * (fp / (fp - fq));
        match rays.on_plane(m, cp, np) {
            Some(crease) if (crease - cp).length() <= 2.0 * (cq - cp).length() => {}
            _ => continue,
        }
        own = clip(&own, |uv| sign * (line(uv) - offset));
        cut = true;
        let theirs = clip(&square, |uv| -sign * (line(uv) - offset));
        if let Some((area, centroid, size)) = rays.lift(&theirs, cq, nq) {
            if size <= 20.0 * aq.sqrt() && other.is_none_or(|o| area > 1.001 * o.2) {
                other = Some((centroid, nq, area, j));
            }
        }
    }
    let lifted = if cut {
        rays.lift(&own, cp, np)
    } else {
        rays.lift_square(&square, cp, np)
    };
    match lifted {
        Some((own_area, _, size)) if size <= 20.0 * ap.sqrt() => Footprint { own_area, other },
        _ => Footprint {
            own_area: ap,
            other: None,
        },
    }
}

/// Whether the crease line (value `fp` at p's centre, `fq` at the
/// neighbour's) runs between the two centres, and how to clip by it: the
/// offset to take from the line (non-zero when p's centre is snapped onto
/// it) and the sign that makes p's side positive. p's centre sees p's
/// plane, so it is never truly beyond the line: within 1e-4 of the change
/// between the centres it is on it (rounding put it either side: NVIDIA
/// fuses multiply-adds, lavapipe and the CPU do not), and the line halves
/// p's square. (Skipping a line exactly through the centre, as before, gave
/// pixels whose centre a crease crosses their whole square on their own
/// plane (measured: docs/accuracy.md, "Tuned constants").)
/// ssbc_geometry_base.comp's `crease_side` is the same.
fn crease_side(fp: f32, fq: f32) -> Option<(f32, f32)> {
    let offset = if fp.abs() <= 1e-4 * (fp - fq).abs() {
        fp
    } else {
        0.0
    };
    let fp = fp - offset;
    if fq == 0.0 || (fp != 0.0 && (fp > 0.0) == (fq > 0.0)) {
        return None;
    }
    let sign = if fp != 0.0 { fp.signum() } else { -fq.signum() };
    Some((offset, sign))
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
    /// Parts of pixels beyond a crease: (centroid, normal, area, the
    /// neighbour whose term they carry).
    across_creases: Vec<(Vec3, Vec3, f32, usize)>,
    /// Sources only: a second G-buffer layer, its term, and its pixels'
    /// (position, normal, area, term).
    hidden: Vec<(Vec3, Vec3, f32, Vec3)>,
    /// With glossy receivers, the eye they reflect towards.
    glossy_eye: Option<Vec3>,
    /// The camera (a source pixel's area widens a glossy lobe: its
    /// layer's pixel at its position, as the GPU's walk takes it).
    camera: TwinCamera,
    /// Image pixels a pixel of the second layer covers (4 at half
    /// resolution).
    hidden_scale: f32,
}

fn vec3_at(buf: &[f32], i: usize) -> Vec3 {
    Vec3::new(buf[i * 4], buf[i * 4 + 1], buf[i * 4 + 2])
}

impl<'a> BruteForceTwin<'a> {
    /// Prepares the pixels' footprints (split at creases as the GPU's) of `g` for the
    /// term `s_prev` (RGBA).
    pub fn new(g: &'a GBufferView<'a>, s_prev: &'a [f32], camera: TwinCamera, bound: f32) -> Self {
        let n = (g.width * g.height) as usize;
        let geometry: Vec<usize> = (0..n).filter(|&i| g.position[i * 4 + 3] != 0.0).collect();
        let mut area = vec![0.0; n];
        let mut across_creases = Vec::new();
        for &i in &geometry {
            let f = footprint(g, &camera, i as u32 % g.width, i as u32 / g.width);
            area[i] = f.own_area;
            across_creases.extend(f.other);
        }
        Self {
            g,
            s_prev,
            bound,
            geometry,
            area,
            across_creases,
            hidden: Vec::new(),
            glossy_eye: None,
            camera,
            hidden_scale: 1.0,
        }
    }

    /// Reads the receivers' BRDF from the G-buffer's w channels (albedo.w
    /// metallic, normal.w roughness, negative: Lambertian), as ssbc's own
    /// G-buffer holds it, and reflects towards the camera at `eye`:
    /// `S(x) = sum_y f_x(x->eye, x->y) max(G - b, 0) A_y S_prev(y)`.
    /// Without it every receiver is Lambertian of the albedo's rgb.
    pub fn with_glossy_receivers(mut self, eye: Vec3) -> Self {
        self.glossy_eye = Some(eye);
        self
    }

    /// Adds the pixels of a second G-buffer layer (a deep G-buffer's, as
    /// `SsbcPostProcess` takes it) at `resolution` as sources: at half
    /// resolution each stands for 2 x 2 pixels of the image (four times the
    /// area); at full resolution they are split at creases like the first
    /// layer's.
    pub fn with_second_layer(
        mut self,
        g: &GBufferView<'_>,
        s_prev: &[f32],
        camera: TwinCamera,
        resolution: LayerResolution,
    ) -> Self {
        let n = (g.width * g.height) as usize;
        let side = (1u32 << resolution.shift()) as f32;
        self.hidden_scale = side * side;
        for i in (0..n).filter(|&i| g.position[i * 4 + 3] != 0.0) {
            let (p, normal) = (vec3_at(g.position, i), vec3_at(g.normal, i));
            let s = vec3_at(s_prev, i);
            let area = match resolution {
                LayerResolution::Full => {
                    let f = footprint(g, &camera, i as u32 % g.width, i as u32 / g.width);
                    let across = f.other.map(|(c, nc, a, j)| (c, nc, a, vec3_at(s_prev, j)));
                    self.hidden.extend(across);
                    f.own_area
                }
                LayerResolution::Half => pixel_area(
                    p,
                    normal,
                    camera.position,
                    camera.forward,
                    side * camera.pixel_side,
                    camera.min_cos_view,
                ),
            };
            self.hidden.push((p, normal, area, s));
        }
        self
    }

    /// The residual (RGB) at pixel index `i` (row-major).
    pub fn residual(&self, i: usize) -> Vec3 {
        let g = self.g;
        if g.position[i * 4 + 3] == 0.0 || !self.bound.is_finite() {
            return Vec3::ZERO;
        }
        let (x, nx) = (vec3_at(g.position, i), vec3_at(g.normal, i));
        // (position, normal, area, term, image pixels per pixel) of every
        // source.
        let own = self.geometry.iter().map(|&j| {
            let s = vec3_at(self.s_prev, j);
            (vec3_at(g.position, j), vec3_at(g.normal, j), self.area[j], s, 1.0)
        });
        let across = self.across_creases.iter();
        let others = across.map(|&(y, ny, a, j)| (y, ny, a, vec3_at(self.s_prev, j), 1.0));
        let hidden = self.hidden.iter().map(|&(y, ny, a, s)| (y, ny, a, s, self.hidden_scale));
        let sources = own.chain(others).chain(hidden);
        let brdf = match self.glossy_eye {
            Some(eye) => {
                let albedo = glam::Vec4::from_slice(&g.albedo[i * 4..i * 4 + 4]);
                Some((Brdf::from_gbuffer(albedo, g.normal[i * 4 + 3]), eye))
            }
            None => None,
        };
        match brdf {
            Some((b, eye)) if !b.is_lambertian() => {
                let wo = (eye - x).normalize_or_zero();
                let mirror = 2.0 * nx.dot(wo) * nx - wo;
                // A pixel's area at x's distance, facing the eye (the GPU's
                // glossy_pixel_area).
                let c = &self.camera;
                let pixel_at_x = pixel_area(x, wo, c.position, c.forward, c.pixel_side, 0.0);
                sources
                    .map(|(y, ny, area, s, pixels)| {
                        let weight = residual_weight(x, nx, y, ny, self.bound);
                        if weight == 0.0 {
                            return Vec3::ZERO;
                        }
                        let d = y - x;
                        let w = d.normalize_or_zero();
                        // Its solid angle (the GPU's glossy_pixel_omega).
                        let omega = (-ny.dot(w)).max(0.0) * pixels * pixel_at_x / d.length_squared();
                        let spread2 = glossy_pixel_spread(omega, b.alpha(), w, mirror);
                        b.widened(spread2).eval(nx, wo, w) * weight * area * s
                    })
                    .sum()
            }
            _ => {
                let sum: Vec3 = sources
                    .map(|(y, ny, area, s, _)| residual_weight(x, nx, y, ny, self.bound) * area * s)
                    .sum();
                vec3_at(g.albedo, i) / std::f32::consts::PI * sum
            }
        }
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

#[cfg(test)]
mod tests {
    use super::crease_side;

    /// A crease line through p's centre (fp = 0), or a hair beyond it by
    /// rounding, halves p's square on p's side; a line that does not run
    /// between the centres is no crease. (Before, fp = 0 exactly was no
    /// crease and a rounding error either side decided (measured: docs/accuracy.md, "Tuned constants").)
    #[test]
    fn a_crease_line_through_the_centre_halves_the_pixel() {
        // Clearly between the centres: no snapping, p's side positive.
        assert_eq!(crease_side(0.3, -0.7), Some((0.0, 1.0)));
        assert_eq!(crease_side(-0.3, 0.7), Some((0.0, -1.0)));
        // Through p's centre, and a rounding error either side of it: the
        // line is moved onto the centre and oriented away from q.
        for fp in [0.0, 1e-6, -1e-6] {
            let (offset, sign) = crease_side(fp, -1.0).expect("a crease");
            assert_eq!((offset, sign), (fp, 1.0), "fp = {fp}");
            let (offset, sign) = crease_side(fp, 1.0).expect("a crease");
            assert_eq!((offset, sign), (fp, -1.0), "fp = {fp}");
        }
        // Both centres on one side, or q's on the line: no crease.
        assert_eq!(crease_side(0.3, 0.7), None);
        assert_eq!(crease_side(-2e-3, -1.0), None);
        assert_eq!(crease_side(0.3, 0.0), None);
    }
}
