//! Ground truth on the CPU: a path tracer for the same scenes, cameras, pixel
//! grid and light units as the GPU renderer, plus the two VPL baselines:
//! the VPL sum with exact visibility (`Vpl`) and Kollig & Keller's unbiased
//! compensation of the clamped sum by path tracing (`KolligKeller`).
//!
//! Every estimator is deterministic for a seed: each (pixel, sample,
//! dimension) draws from a hash. Samples are taken in passes over the whole
//! image, so a run can stop after any pass with a consistent image.

use std::sync::atomic::{AtomicBool, Ordering};

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::brdf::BrdfSample;
use super::bvh::{SceneBvh, Surface};
use super::emitters::{luminance, EmitterSample, Emitters};
use super::sampling::{cosine_hemisphere, hash64};
use super::vpl::{self, bounded_radiance, Vpl, VplSettings};
use crate::error::{Error, Result};
use crate::settings::NamedChoice;
use crate::scene::{Camera, LightKind, Scene};

/// Which estimator to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Path tracing with next-event estimation (the truth).
    PathTrace,
    /// Direct light plus the (clamped) VPL sum with exact visibility.
    Vpl,
    /// Direct light plus the clamped VPL sum plus the residual recovered by
    /// path tracing (Kollig & Keller 2004): unbiased w.r.t. the unclamped sum.
    KolligKeller,
}

crate::settings::named_choice!(Method, [
    Method::PathTrace => "path-trace",
    Method::Vpl => "vpl",
    Method::KolligKeller => "kollig-keller",
]);

/// The cosine below which a walk's surface point does not see the camera
/// ([`Reference::emission_reaches_camera`]).
const GRAZING: f32 = 1e-4;

/// Most bounces of the walk that decides whether an emitter's light can
/// reach the camera (`Reference::emission_reaches_camera`): with no
/// absorption a walk finds any opening of a volume long before this.
pub const REACH_WALK: u32 = 2048;

/// Reference-renderer parameters.
#[derive(Clone, Debug)]
pub struct ReferenceSettings {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Camera index (None: first or framing).
    pub camera: Option<usize>,
    /// Samples per pixel.
    pub spp: u32,
    /// Most indirect bounces (0 = direct light only): a safety net, Russian
    /// roulette ends paths.
    pub bounces: u32,
    /// Seed.
    pub seed: u64,
    /// Estimator.
    pub method: Method,
    /// VPLs for `Vpl` and `KolligKeller`.
    pub vpl: VplSettings,
    /// Clamping bound b for `Vpl` and `KolligKeller`.
    pub bound: f32,
    /// Each sample through a uniformly random point of its pixel (a box
    /// filter: the pixel's mean, as renderers that integrate over pixels
    /// give) instead of its centre (what the GPU's G-buffer samples). The
    /// `Vpl` method then takes `spp` passes too.
    pub antialias: bool,
}

impl Default for ReferenceSettings {
    fn default() -> Self {
        Self {
            width: 1024,
            height: 768,
            camera: None,
            spp: 64,
            bounces: super::vpl::DEFAULT_BOUNCES,
            seed: 0,
            method: Method::PathTrace,
            vpl: VplSettings::default(),
            bound: f32::INFINITY,
            antialias: false,
        }
    }
}

/// A deterministic random stream for one (pixel, sample).
struct Rng {
    key: u64,
    dim: u64,
}

impl Rng {
    fn new(seed: u64, pixel: u64, sample: u64) -> Self {
        Self {
            key: hash64(seed ^ hash64(pixel ^ hash64(sample.wrapping_add(0x5851_F42D)))),
            dim: 0,
        }
    }
    fn next(&mut self) -> f32 {
        self.dim += 1;
        let bits = hash64(self.key ^ self.dim.wrapping_mul(0x9E37_79B9_7F4A_7C15));
        ((bits >> 40) as f32 / (1u64 << 24) as f32).min(1.0 - f32::EPSILON)
    }
    fn next2(&mut self) -> Vec2 {
        Vec2::new(self.next(), self.next())
    }
}

