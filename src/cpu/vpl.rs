//! VPL distribution by light tracing (Keller 1997): paths leave the lights
//! (punctual lights and emissive triangles) with their share of the emitted
//! power, deposit a VPL at every hit, and continue by sampling the surface's
//! BRDF with Russian roulette by the sample's weight f cos / pdf (a
//! Lambertian surface's albedo; at most [`MAX_SURVIVAL`]), which is what
//! ends them (the bounce limit is only a safety net). A path that starts on
//! an emitter's side facing into a solid, whose light cannot leave
//! it, deposits nothing. A path from an emitter first deposits a VPL
//! on the emitter itself ("bounce 0", albedo 1): its clamped contribution
//! near the fixture is what SSBC gives back.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::brdf::Brdf;
use super::bvh::{SceneBvh, RAY_EPSILON};
use super::emitters::{luminance, Emitters};
use super::sampling::{
    cosine_hemisphere, hash64, uniform_cone, uniform_disk, uniform_sphere, Halton,
};
use crate::error::{Error, Result};
use crate::scene::{Bounds, Light, LightKind, Scene};

/// A virtual point light: a diffuse surface point lit by a light path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Vpl {
    /// Position z_i (m).
    pub position: Vec3,
    /// Unit normal on the side the light arrived from.
    pub normal: Vec3,
    /// The BRDF at z_i (Lambertian of albedo 1 on an emitter, whose
    /// radiance is the same in every direction).
    pub brdf: Brdf,
    /// Unit direction the light arrived from (on an emitter, its normal):
    /// a glossy VPL sends `f(incident, w) Phi_i` towards w. On a surface
    /// whose shading normal turns from `normal`, the direction whose
    /// mirror about `normal` is the incident light's mirror about the
    /// shading normal (the lobe points where the shading normal sends it).
    pub incident: Vec3,
    /// A Lambertian VPL's shading normal where it turns more than
    /// [`SHADING_TURN_COS`] from `normal` (else zero): it sends nothing
    /// where the shading normal faces away.
    pub shading_normal: Vec3,
    /// Flux Phi_i (W) the path carried into z_i (on an emitter: the flux it
    /// leaves with).
    pub flux: Vec3,
    /// Radius (m) of the surface it stands for, from the distance to its
    /// nearest VPLs ([`VSL_NEIGHBOURS`]): glossy lobes are widened by the
    /// angle it subtends, as for a virtual spherical light (Hašan et al.
    /// 2009), which bounds what a narrow lobe makes of one VPL.
    pub radius: f32,
    /// Bounce at which it was deposited (0 = on an emitter, 1 = first hit).
    pub bounce: u32,
    /// The light path that deposited it (its index in the Halton sequence).
    /// With `bounce` it names the VPL across frames: when a light moves a
    /// little, the same path deposits "the same" VPL a little elsewhere,
    /// whatever happened to the paths before it.
    pub path: u64,
}

impl Vpl {
    /// f at z_i for light leaving towards `w` (unit) to a receiver at
    /// squared distance `d2`: what the VPL sends that way per unit flux and
    /// geometry term, its lobe widened by the angle its radius subtends.
    pub fn brdf_towards(&self, w: Vec3, d2: f32) -> Vec3 {
        if self.brdf.is_lambertian() {
            if self.shading_normal != Vec3::ZERO && self.shading_normal.dot(w) <= 0.0 {
                return Vec3::ZERO;
            }
            return self.brdf.base / std::f32::consts::PI;
        }
        self.brdf
            .widened(self.spread2(d2))
            .eval(self.normal, self.incident, w)
    }

    /// The square of the angle (rad) its radius subtends at squared
    /// distance `d2`: how much glossy lobes towards or from it widen.
    pub fn spread2(&self, d2: f32) -> f32 {
        self.radius * self.radius / d2.max(1e-12)
    }

    /// A number fixed by the VPL's identity (path, bounce), uniform over u64:
    /// what assigns it an interleaving subset and an ISM point set, so that
    /// neither changes between frames unless its own path does.
    pub fn identity_hash(&self) -> u64 {
        super::sampling::hash64(self.path.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ self.bounce as u64)
    }
}

pub use crate::settings::{VplSettings, DEFAULT_BOUNCES};

/// The highest survival probability of Russian roulette: on white surfaces
/// (albedo 1, the default glTF material) a path would otherwise bounce
/// until the bounce limit, and a handful of paths would make every VPL.
/// Unbiased (the flux is divided by it); paths average at most 10 bounces.
pub const MAX_SURVIVAL: f32 = 0.9;

/// The VPLs and how many light paths were started to make them.
#[derive(Clone, Debug, Default)]
pub struct VplSet {
    /// Every deposited VPL, flux already divided by `paths`.
    pub vpls: Vec<Vpl>,
    /// Paths started (the normalisation, including paths that missed).
    pub paths: u64,
    /// Most VPLs one path deposited.
    pub max_per_path: u32,
    /// Power (W, rgb) the scene's emissive triangles emit.
    pub emitted_power: Vec3,
    /// The part of `emitted_power` left out because it goes into closed
    /// volumes ([`Enclosure::emits_into_solid`](super::enclosure::Enclosure::emits_into_solid)):
    /// `emitted_power` times the share of the flux of the paths started on
    /// emitters that started enclosed, so never more than `emitted_power`.
    pub enclosed_power: Vec3,
    /// What each path did, for tracing the same paths again after objects
    /// moved ([`generate_with`]).
    trail: Trail,
}

