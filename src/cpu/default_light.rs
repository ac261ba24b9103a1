//! The default light of a scene that has none: placing it needs ray casts
//! (never hidden from the camera, never inside a closed object), so it
//! lives with the BVH rather than in [`crate::scene`], which knows nothing
//! of ray casting.

use glam::Vec3;

use super::bvh::SceneBvh;
use super::emitters::Emitters;
use crate::scene::{Light, LightKind, Scene};

impl Scene {
    /// Adds the documented default light if the scene has none (punctual or
    /// emissive): a white point light near the camera, raised and moved
    /// towards the scene when there is room (never hidden from the camera
    /// nor inside a closed object), with an intensity giving 1 W/m²
    /// irradiance at the centre of the scene's bounds. Logged.
    pub fn ensure_light(&mut self) {
        // Emissive triangles light the scene, not emissive materials: a
        // file may define an emissive material no triangle uses.
        if !self.lights.is_empty()
            || self.indices.is_empty()
            || Emitters::new(self).power().max_element() > 0.0
        {
            return;
        }
        let Ok(camera) = self.camera(None) else {
            return;
        };
        let b = self.bounds();
        let center = b.center();
        let bvh = SceneBvh::new(self);
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
            "scene '{}' has no lights: adding a default point light at {position} (near the camera) of {d2:.3} W/sr, 1 W/m² at the centre of its bounds",
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