/// Scene, BVH and VPLs shared by every pixel.
pub struct Reference<'a> {
    scene: &'a Scene,
    bvh: SceneBvh,
    camera: Camera,
    settings: ReferenceSettings,
    vpls: Vec<Vpl>,
    scene_radius: f32,
    emitters: Emitters,
}

/// The power heuristic's weight for a sample drawn with density `p` when
/// another strategy could have drawn it with density `q`.
fn power_heuristic(p: f32, q: f32) -> f32 {
    let (p2, q2) = (p * p, q * q);
    if p2 + q2 > 0.0 && (p2 + q2).is_finite() {
        p2 / (p2 + q2)
    } else if p > q {
        1.0
    } else {
        0.0
    }
}

/// Offset from a surface along its geometric normal, scaled to the scene.
fn offset(bvh: &SceneBvh, s: &Surface) -> Vec3 {
    s.position + s.geometric_normal * bvh.surface_offset(s.position)
}

impl<'a> Reference<'a> {
    /// Prepares the BVH and (for the VPL methods) the VPLs.
    pub fn new(scene: &'a Scene, settings: ReferenceSettings) -> Result<Self> {
        if settings.width == 0
            || settings.height == 0
            || settings.width > 16384
            || settings.height > 16384
        {
            return Err(Error::InvalidParameter(format!(
                "image size {}x{} outside 1..=16384",
                settings.width, settings.height
            )));
        }
        if settings.spp == 0 {
            return Err(Error::InvalidParameter("spp must be at least 1".into()));
        }
        if settings.bounces > 64 {
            return Err(Error::InvalidParameter("bounces above 64".into()));
        }
        if settings.bound.is_nan() || settings.bound <= 0.0 {
            return Err(Error::InvalidParameter(format!(
                "bound {} must be positive (or inf)",
                settings.bound
            )));
        }
        scene.validate()?;
        let camera = scene.camera(settings.camera)?;
        let bvh = SceneBvh::new(scene);
        let vpls = if settings.method == Method::PathTrace {
            Vec::new()
        } else {
            vpl::generate(scene, &bvh, &settings.vpl)?.vpls
        };
        Ok(Self {
            scene,
            bvh,
            camera,
            scene_radius: scene.bounds().radius(),
            settings,
            vpls,
            emitters: Emitters::new(scene),
        })
    }

    /// The BVH it casts rays with.
    pub fn bvh(&self) -> &SceneBvh {
        &self.bvh
    }

    /// The camera it renders from.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// The VPLs used by the VPL methods.
    pub fn vpls(&self) -> &[Vpl] {
        &self.vpls
    }

    /// Direct light (next-event estimation to every light) leaving `s`.
    pub fn direct(&self, s: &Surface) -> Vec3 {
        let mut e = Vec3::ZERO;
        let origin = offset(&self.bvh, s);
        for light in &self.scene.lights {
            let (to_light, irradiance, target) = match light.kind {
                LightKind::Directional => {
                    let dir = -light.direction;
                    (
                        dir,
                        light.intensity,
                        origin + dir * (4.0 * self.scene_radius + s.position.length()),
                    )
                }
                _ => {
                    let d = light.position - s.position;
                    let d2 = d.length_squared();
                    let dir = d / d2.sqrt();
                    (
                        dir,
                        light.intensity * light.spot_factor(-dir) / d2,
                        light.position,
                    )
                }
            };
            let cos = s.normal.dot(to_light);
            if cos <= 0.0
                || irradiance.max_element() <= 0.0
                || s.geometric_normal.dot(to_light) <= 0.0
            {
                continue;
            }
            if !self.bvh.occluded(origin, target) {
                e += s.brdf.eval(s.normal, s.wo, to_light) * irradiance * cos;
            }
        }
        e
    }