/// A ray a light path cast: origin, unit direction, and how far it went
/// (infinite for a miss).
#[derive(Clone, Copy, Debug)]
struct Segment {
    origin: Vec3,
    dir: Vec3,
    t: f32,
}

/// One light path's record: its VPLs (before normalisation) and rays.
#[derive(Clone, Debug)]
struct PathLog {
    vpls: std::ops::Range<usize>,
    segments: std::ops::Range<usize>,
}

/// Every path of a set, from its first.
#[derive(Clone, Debug, Default)]
struct Trail {
    first: u64,
    raw: Vec<Vpl>,
    segments: Vec<Segment>,
    paths: Vec<PathLog>,
}

impl Trail {
    /// Logs a path that deposited `vpls` and cast the segments from
    /// `segments` on.
    fn log(&mut self, vpls: std::ops::Range<usize>, segments: usize) {
        self.paths.push(PathLog {
            vpls,
            segments: segments..self.segments.len(),
        });
    }

    /// Logs a path that deposited nothing and cast nothing.
    fn skip(&mut self, vpls: usize, segments: usize) {
        self.paths.push(PathLog {
            vpls: vpls..vpls,
            segments: segments..segments,
        });
    }
}

/// What lets [`generate_with`] keep light paths of an earlier set: the set
/// (for the same lights, settings and visible objects, without emissive
/// triangles) and the world boxes where objects were and are now. A path
/// none of whose rays crosses a box is the path a new trace would make.
pub struct Reuse<'a> {
    /// The earlier set.
    pub set: &'a VplSet,
    /// Where the moved objects were and are (world bounds).
    pub moved: &'a [Bounds],
}

/// Whether the ray from `origin` along `dir` meets box `b` before `t`.
pub fn ray_meets_box(origin: Vec3, dir: Vec3, t: f32, b: &Bounds) -> bool {
    let inv = dir.recip();
    let (t0, t1) = ((b.min - origin) * inv, (b.max - origin) * inv);
    let near = t0.min(t1).max_element();
    let far = t0.max(t1).min_element();
    // NaN (a ray in a box's face plane) counts as meeting it.
    !(near > far || far < 0.0 || near > t)
}

/// Power (W) emitted by a light (per channel); `scene_radius` sizes the disk
/// that stands in for a directional light.
pub fn light_power(light: &Light, scene_radius: f32) -> Vec3 {
    match light.kind {
        LightKind::Point => light.intensity * 4.0 * std::f32::consts::PI,
        LightKind::Spot {
            inner_cone,
            outer_cone,
        } => {
            // Integral of the glTF smooth falloff over the cone: 2pi I int t(c)^2 dc.
            let (co, ci) = (outer_cone.cos(), inner_cone.cos());
            let width = (ci - co).max(1e-3);
            let falloff = (1.0 - ci) + width / 3.0;
            light.intensity * 2.0 * std::f32::consts::PI * falloff
        }
        LightKind::Directional => {
            light.intensity * std::f32::consts::PI * scene_radius * scene_radius
        }
    }
}

/// Distributes about `settings.count` VPLs over `scene`. Stops early (with
/// fewer VPLs) if 64 x `count` paths produce too few (e.g. lights facing away).
pub fn generate(scene: &Scene, bvh: &SceneBvh, settings: &VplSettings) -> Result<VplSet> {
    generate_with(scene, bvh, settings, &scene.bounds(), None)
}

