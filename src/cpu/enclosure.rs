//! Which emitted light can never leave the solid it is emitted into.
//!
//! A closed mesh whose normals point out (a thin emissive box modelled as a
//! fixture, a wall modelled as a slab) is a solid: light emitted into it
//! (the inner sides of a double-sided fixture, the top of a fixture pressed
//! against a slab) stays there. Light tracing leaves such emission out: its
//! paths count in the normalisation and deposit nothing, instead of
//! bouncing inside a fixture thinner than any shadow map resolves.
//!
//! A point is inside a solid when, along every one of 14 rays, one connected
//! surface (triangles joined by shared vertex positions) is left more often
//! than entered: its winding number there is at least 1 (crossing a surface
//! from its back is leaving it; front and back are per triangle,
//! [`Scene::front_normal`]). Each surface is counted on its own, so solids
//! that overlap (slabs overlapping at the corners) or touch (a fixture
//! against a ceiling) need no special case, and an open surface (a quad, a
//! box with a hole, a room of one-sided walls) is never "left" along every
//! ray. A surface that holds the camera is a room, not a solid (a room
//! modelled as a closed box whose normals point out). When in doubt (the
//! rays disagree, one slips along an edge) the point is not inside a solid
//! and its light is kept.

use glam::Vec3;

use super::bvh::{SceneBvh, ENCLOSURE_DIRECTIONS};
use super::emitters::EmitterSample;
use crate::scene::Scene;

/// How far off an emitter the point whose enclosure decides its light lies:
/// 1e-5 of the coordinates (30 µm at 2 m), plus of the scene's size up to
/// a metre (`floor`: [`length_floor`](super::bvh::length_floor)), far
/// below any modelled thickness, far above float rounding, so that a
/// surface the emitter touches is behind it.
pub fn emission_offset(p: Vec3, floor: f32) -> f32 {
    1e-5 * (floor + p.abs().max_element())
}

/// The enclosure test for one scene and camera.
pub struct Enclosure<'a> {
    scene: &'a Scene,
    bvh: &'a SceneBvh,
    /// Connected surfaces that hold the camera (rooms, not solids).
    rooms: Vec<u32>,
}

impl<'a> Enclosure<'a> {
    /// The test for `scene` seen from its camera (its first, or the one
    /// framing it).
    pub fn new(scene: &'a Scene, bvh: &'a SceneBvh) -> Self {
        let mut e = Self {
            scene,
            bvh,
            rooms: Vec::new(),
        };
        if let Ok(camera) = scene.camera(None) {
            e.rooms = e.surfaces_around(camera.position);
        }
        e
    }

    /// Whether `p` is inside a solid (not a room).
    pub fn inside_solid(&self, p: Vec3) -> bool {
        self.surfaces_around(p)
            .iter()
            .any(|s| !self.rooms.contains(s))
    }

    /// Whether the light of the emitter sample `e` goes into a solid, the
    /// point [`emission_offset`] off it on its emitting side being inside one.
    pub fn emits_into_solid(&self, e: &EmitterSample) -> bool {
        self.inside_solid(e.position + e.normal * emission_offset(e.position, self.bvh.length_floor()))
    }