    /// Direct light from emissive triangles leaving `s`: one point sampled
    /// on them in proportion to power (next-event estimation), weighted
    /// against sampling the BRDF by the power heuristic if `mis` (the path
    /// then also counts emitters its BRDF-sampled ray hits).
    fn direct_emitters(&self, s: &Surface, rng: &mut Rng, mis: bool) -> Vec3 {
        let u = glam::Vec4::new(rng.next(), rng.next(), rng.next(), rng.next());
        let Some(e) = self.emitters.sample(self.scene, u) else {
            return Vec3::ZERO;
        };
        let d = e.position - s.position;
        let d2 = d.length_squared();
        if d2 < 1e-12 {
            return Vec3::ZERO;
        }
        let dir = d / d2.sqrt();
        let (cos_x, cos_e) = (s.normal.dot(dir), -e.normal.dot(dir));
        if cos_x <= 0.0 || cos_e <= 0.0 || s.geometric_normal.dot(dir) <= 0.0 {
            return Vec3::ZERO;
        }
        if self.bvh.occluded_except(offset(&self.bvh, s), e.position, e.triangle) {
            return Vec3::ZERO;
        }
        let weight = if mis {
            let p_light = e.pdf_area * d2 / cos_e;
            power_heuristic(p_light, s.brdf.pdf(s.normal, s.wo, dir))
        } else {
            1.0
        };
        s.brdf.eval(s.normal, s.wo, dir) * e.radiance * (cos_x * cos_e / d2 / e.pdf_area) * weight
    }

    /// What the VPL method shows at `s`: direct light plus the clamped VPL
    /// sum with exact visibility (a screen-space method's first source, S0).
    pub fn clamped_radiance(&self, s: &Surface) -> Vec3 {
        self.direct(s) + self.vpl_sum(s)
    }

    /// The clamped VPL sum at `s` with exact visibility.
    fn vpl_sum(&self, s: &Surface) -> Vec3 {
        let origin = offset(&self.bvh, s);
        bounded_radiance(
            s.position,
            s.normal,
            &s.brdf,
            s.wo,
            &self.vpls,
            self.settings.bound,
            |_, v| {
                !self.bvh.occluded(
                    v.position + v.normal * self.bvh.surface_offset(v.position),
                    origin,
                )
            },
        )
    }

    /// Path-traced radiance leaving `s` towards the previous vertex, counting
    /// only light that took `min_bounce..=max_bounce` indirect bounces.
    pub fn path_radiance(
        &self,
        s: &Surface,
        rng_pixel: u64,
        sample: u64,
        min_bounce: u32,
        max_bounce: u32,
    ) -> Vec3 {
        let mut rng = Rng::new(self.settings.seed, rng_pixel, sample);
        let mut surface = *s;
        let mut throughput = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        for bounce in 0..=max_bounce {
            // Emitters a BRDF-sampled ray hits count only off glossy
            // surfaces (weighted against next-event estimation); off
            // Lambertian ones next-event estimation alone covers them.
            let mis = !surface.brdf.is_lambertian() && bounce < max_bounce;
            let counted = bounce >= min_bounce;
            if counted {
                radiance += throughput
                    * (self.direct(&surface) + self.direct_emitters(&surface, &mut rng, mis));
            }
            if bounce == max_bounce {
                break;
            }
            // Russian roulette by f cos / pdf (the albedo of a Lambertian
            // surface), then a bounce sampled from the BRDF.
            let roulette = rng.next();
            let Some(sample) = self.sample_brdf(&surface, &mut rng) else {
                break;
            };
            let survive = sample.weight.max_element().min(1.0);
            if survive <= 0.0 || roulette >= survive {
                break;
            }
            throughput *= sample.weight / survive;
            let dir = sample.wi;
            if dir.dot(surface.geometric_normal) <= 0.0 {
                break;
            }
            let Some(hit) = self
                .bvh
                .intersect(offset(&self.bvh, &surface), dir, 0.0, f32::INFINITY)
            else {
                break;
            };
            let next = self.bvh.surface(self.scene, &hit, -dir);
            if mis && counted && next.emission.max_element() > 0.0 {
                let cos_e = next.geometric_normal.dot(-dir).abs().max(1e-8);
                let p_light = self.emitters.pdf_area(hit.triangle) * hit.t * hit.t / cos_e;
                radiance += throughput * next.emission * power_heuristic(sample.pdf, p_light);
            }
            surface = next;
        }
        radiance
    }

