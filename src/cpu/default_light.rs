//! The default light of a scene that nothing lights: deciding whether its
//! emitters light it and placing the light both need ray casts, so it lives
//! with the BVH rather than in [`crate::scene`], which knows nothing of ray
//! casting.

use glam::{Vec2, Vec3, Vec4};

use super::bvh::SceneBvh;
use super::emitters::{luminance, Emitters};
use super::sampling::{cosine_hemisphere, Halton};
use crate::scene::{Light, LightKind, Scene};

/// Below this share of their light reaching a surface that reflects it,
/// emitters do not light the scene (they glow into the void: a label on a
/// convex bottle, a lone emissive plane).
pub const MIN_EMISSION_REACH: f32 = 0.05;

/// Below this mean irradiance (W/m², over the scene's surface area) that
/// the emitters' light brings onto the surfaces that reflect it, they do not
/// light the scene: a thousandth of the default light's level at the
/// centre of the scene (a tiny or nearly black emissive texture).
pub const MIN_EMISSION_IRRADIANCE: f32 = 1e-3;

/// What the scene's emitters do for its lighting, by light tracing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionReach {
    /// Power (W, luminance) emitted.
    pub emitted: f32,
    /// The part of `emitted` that does not go into solids.
    pub power: f32,
    /// Share of `power` whose first hit is a surface, weighted by the
    /// surface's albedo (what makes it visible).
    pub reach: f32,
    /// Reflected first-hit flux over the scene's surface area (W/m²).
    pub irradiance: f32,
}

impl EmissionReach {
    /// Traces 4096 light paths' first segments from `emitters`, those of `scene`.
    pub fn measure(scene: &Scene, bvh: &SceneBvh, emitters: &Emitters) -> Self {
        let area: f32 = (0..scene.triangle_count())
            .map(|t| {
                let p = scene.triangle_positions(t as u32);
                0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length()
            })
            .filter(|a| a.is_finite())
            .sum();
        const PATHS: u64 = 4096;
        let halton = Halton::new(0x11C);
        let (mut reflected, mut open) = (0.0f32, 0u64);
        let enclosure = super::enclosure::Enclosure::new(scene, bvh);
        for k in 0..PATHS {
            let s = |d: usize| halton.sample(k, d);
            let Some(e) = emitters.sample(scene, Vec4::new(s(0), s(1), s(2), s(3))) else {
                continue;
            };
            // Light trapped in a solid lights nothing outside it.
            if enclosure.emits_into_solid(&e) {
                continue;
            }
            open += 1;
            let dir = cosine_hemisphere(e.normal, Vec2::new(s(4), s(5)));
            if let Some(hit) = bvh.intersect_leaving(e.position, dir, e.triangle) {
                let albedo = bvh.surface(scene, &hit, -dir).albedo;
                // Flux of the path: pi Le / pdf_area, averaged over PATHS.
                let flux = luminance(e.radiance * albedo) * std::f32::consts::PI / e.pdf_area;
                reflected += flux / PATHS as f32;
            }
        }
        let emitted = luminance(emitters.power());
        let power = emitted * open as f32 / PATHS as f32;
        Self {
            emitted,
            power,
            reach: if power > 0.0 { reflected / power } else { 0.0 },
            irradiance: reflected / area.max(1e-12),
        }
    }

    /// Whether the emitters light the scene (the default light is not added).
    pub fn lights_the_scene(&self) -> bool {
        self.reach >= MIN_EMISSION_REACH && self.irradiance >= MIN_EMISSION_IRRADIANCE
    }
}

impl Scene {
    /// Adds the documented default light if nothing lights the scene: no
    /// punctual light, and no emitters, or emitters that cannot light it
    /// (under 5% of their light reflected by the first surface it meets, or
    /// under 1e-3 W/m² over the scene; they keep glowing). A white
    /// point light near the camera, raised and moved towards the scene when
    /// there is room (never hidden from the camera nor inside a closed
    /// object), with an intensity giving 1 W/m² irradiance at the centre of
    /// the scene's bounds. Logged, with the reason.
    pub fn ensure_light(&mut self) {
        if !self.lights.is_empty() || self.triangle_count() == 0 {
            return;
        }
        let bvh = SceneBvh::new(self);
        // Emissive triangles light the scene, not emissive materials: a
        // file may define an emissive material no triangle uses.
        let emitters = Emitters::new(self);
        let reason = if emitters.is_empty() {
            "has no lights".to_string()
        } else {
            let e = EmissionReach::measure(self, &bvh, &emitters);
            if e.lights_the_scene() {
                log::info!(
                    "scene '{}' is lit by its emitters: {:.3} W emitted, {:.3} W of it outside solids, {:.1}% of that reflected by the first surface it meets, {:.2e} W/m² over the scene",
                    self.name,
                    e.emitted,
                    e.power,
                    e.reach * 100.0,
                    e.irradiance
                );
                return;
            }
            format!(
                "has emitters that cannot light it ({:.3} W outside solids, {:.1}% of it reflected by the first surface it meets (at least {:.0}% needed), {:.2e} W/m² over the scene (at least {MIN_EMISSION_IRRADIANCE:.0e} needed)); they keep glowing",
                e.power,
                e.reach * 100.0,
                MIN_EMISSION_REACH * 100.0,
                e.irradiance
            )
        };
        let Ok(camera) = self.camera(None) else {
            return;
        };
        let b = self.bounds();
        let center = b.center();
        let d = (center - camera.position)
            .length()
            .max(b.radius() * 0.1)
            .max(1e-3);
        let candidates =
            [(0.3, 0.2), (0.15, 0.1), (0.05, 0.05), (0.0, 0.0)].map(|(up, forward)| {
                camera.position + camera.up * (up * d) + camera.forward * (forward * d)
            });
        let position = candidates
            .into_iter()
            .find(|&p| !bvh.occluded(camera.position, p) && bvh.enclosed_fraction(self, p) < 0.6)
            .unwrap_or(camera.position);
        let d2 = (position - center).length_squared().max(1e-6);
        log::info!(
            "scene '{}' {reason}: adding a default point light at {position} (near the camera) of {d2:.3} W/sr, 1 W/m² at the centre of its bounds",
            self.name
        );
        self.lights.push(Light {
            kind: LightKind::Point,
            position,
            direction: -Vec3::Y,
            intensity: Vec3::splat(d2),
        });
    }
}