/// [`generate`] for a scene with bounds `bounds`, keeping the paths of
/// `reuse` that the moved objects cannot have changed (the result is the
/// set `generate` makes, path for path).
pub fn generate_with(
    scene: &Scene,
    bvh: &SceneBvh,
    settings: &VplSettings,
    bounds: &Bounds,
    reuse: Option<Reuse<'_>>,
) -> Result<VplSet> {
    check_bounces(settings)?;
    let mut set = VplSet::default();
    let emitters = Emitters::new(scene);
    if settings.count == 0 || (scene.lights.is_empty() && emitters.is_empty()) {
        return Ok(set);
    }
    let radius = bounds.radius().max(1e-3);
    let powers = source_powers(scene, &emitters, radius);
    let total: f32 = powers.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return Ok(set);
    }
    let halton = Halton::new(settings.seed);
    let max_paths = settings.count as u64 * 64;
    let mut raw = Vec::with_capacity(settings.count);
    // Paths continue the sequence after those of earlier frames.
    let first = settings.first_path;
    let mut path = first;
    // Flux of the paths started on emitters, and of those left out.
    let (mut emitter_flux, mut enclosed) = (Vec3::ZERO, Vec3::ZERO);
    let enclosure = (!emitters.is_empty()).then(|| super::enclosure::Enclosure::new(scene, bvh));
    // Emitters' paths start from sampled triangles and an enclosure test:
    // they are never kept.
    let reuse = reuse.filter(|r| emitters.is_empty() && r.set.trail.first == first);
    let mut trail = Trail {
        first,
        ..Trail::default()
    };
    while raw.len() < settings.count && path - first < max_paths && path < u64::MAX {
        let before = raw.len();
        let segments_before = trail.segments.len();
        if let Some((log, old)) = reuse.as_ref().and_then(|r| kept_path(r, path - first)) {
            raw.extend_from_slice(&old.trail.raw[log.vpls.clone()]);
            trail
                .segments
                .extend_from_slice(&old.trail.segments[log.segments.clone()]);
            trail.log(before..raw.len(), segments_before);
            path += 1;
            continue;
        }
        let s = |d: usize| halton.sample(path, d);
        let li = pick_source(&powers, s(0) * total);
        let p_light = powers[li] / total;
        let (origin, dir, mut flux, leaving) = if li == scene.lights.len() {
            let start = EmitterStart::sample(scene, &emitters, enclosure.as_ref(), path, s);
            let flux = start.flux();
            emitter_flux += flux;
            let Some((vpl, dir, triangle)) = start.leaving() else {
                enclosed += start.enclosed_flux();
                trail.skip(before, segments_before);
                path += 1;
                continue;
            };
            raw.push(Vpl {
                flux: flux / p_light,
                ..vpl
            });
            (vpl.position, dir, flux, Some(triangle))
        } else {
            let (u1, u2) = (Vec2::new(s(1), s(2)), Vec2::new(s(3), s(4)));
            let (origin, dir, flux) = punctual_start(&scene.lights[li], radius, bounds, u1, u2);
            (origin, dir, flux, None)
        };
        flux /= p_light;
        path += 1;
        trace_path(
            scene,
            bvh,
            settings,
            &halton,
            path - 1,
            origin,
            leaving,
            dir,
            flux,
            &mut raw,
            &mut trail.segments,
        );
        trail.log(before..raw.len(), segments_before);
    }
    set.paths = path - first;
    set.max_per_path = trail.paths.iter().map(|p| p.vpls.len() as u32).max().unwrap_or(0);
    trail.raw = raw.clone();
    set.trail = trail;
    // Exactly `count` VPLs: GPU resources are sized by it.
    let norm = (1.0 / set.paths.max(1) as f32) * thin_to(&mut raw, settings.count);
    set.emitted_power = emitters.power();
    set.enclosed_power = set.emitted_power * (enclosed / emitter_flux.max(Vec3::splat(1e-30)));
    raw.iter_mut().for_each(|v| v.flux *= norm);
    set.vpls = raw;
    assign_radii(&mut set.vpls);
    Ok(set)
}

/// VPLs need a bounce.
fn check_bounces(settings: &VplSettings) -> Result<()> {
    if settings.count > 0 && settings.bounces == 0 {
        return Err(Error::InvalidParameter(
            "vpl.bounces 0 leaves no VPLs; set vpl.count to 0 to switch indirect light off"
                .into(),
        ));
    }
    Ok(())
}

/// The power (luminance) of every punctual light, then of the emitters as
/// one source: what light paths start from.
fn source_powers(scene: &Scene, emitters: &Emitters, radius: f32) -> Vec<f32> {
    let lights = scene.lights.iter().map(|l| light_power(l, radius));
    lights
        .chain(std::iter::once(emitters.power()))
        .map(|p| luminance(p).max(0.0))
        .collect()
}

/// The earlier set's path `index` (from its first) with that set, if none
/// of its rays crosses where an object moved.
fn kept_path<'a>(reuse: &Reuse<'a>, index: u64) -> Option<(&'a PathLog, &'a VplSet)> {
    let log = reuse.set.trail.paths.get(index as usize)?;
    let segments = &reuse.set.trail.segments[log.segments.clone()];
    let crossed = segments
        .iter()
        .any(|s| reuse.moved.iter().any(|b| ray_meets_box(s.origin, s.dir, s.t, b)));
    (!crossed).then_some((log, reuse.set))
}

/// The source whose share of the summed `powers` holds `pick` (a uniform
/// number times their sum): each in proportion to its power.
fn pick_source(powers: &[f32], mut pick: f32) -> usize {
    for (i, p) in powers.iter().enumerate() {
        if pick < *p {
            return i;
        }
        pick -= p;
    }
    powers.len() - 1
}

/// A light path's start on an emissive triangle: a point in proportion to
/// power, a VPL on it, then a cosine-distributed direction (pdf cos/pi, so
/// the path's flux is pi Le / pdf_area).
enum EmitterStart {
    /// A cut-out point of an alpha-masked emitter: it sends nothing.
    Nothing,
    /// Light emitted into a solid never leaves it: the path counts (the
    /// estimate stays unbiased) but deposits nothing.
    IntoSolid(Vec3),
    /// The VPL on the emitter (its flux not yet divided by the source's
    /// probability), the direction the path leaves in and the triangle.
    Leaving(Vpl, Vec3, u32),
}