    /// A direction from `s`'s BRDF (a Lambertian one draws two numbers, as
    /// cosine sampling always did; a glossy one a third for the lobe).
    fn sample_brdf(&self, s: &Surface, rng: &mut Rng) -> Option<BrdfSample> {
        let lobe = if s.brdf.is_lambertian() {
            0.0
        } else {
            rng.next()
        };
        let u = rng.next2();
        s.brdf.sample(s.normal, s.wo, Vec3::new(lobe, u.x, u.y))
    }

    unstable_pub! {
        /// Whether light leaving the emitter sample `e` can reach the camera: a
        /// random walk from it (cosine-distributed bounces, no absorption, up to
        /// [`REACH_WALK`] of them) meets a surface point that sees the camera
        /// (the camera on the side the walk arrived on, the segment between them
        /// unoccluded) or leaves the scene: the truth light tracing's rule for
        /// solids is checked against (unstable).
        fn emission_reaches_camera(&self, e: &EmitterSample, walk: u64) -> bool {
            let mut rng = Rng::new(self.settings.seed ^ 0x0E4C_105E, walk, 0);
            let mut dir = cosine_hemisphere(e.normal, rng.next2());
            let mut hit = self.bvh.intersect_leaving(e.position, dir, e.triangle);
            for _ in 0..REACH_WALK {
                let Some(h) = hit else {
                    return true;
                };
                let s = self.bvh.surface(self.scene, &h, -dir);
                // Rays leave the point, kept off its triangle's edges (where
                // it lies in the next face's plane), by skipping its triangle:
                // any offset along the normal crosses a thin enough box.
                let p = self
                    .bvh
                    .inset(&h, super::enclosure::emission_offset(s.position, self.bvh.length_floor()));
                let to_camera = self.camera.position - p;
                // A camera in the surface's own plane sees it edge-on: no
                // light leaves that way (cos 0), and the segment would run
                // along the surface, where the occlusion test is rounding.
                if s.geometric_normal.dot(to_camera.normalize_or_zero()) > GRAZING
                    && !self
                        .bvh
                        .occluded_except(p, self.camera.position, h.triangle)
                {
                    return true;
                }
                // On, whatever the albedo: where light can go, not how much.
                dir = cosine_hemisphere(s.geometric_normal, rng.next2());
                hit = self.bvh.intersect_leaving(p, dir, h.triangle);
            }
            false
        }
    }

    unstable_pub! {
        /// The share of the emitters' power (luminance) whose light cannot reach
        /// the camera ([`Reference::emission_reaches_camera`]), from `samples`
        /// points drawn on the emitters as light tracing draws them, with the
        /// decisions per sample (`None` without emitters).
        fn enclosed_emission(&self, samples: u64) -> Option<(f32, Vec<(EmitterSample, bool)>)> {
            if self.emitters.is_empty() {
                return None;
            }
            let halton = super::sampling::Halton::new(self.settings.seed ^ 0xE4C1);
            let decided: Vec<(EmitterSample, bool, f32)> = (0..samples)
                .into_par_iter()
                .filter_map(|i| {
                    let u = glam::Vec4::new(
                        halton.sample(i, 0),
                        halton.sample(i, 1),
                        halton.sample(i, 2),
                        halton.sample(i, 3),
                    );
                    let e = self.emitters.sample(self.scene, u)?;
                    let weight = luminance(e.radiance) / e.pdf_area;
                    Some((e, !self.emission_reaches_camera(&e, i), weight))
                })
                .collect();
            let total: f32 = decided.iter().map(|d| d.2).sum();
            let enclosed: f32 = decided.iter().filter(|d| d.1).map(|d| d.2).sum();
            let share = if total > 0.0 { enclosed / total } else { 0.0 };
            Some((share, decided.into_iter().map(|(e, d, _)| (e, d)).collect()))
        }
    }