    /// The connected surfaces whose winding number at `p` is at least 1
    /// along every ray of [`ENCLOSURE_DIRECTIONS`].
    fn surfaces_around(&self, p: Vec3) -> Vec<u32> {
        let surface_of = self.bvh.connected_surfaces();
        let mut around: Option<Vec<u32>> = None;
        let mut crossings = Vec::new();
        for &dir in ENCLOSURE_DIRECTIONS.iter() {
            crossings.clear();
            // Coplanar faces of overlapping solids (slabs overlapping at
            // the corners) are crossed one after the other, each counted.
            self.bvh.crossings(p, dir, self.bvh.lift(p), |t, _| {
                let left = SceneBvh::meets_back(self.scene, t, dir);
                crossings.push((surface_of[t as usize], left));
            });
            let mut winding: Vec<(u32, i32)> = Vec::new();
            for &(surface, left) in &crossings {
                let w = match winding.iter_mut().find(|(s, _)| *s == surface) {
                    Some((_, w)) => w,
                    None => {
                        winding.push((surface, 0));
                        &mut winding.last_mut().unwrap().1
                    }
                };
                *w += if left { 1 } else { -1 };
            }
            let inside = winding.iter().filter(|(_, w)| *w >= 1).map(|(s, _)| *s);
            let kept: Vec<u32> = match &around {
                None => inside.collect(),
                Some(before) => inside.filter(|s| before.contains(s)).collect(),
            };
            if kept.is_empty() {
                return kept;
            }
            around = Some(kept);
        }
        around.unwrap_or_default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::emitters::Emitters;
    use crate::scene::builtin::axis_box;

    /// A closed box whose faces point out, emissive and double-sided.
    fn thin_emissive_box(scene: &mut Scene, lo: Vec3, hi: Vec3) {
        let m = scene.add_material(Vec3::ONE, None);
        scene.materials[m as usize].emission = Vec3::ONE;
        axis_box(scene, lo, hi, m).unwrap();
    }

    /// Share of 256 emitter samples whose light goes into a solid, and
    /// whether it is exactly those that `expected` names.
    fn enclosed_share(scene: &Scene, expected: impl Fn(&EmitterSample) -> bool) -> f32 {
        let bvh = SceneBvh::new(scene);
        let emitters = Emitters::new(scene);
        let enclosure = Enclosure::new(scene, &bvh);
        let h = crate::cpu::sampling::Halton::new(1);
        let n = 256;
        let mut inside = 0;
        for i in 0..n {
            let u = glam::Vec4::from_array([0, 1, 2, 3].map(|d| h.sample(i, d)));
            let e = emitters.sample(scene, u).unwrap();
            assert_eq!(enclosure.emits_into_solid(&e), expected(&e), "{e:?}");
            inside += expected(&e) as u32;
        }
        inside as f32 / n as f32
    }

    #[test]
    fn a_closed_box_emits_only_outwards() {
        let mut scene = Scene::new("lamp");
        let centre = Vec3::new(0.0, 1.98, 0.0);
        thin_emissive_box(
            &mut scene,
            centre - Vec3::new(0.25, 0.01, 0.25),
            centre + Vec3::new(0.25, 0.01, 0.25),
        );
        // Exactly the samples whose side faces the box's inside.
        let share = enclosed_share(&scene, |e| e.normal.dot(e.position - centre) < 0.0);
        assert!((share - 0.5).abs() < 0.07, "{share}");
    }

    #[test]
    fn a_fixture_against_a_slab_also_loses_its_top() {
        // A 1 mm fixture touching the underside of a 10 cm slab that
        // overlaps a wall slab: its inside and its top are enclosed.
        let mut scene = Scene::new("ceiling");
        let wall = scene.add_material(Vec3::splat(0.7), None);
        axis_box(
            &mut scene,
            Vec3::new(-2.0, 2.0, -2.0),
            Vec3::new(2.0, 2.1, 2.0),
            wall,
        )
        .unwrap();
        axis_box(
            &mut scene,
            Vec3::new(-2.1, -0.1, -2.0),
            Vec3::new(-1.9, 2.1, 2.0),
            wall,
        )
        .unwrap();
        thin_emissive_box(
            &mut scene,
            Vec3::new(-0.5, 1.999, -0.5),
            Vec3::new(0.5, 2.0, 0.5),
        );
        let share = enclosed_share(&scene, |e| {
            let inwards = e.normal.dot(e.position - Vec3::new(0.0, 1.9995, 0.0)) < 0.0;
            inwards || e.normal.y > 0.5
        });
        assert!(share > 0.6, "{share}");
        // The camera in the room; in a closed outward box, the box is a room.
        let mut room = Scene::new("outward room");
        let m = room.add_material(Vec3::splat(0.7), None);
        axis_box(&mut room, Vec3::splat(-2.0), Vec3::splat(2.0), m).unwrap();
        thin_emissive_box(
            &mut room,
            Vec3::new(-0.5, 1.9, -0.5),
            Vec3::new(0.5, 1.95, 0.5),
        );
        room.cameras
            .push(crate::scene::Camera::look_at(Vec3::ZERO, -Vec3::Z, 1.0));
        let share = enclosed_share(&room, |e| {
            e.normal.dot(e.position - Vec3::new(0.0, 1.925, 0.0)) < 0.0
        });
        assert!((share - 0.5).abs() < 0.07, "{share}");
    }
}