impl EmitterStart {
    fn sample(
        scene: &Scene,
        emitters: &Emitters,
        enclosure: Option<&super::enclosure::Enclosure>,
        path: u64,
        s: impl Fn(usize) -> f32,
    ) -> Self {
        let e = emitters.sample(scene, glam::Vec4::new(s(1), s(2), s(3), s(4)));
        let Some(e) = e.filter(|e| e.radiance != Vec3::ZERO) else {
            return Self::Nothing;
        };
        let flux = e.radiance * std::f32::consts::PI / e.pdf_area;
        if enclosure.is_some_and(|c| c.emits_into_solid(&e)) {
            return Self::IntoSolid(flux);
        }
        let vpl = Vpl {
            position: e.position,
            normal: e.normal,
            brdf: Brdf::lambertian(Vec3::ONE),
            incident: e.normal,
            shading_normal: Vec3::ZERO,
            flux,
            radius: 0.0,
            bounce: 0,
            path,
        };
        let dir = cosine_hemisphere(e.normal, Vec2::new(s(5), s(6)));
        Self::Leaving(vpl, dir, e.triangle)
    }

    /// The flux the path starts with (zero for a cut-out point).
    fn flux(&self) -> Vec3 {
        match self {
            Self::Nothing => Vec3::ZERO,
            Self::IntoSolid(flux) => *flux,
            Self::Leaving(vpl, ..) => vpl.flux,
        }
    }

    /// The flux emitted into a solid.
    fn enclosed_flux(&self) -> Vec3 {
        match self {
            Self::IntoSolid(flux) => *flux,
            _ => Vec3::ZERO,
        }
    }

    /// The VPL, direction and triangle of a path that leaves the emitter.
    fn leaving(&self) -> Option<(Vpl, Vec3, u32)> {
        match self {
            Self::Leaving(vpl, dir, triangle) => Some((*vpl, *dir, *triangle)),
            _ => None,
        }
    }
}

/// Thins `raw` to `count` VPLs without bias, returning the weight the
/// survivors take. The last path ran to its end (cutting it short would
/// lose the light of its later bounces: a bias of about 1/paths), so there
/// may be a surplus: the VPLs lowest in a hash of their identity (a choice
/// independent of what they carry, and of the interleaving subset the
/// identity hash's high bits pick) are dropped and the rest weighted up.
fn thin_to(raw: &mut Vec<Vpl>, count: usize) -> f32 {
    let surplus = raw.len().saturating_sub(count);
    if surplus == 0 {
        return 1.0;
    }
    let mut order: Vec<(u64, usize)> = raw
        .iter()
        .enumerate()
        .map(|(i, v)| (hash64(v.identity_hash() ^ 0xD1B5_4A32_D192_ED03), i))
        .collect();
    order.sort_unstable();
    let mut keep = vec![true; raw.len()];
    for &(_, i) in &order[..surplus] {
        keep[i] = false;
    }
    let weight = raw.len() as f32 / count as f32;
    let mut k = keep.iter();
    raw.retain(|_| *k.next().expect("one flag per VPL"));
    weight
}

/// How many nearest VPLs set a VPL's radius.
pub const VSL_NEIGHBOURS: usize = 8;

/// Gives every VPL the radius of the disk that holds its share of the
/// surface around it: the distance to its [`VSL_NEIGHBOURS`]-th nearest
/// VPL over sqrt(VSL_NEIGHBOURS) (that disk holds about that many VPLs, so
/// each stands for 1 / VSL_NEIGHBOURS of its area). Alone: radius 0.
pub fn assign_radii(vpls: &mut [Vpl]) {
    let k = VSL_NEIGHBOURS.min(vpls.len().saturating_sub(1));
    if k == 0 {
        vpls.iter_mut().for_each(|v| v.radius = 0.0);
        return;
    }
    // (The second number is the points a leaf holds, not the tree's size.)
    let mut tree = kdtree::KdTree::with_capacity(3, 16);
    for (i, v) in vpls.iter().enumerate() {
        // Positions are finite (they lie on the scene's validated geometry).
        let _ = tree.add(v.position.to_array(), i);
    }
    let radii: Vec<f32> = vpls
        .par_iter()
        .map(|v| {
            // The VPL itself is its own nearest (distance 0): k + 1 of them.
            tree.nearest(
                &v.position.to_array(),
                k + 1,
                &kdtree::distance::squared_euclidean,
            )
            .ok()
            .and_then(|n| n.last().map(|(d2, _)| d2.sqrt() / (k as f32).sqrt()))
            .unwrap_or(0.0)
        })
        .collect();
    for (v, r) in vpls.iter_mut().zip(radii) {
        v.radius = r;
    }
}