    /// Kollig & Keller: L(x) = direct + clamped VPL sum + residual, the
    /// residual estimated by a BRDF-sampled ray weighted by max(1 - b/G, 0)
    /// and recursing with the same estimator.
    fn kollig_keller(&self, s: &Surface, rng: &mut Rng, depth: u32) -> Vec3 {
        let mut l = self.direct(s) + self.vpl_sum(s);
        if depth >= self.settings.bounces || !self.settings.bound.is_finite() {
            return l;
        }
        let Some(sample) = self.sample_brdf(s, rng) else {
            return l;
        };
        let dir = sample.wi;
        if dir.dot(s.geometric_normal) <= 0.0 {
            return l;
        }
        let Some(hit) = self.bvh.intersect(offset(&self.bvh, s), dir, 0.0, f32::INFINITY) else {
            return l;
        };
        let y = self.bvh.surface(self.scene, &hit, -dir);
        let cos_x = s.normal.dot(dir);
        let cos_y = y.normal.dot(-dir);
        let g = cos_x * cos_y / (hit.t * hit.t);
        if g > self.settings.bound {
            // f cos_x / pdf, and the part of G above b.
            let weight = sample.weight * (1.0 - self.settings.bound / g);
            l += weight * self.kollig_keller(&y, rng, depth + 1);
        }
        l
    }

    /// One sample of pixel (x, y).
    fn sample(&self, x: u32, y: u32, sample: u64) -> Vec3 {
        let (w, h) = (self.settings.width, self.settings.height);
        let pixel = (y * w + x) as u64;
        let offset = if self.settings.antialias {
            // Its own stream: the paths' dimensions stay as without.
            Rng::new(self.settings.seed ^ 0xA471_A5ED, pixel, sample).next2() - 0.5
        } else {
            Vec2::ZERO
        };
        let dir = self
            .camera
            .pixel_ray(x as f32 + offset.x, y as f32 + offset.y, w, h);
        let Some(hit) = self
            .bvh
            .intersect_camera(self.scene, self.camera.position, dir)
        else {
            return Vec3::ZERO;
        };
        let s = self.bvh.surface(self.scene, &hit, -dir);
        // Emitters seen by the camera show their own radiance.
        s.emission
            + match self.settings.method {
                Method::PathTrace => {
                    self.path_radiance(&s, pixel, sample, 0, self.settings.bounces)
                }
                Method::Vpl => self.direct(&s) + self.vpl_sum(&s),
                Method::KolligKeller => {
                    let mut rng = Rng::new(self.settings.seed ^ 0x4B4B, pixel, sample);
                    self.kollig_keller(&s, &mut rng, 0)
                }
            }
    }

    /// Renders `spp` passes (fewer if `stop` is raised between passes),
    /// calling `progress(passes_done)` after each. Returns RGBA (alpha 1 on
    /// geometry) averaged over the passes done, and that count.
    pub fn render(&self, stop: &AtomicBool, mut progress: impl FnMut(u32)) -> (Vec<f32>, u32) {
        let (w, h) = (self.settings.width, self.settings.height);
        let mut sum = vec![Vec3::ZERO; (w * h) as usize];
        // Deterministic methods need one pass.
        let passes = if self.settings.method == Method::Vpl && !self.settings.antialias {
            1
        } else {
            self.settings.spp
        };
        let mut done = 0;
        for pass in 0..passes {
            if stop.load(Ordering::Relaxed) {
                break;
            }
            sum.par_iter_mut().enumerate().for_each(|(i, acc)| {
                *acc += self.sample(i as u32 % w, i as u32 / w, pass as u64);
            });
            done += 1;
            progress(done);
        }
        let inv = 1.0 / done.max(1) as f32;
        let geometry: Vec<bool> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let dir = self.camera.pixel_ray((i % w) as f32, (i / w) as f32, w, h);
                self.bvh
                    .intersect_camera(self.scene, self.camera.position, dir)
                    .is_some()
            })
            .collect();
        let rgba = sum
            .iter()
            .zip(&geometry)
            .flat_map(|(s, &g)| {
                let v = *s * inv;
                [v.x, v.y, v.z, if g { 1.0 } else { 0.0 }]
            })
            .collect();
        (rgba, done)
    }
}