/// Where a light path from the punctual light `light` starts, in which
/// direction, and with which flux (before dividing by the light's choice
/// probability); `radius` sizes the disk standing in for a directional
/// light, `u1` and `u2` are its random numbers.
fn punctual_start(
    light: &Light,
    radius: f32,
    bounds: &crate::scene::Bounds,
    u1: Vec2,
    u2: Vec2,
) -> (Vec3, Vec3, Vec3) {
    match light.kind {
        LightKind::Point => (
            light.position,
            uniform_sphere(u1),
            light_power(light, radius),
        ),
        LightKind::Spot { outer_cone, .. } => {
            let cos_max = outer_cone.cos();
            let dir = uniform_cone(light.direction, cos_max, u1);
            let pdf = 1.0 / (2.0 * std::f32::consts::PI * (1.0 - cos_max));
            (
                light.position,
                dir,
                light.intensity * light.spot_factor(dir) / pdf,
            )
        }
        LightKind::Directional => {
            let (t, b) = super::sampling::basis(light.direction);
            let d = uniform_disk(u2) * radius;
            let origin = bounds.center() - light.direction * (2.0 * radius) + t * d.x + b * d.y;
            (origin, light.direction, light_power(light, radius))
        }
    }
}

/// Largest ratio of a shading to a geometric cosine taken (grazing the
/// geometric surface they grow without bound; the path tracer never sees
/// them, its camera paths need no such ratio).
const MAX_SHADING_RATIO: f32 = 4.0;

/// Shading normals within this cosine of the geometric one count as it
/// (interpolated normals on tessellated curves: a glossy VPL's lobe moves
/// by twice the angle, a Lambertian one's hemisphere by a sliver).
pub const SHADING_TURN_COS: f32 = 0.996;

/// A VPL's (incident, shading normal) where the light arrived from `wi`
/// (see [`Vpl::incident`], [`Vpl::shading_normal`]).
fn shading_frame(brdf: &Brdf, shading: Vec3, geometric: Vec3, wi: Vec3) -> (Vec3, Vec3) {
    if shading.dot(geometric) >= SHADING_TURN_COS {
        return (wi, Vec3::ZERO);
    }
    if brdf.is_lambertian() {
        return (wi, shading);
    }
    // The mirror about the shading normal, mirrored back about the
    // geometric one; kept above the surface.
    let mirror = 2.0 * shading.dot(wi) * shading - wi;
    let incident = 2.0 * geometric.dot(mirror) * geometric - mirror;
    if incident.dot(geometric) > 0.0 {
        (incident.normalize(), Vec3::ZERO)
    } else {
        (wi, Vec3::ZERO)
    }
}

/// |n_s . w| / |n_g . w|, at most MAX_SHADING_RATIO (1 where they agree).
fn shading_ratio(shading: Vec3, geometric: Vec3, w: Vec3) -> f32 {
    let cos_g = geometric.dot(w).abs();
    if shading == geometric || cos_g <= 0.0 {
        return 1.0;
    }
    (shading.dot(w).abs() / cos_g).min(MAX_SHADING_RATIO)
}

/// Follows light path `path` from `origin` (on triangle `leaving`, if it
/// starts on an emitter) along `dir` carrying `flux`: a VPL at every hit,
/// Russian roulette by f cos / pdf, BRDF-sampled bounces (Halton
/// dimensions from 7 on, 3 per bounce, the lobe from 1025 on).
#[allow(clippy::too_many_arguments)]
fn trace_path(
    scene: &Scene,
    bvh: &SceneBvh,
    settings: &VplSettings,
    halton: &Halton,
    path: u64,
    mut origin: Vec3,
    leaving: Option<u32>,
    mut dir: Vec3,
    mut flux: Vec3,
    out: &mut Vec<Vpl>,
    segments: &mut Vec<Segment>,
) {
    // A path runs to its end even past `settings.count` VPLs (`generate`
    // thins the surplus without bias).
    for bounce in 1..=settings.bounces {
        let hit = match leaving.filter(|_| bounce == 1) {
            Some(t) => bvh.intersect_leaving(origin, dir, t),
            None => bvh.intersect(origin, dir, RAY_EPSILON * bvh.length_floor(), f32::INFINITY),
        };
        segments.push(Segment {
            origin,
            dir,
            t: hit.map_or(f32::INFINITY, |h| h.t),
        });
        let Some(hit) = hit else {
            return;
        };
        let surf = bvh.surface(scene, &hit, -dir);
        // Shading normals, as the path tracer reflects: a surface reflects
        // the light arriving from w_i weighted by |n_s . w_i|, where the
        // flux a light path brings counts |n_g . w_i| (Veach 1997, 5.3: the
        // adjoint BRDF with shading normals). The VPL's flux carries the
        // ratio; it reflects around the geometric normal (a normal map
        // shades, it does not tilt the surface that reflects).
        flux *= shading_ratio(surf.normal, surf.geometric_normal, -dir);
        let (incident, shading_normal) = shading_frame(&surf.brdf, surf.normal, surf.geometric_normal, -dir);
        out.push(Vpl {
            position: surf.position,
            normal: surf.geometric_normal,
            brdf: surf.brdf,
            incident,
            shading_normal,
            flux,
            radius: 0.0,
            bounce,
            path,
        });
        if bounce == settings.bounces {
            return;
        }
        // A direction from the BRDF (f is reciprocal: sampled as if seen
        // from where the light came), then Russian roulette by f cos / pdf
        // (the albedo of a Lambertian surface), at most MAX_SURVIVAL.
        let dim = 7 + 3 * (bounce as usize - 1);
        let u = |k: usize| halton.sample(path, dim + k);
        // The lobe's number comes from dimensions past the bounces' (a
        // Lambertian surface draws none, as before glossy surfaces).
        let lobe = if surf.brdf.is_lambertian() {
            0.0
        } else {
            halton.sample(path, 1024 + bounce as usize)
        };
        let Some(sample) = surf.brdf.sample(surf.normal, -dir, Vec3::new(lobe, u(1), u(2)))
        else {
            return;
        };
        // f |n_g . w| / pdf: the light leaving is counted by the area it
        // leaves (the sample's weight has |n_s . w|).
        let cos_s = sample.wi.dot(surf.normal).abs();
        let cos_g = sample.wi.dot(surf.geometric_normal);
        if cos_g <= 0.0 || cos_s <= 1e-6 {
            return;
        }
        let weight = sample.weight * (cos_g / cos_s).min(MAX_SHADING_RATIO);
        let survive = weight.max_element().min(MAX_SURVIVAL);
        if survive <= 0.0 || u(0) >= survive {
            return;
        }
        flux *= weight / survive;
        dir = sample.wi;
        origin = surf.position + surf.geometric_normal * bvh.surface_offset(surf.position);
    }
}

/// Orders `vpls` by interleaving subset, for a gather in which each pixel
/// of an N x N block evaluates one of `subsets` = N² subsets: VPL v is in
/// subset `(v.identity_hash() >> 32) % subsets`, a random split that keeps a
/// VPL in its subset from frame to frame. The order within a subset is
/// kept (one subset: nothing moves). Returns the `subsets + 1` offsets of
/// the subsets in the new order.
pub fn interleave(vpls: &mut [Vpl], subsets: u32) -> Vec<u32> {
    let subsets = subsets.max(1);
    let subset = |v: &Vpl| ((v.identity_hash() >> 32) % subsets as u64) as u32;
    vpls.sort_by_key(subset);
    let mut offsets = vec![0u32; subsets as usize + 1];
    for v in vpls.iter() {
        offsets[subset(v) as usize + 1] += 1;
    }
    for s in 0..subsets as usize {
        offsets[s + 1] += offsets[s];
    }
    offsets
}

/// Bounded VPL lighting at one surface point seen from `wo`, the CPU twin
/// of the GPU's `indirect_bounded` pass:
/// `sum_i f_x(wo, x->z_i) min(G, b) V(x, z_i) f_i(incident_i, z_i->x) Phi_i`,
/// both glossy lobes widened by the angle VPL i's radius subtends at x.
/// `visible(i, vpl)` decides visibility (exact ray casts, or an ISM lookup).
pub fn bounded_radiance(
    position: Vec3,
    normal: Vec3,
    brdf: &Brdf,
    wo: Vec3,
    vpls: &[Vpl],
    bound: f32,
    mut visible: impl FnMut(usize, &Vpl) -> bool,
) -> Vec3 {
    let mut sum = Vec3::ZERO;
    for (i, v) in vpls.iter().enumerate() {
        let d = position - v.position;
        let d2 = d.length_squared();
        if d2 < 1e-10 {
            continue;
        }
        let w = d / d2.sqrt();
        let (cos_z, cos_x) = (v.normal.dot(w), -normal.dot(w));
        if cos_z <= 0.0 || cos_x <= 0.0 {
            continue;
        }
        let g = (cos_x * cos_z / d2).min(bound);
        if visible(i, v) {
            let receiver = if brdf.is_lambertian() {
                brdf.base / std::f32::consts::PI
            } else {
                brdf.widened(v.spread2(d2)).eval(normal, wo, -w)
            };
            sum += receiver * v.brdf_towards(w, d2) * v.flux * g;
        }
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Scene;

    /// Moving one object: the paths that kept away from where it was and
    /// is are copied, the rest traced again, and the set (and every VPL's
    /// corner rays) is the one a full trace makes, bit for bit.
    #[test]
    fn paths_kept_after_an_object_moved_give_the_full_trace() {
        let mut scene = crate::scene::builtin::cornell();
        scene.ensure_light();
        let settings = VplSettings {
            count: 512,
            ..VplSettings::default()
        };
        let bvh = SceneBvh::new(&scene);
        let before = generate(&scene, &bvh, &settings).unwrap();
        let miss = 10.0;
        let corners = super::super::ism_rays::corner_depths(&bvh, &before.vpls, miss, None);
        // The last object (a block) moves up by 5 cm and turns.
        let object = scene.objects().len() - 1;
        let old = scene.objects()[object].transform;
        let box_of = |scene: &Scene| {
            let o = &scene.objects()[object];
            scene.meshes()[o.mesh].bounds().unwrap().transformed(o.transform)
        };
        let was = box_of(&scene);
        let new = glam::Mat4::from_translation(Vec3::new(0.0, 0.05, 0.0))
            * old
            * glam::Mat4::from_rotation_y(0.2);
        scene.set_transform(object, new).unwrap();
        let moved = [was, box_of(&scene)];
        let bvh = bvh.moved(&scene);
        let reuse = Reuse {
            set: &before,
            moved: &moved,
        };
        let kept = generate_with(&scene, &bvh, &settings, &scene.bounds(), Some(reuse)).unwrap();
        let fresh = generate(&scene, &bvh, &settings).unwrap();
        assert_eq!(kept.paths, fresh.paths);
        assert_eq!(kept.vpls, fresh.vpls);
        assert!(kept.vpls != before.vpls, "the block's move changes some paths");
        let shared = before
            .trail
            .paths
            .iter()
            .zip(&fresh.trail.paths)
            .filter(|(a, b)| before.trail.raw[a.vpls.clone()] == fresh.trail.raw[b.vpls.clone()])
            .count();
        assert!(
            shared * 2 > fresh.trail.paths.len(),
            "most paths keep away from the block ({shared} of {})",
            fresh.trail.paths.len()
        );
        let known = super::super::ism_rays::KnownCorners {
            vpls: &before.vpls,
            depths: &corners,
            moved: &moved,
        };
        let reused = super::super::ism_rays::corner_depths(&bvh, &kept.vpls, miss, Some(known));
        let full = super::super::ism_rays::corner_depths(&bvh, &kept.vpls, miss, None);
        assert_eq!(reused, full);
    }

    /// A VPL seen in a near-mirror floor: without a radius its reflection is
    /// a spike as high as the lobe is narrow; with one it is bounded by the
    /// radiance of the patch the VPL stands for, and the light the floor
    /// reflects towards the eye, summed over the floor, stays the same.
    #[test]
    fn a_vpl_radius_bounds_its_glossy_reflection_and_keeps_its_energy() {
        let mirror = Brdf::from_gbuffer(glam::Vec4::new(1.0, 1.0, 1.0, 1.0), super::super::brdf::MIN_ROUGHNESS);
        let eye = Vec3::new(-1.0, 1.0, 0.0);
        let mut vpl = Vpl {
            position: Vec3::new(1.0, 1.0, 0.0),
            normal: -Vec3::Y,
            brdf: Brdf::lambertian(Vec3::ONE),
            incident: -Vec3::Y,
            shading_normal: Vec3::ZERO,
            flux: Vec3::ONE,
            radius: 0.0,
            bounce: 1,
            path: 0,
        };
        // The floor y = 0 around the mirror point (0, 0, 0), on a fine grid.
        let (n, half) = (401, 0.4f32);
        let scan = |vpl: &Vpl| {
            let (mut peak, mut sum) = (0.0f32, 0.0f64);
            for i in 0..n {
                for j in 0..n {
                    let t = |k| (k as f32 / (n - 1) as f32 * 2.0 - 1.0) * half;
                    let x = Vec3::new(t(i), 0.0, t(j));
                    let wo = (eye - x).normalize();
                    let l = bounded_radiance(x, Vec3::Y, &mirror, wo, std::slice::from_ref(vpl), f32::INFINITY, |_, _| true).x;
                    peak = peak.max(l);
                    sum += l as f64;
                }
            }
            (peak, sum)
        };
        let (peak_point, sum_point) = scan(&vpl);
        vpl.radius = 0.05;
        let (peak_sphere, sum_sphere) = scan(&vpl);
        // A Lambertian disk of radius r sending flux Phi has radiance
        // Phi / (pi * pi r^2); the mirror reflects it with Fresnel about 1.
        let patch = 1.0 / (std::f32::consts::PI.powi(2) * vpl.radius * vpl.radius);
        assert!(peak_point > 10.0 * patch, "no spike to bound: {peak_point} vs {patch}");
        assert!(
            (0.1 * patch..2.0 * patch).contains(&peak_sphere),
            "peak {peak_sphere}, patch radiance {patch}"
        );
        let ratio = sum_sphere / sum_point;
        eprintln!("VPL in a mirror: peak {peak_point} -> {peak_sphere} (patch radiance {patch}), reflected light x {ratio:.4}");
        assert!((ratio - 1.0).abs() < 0.05, "reflected light changed by {ratio}");
    }

    #[test]
    fn first_bounce_flux_equals_emitted_power_in_a_closed_box() {
        // Close the Cornell box's open side so every path hits something.
        let mut scene = crate::scene::builtin::cornell();
        let m = scene.materials.len() as u32 - 1;
        let p = [
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(-1.0, 2.0, 1.0),
        ];
        scene
            .add_mesh(
                &p,
                &[-Vec3::Z; 4],
                &[],
                &[0, 1, 2, 0, 2, 3],
                glam::Mat4::IDENTITY,
                m,
            )
            .unwrap();
        let bvh = SceneBvh::new(&scene);
        let set = generate(
            &scene,
            &bvh,
            &VplSettings {
                count: 20_000,
                bounces: 1,
                seed: 3,
                first_path: 0,
            },
        )
        .unwrap();
        let first: Vec3 = set
            .vpls
            .iter()
            .filter(|v| v.bounce == 1)
            .map(|v| v.flux)
            .sum();
        let power = light_power(&scene.lights[0], 1.0);
        let rel = ((first - power).abs() / power).max_element();
        eprintln!(
            "first-bounce flux {first} vs emitted {power}: {:.3}% apart",
            rel * 100.0
        );
        assert!(
            rel < 0.01,
            "first-bounce flux {first} vs power {power} ({:.3}% off)",
            rel * 100.0
        );
        assert_eq!(
            set.paths as usize,
            set.vpls.len(),
            "closed box: every path hits"
        );
    }

    #[test]
    fn deterministic_for_a_seed() {
        let scene = crate::scene::builtin::cornell();
        let bvh = SceneBvh::new(&scene);
        let s = VplSettings {
            count: 64,
            bounces: 4,
            seed: 11,
            first_path: 0,
        };
        assert_eq!(
            generate(&scene, &bvh, &s).unwrap().vpls,
            generate(&scene, &bvh, &s).unwrap().vpls
        );
    }

    #[test]
    fn interleaving_keeps_a_vpl_in_its_subset() {
        let scene = crate::scene::builtin::cornell();
        let bvh = SceneBvh::new(&scene);
        let s = VplSettings {
            count: 4096,
            ..Default::default()
        };
        let mut vpls = generate(&scene, &bvh, &s).unwrap().vpls;
        let unsorted = vpls.clone();
        let offsets = interleave(&mut vpls, 16);
        assert_eq!(offsets.len(), 17);
        assert_eq!(offsets[16] as usize, vpls.len());
        // Every VPL is still there, each subset holds about 1/16 of them.
        let mut a: Vec<_> = unsorted.iter().map(|v| (v.path, v.bounce)).collect();
        let mut b: Vec<_> = vpls.iter().map(|v| (v.path, v.bounce)).collect();
        a.sort();
        b.sort();
        assert_eq!(a, b);
        for w in offsets.windows(2) {
            let size = (w[1] - w[0]) as f32;
            assert!((size - 256.0).abs() < 64.0, "subset of {size} VPLs");
        }
        // A VPL's subset depends on its path and bounce only: dropping the
        // first path's VPLs moves no other VPL to another subset.
        let subset_of = |vpls: &[Vpl], offsets: &[u32]| {
            let mut m = std::collections::HashMap::new();
            for s in 0..16 {
                for v in &vpls[offsets[s] as usize..offsets[s + 1] as usize] {
                    m.insert((v.path, v.bounce), s);
                }
            }
            m
        };
        let before = subset_of(&vpls, &offsets);
        let mut fewer: Vec<Vpl> = unsorted.into_iter().filter(|v| v.path != 0).collect();
        let fewer_offsets = interleave(&mut fewer, 16);
        for (key, s) in subset_of(&fewer, &fewer_offsets) {
            assert_eq!(before[&key], s);
        }
        // One subset keeps the order.
        let mut same = vpls.clone();
        assert_eq!(interleave(&mut same, 1), vec![0, vpls.len() as u32]);
        assert_eq!(same, vpls);
    }

    /// A 4 m cube with faces pointing out (double-sided, as a scaled
    /// default cube), an emissive quad under its ceiling, and a camera.
    fn outward_room(camera: Vec3) -> Scene {
        let mut scene = Scene::new("outward room");
        let wall = scene.add_material(Vec3::splat(0.7), None);
        let lamp = scene.add_material(Vec3::splat(0.7), None);
        scene.materials[lamp as usize].emission = Vec3::ONE;
        crate::scene::builtin::axis_box(&mut scene, Vec3::splat(-2.0), Vec3::splat(2.0), wall)
            .unwrap();
        let q =
            [(-0.3, -0.3), (0.3, -0.3), (0.3, 0.3), (-0.3, 0.3)].map(|(x, z)| Vec3::new(x, 1.9, z));
        scene
            .add_mesh(
                &q,
                &[-Vec3::Y; 4],
                &[],
                &[0, 2, 1, 0, 3, 2],
                glam::Mat4::IDENTITY,
                lamp,
            )
            .unwrap();
        scene
            .cameras
            .push(crate::scene::Camera::look_at(camera, Vec3::ZERO, 1.0));
        scene
    }

    #[test]
    fn light_in_a_closed_volume_is_kept_when_the_camera_is_in_there_too() {
        let settings = VplSettings {
            count: 256,
            ..Default::default()
        };
        // Camera inside: the room is all it sees, the lamp lights it.
        let inside = outward_room(Vec3::new(0.0, 0.0, 1.5));
        let set = generate(&inside, &SceneBvh::new(&inside), &settings).unwrap();
        assert_eq!(set.enclosed_power, Vec3::ZERO);
        assert!(set.vpls.iter().any(|v| v.bounce >= 1));
        // Camera outside: the lamp's light never leaves the room.
        let outside = outward_room(Vec3::new(0.0, 0.0, 9.0));
        let set = generate(&outside, &SceneBvh::new(&outside), &settings).unwrap();
        assert!(set.enclosed_power.x > 0.0);
        assert!(set.vpls.is_empty(), "{} VPLs", set.vpls.len());
    }

    #[test]
    fn zero_bounces_with_vpls_is_an_error() {
        let scene = crate::scene::builtin::cornell();
        let bvh = SceneBvh::new(&scene);
        assert!(generate(
            &scene,
            &bvh,
            &VplSettings {
                count: 8,
                bounces: 0,
                seed: 0,
                first_path: 0,
            }
        )
        .is_err());
    }
}
