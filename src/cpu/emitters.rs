//! Emissive triangles as area lights: their power, and points on them
//! sampled in proportion to it (for light paths and next-event estimation).
//!
//! A triangle of emitted radiance Le (W/(m² sr), Lambertian) and area A
//! emits pi Le A watts from each emitting side (the front, or both sides if
//! its material is double-sided). With an emissive texture, Le is averaged
//! over the triangle from a fixed set of points for the power (which only
//! steers the sampling); the radiance at the sampled point is exact.
//!
//! Light tracing leaves out light emitted into a solid (the inside of a
//! thin emissive box, say): it can never leave, and its paths would bounce
//! there until the VPL budget is spent ([`super::enclosure`]).

use glam::{Vec2, Vec3, Vec4};

use super::shading;
use crate::scene::{AlphaMode, Material, Scene, Vertex};

/// A point sampled on an emitter.
#[derive(Clone, Copy, Debug)]
pub struct EmitterSample {
    /// Position.
    pub position: Vec3,
    /// Unit normal of the emitting side.
    pub normal: Vec3,
    /// Emitted radiance there (W/(m² sr)).
    pub radiance: Vec3,
    /// Probability density of this (point, side) per unit area, including
    /// the choice of the triangle and of the side.
    pub pdf_area: f32,
    /// The triangle it lies on (rays that leave it skip it).
    pub triangle: u32,
}

/// Every emitting triangle with its power.
#[derive(Clone, Debug, Default)]
pub struct Emitters {
    /// Triangle index, area, emitting sides (1 or 2).
    triangles: Vec<(u32, f32, u32)>,
    /// Power (W, rgb) per triangle.
    power: Vec<Vec3>,
    /// Cumulative luminance of the power.
    cdf: Vec<f32>,
    /// Scene triangle -> index into `triangles`.
    index: std::collections::HashMap<u32, usize>,
}

/// Luminance weights (Rec. 709).
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl Emitters {
    /// Finds the emissive triangles of `scene`.
    pub fn new(scene: &Scene) -> Self {
        let mut e = Self::default();
        let mut total = 0.0f32;
        let emissive: Vec<bool> = scene.materials.iter().map(|m| m.is_emissive()).collect();
        if !emissive.contains(&true) {
            return e;
        }
        // Object by object: a triangle's material is looked up in its mesh
        // before its corners are moved to world space.
        let triangles = scene.instances().list.iter().flat_map(|instance| {
            let mesh = &scene.meshes()[instance.mesh as usize];
            let emissive = &emissive;
            mesh.indices
                .chunks_exact(3)
                .enumerate()
                .filter_map(move |(local, tri)| {
                    let material = instance
                        .placement
                        .material
                        .unwrap_or(mesh.vertices[tri[0] as usize].material);
                    emissive[material as usize].then(|| {
                        let corners = [0, 1, 2]
                            .map(|k| instance.placement.vertex(&mesh.vertices[tri[k] as usize]));
                        (instance.first_triangle as usize + local, corners)
                    })
                })
        });
        for (t, corners) in triangles {
            let v = |k: usize| &corners[k];
            let material = &scene.materials[v(0).material as usize];
            let p = |k: usize| Vec3::from(v(k).position);
            let area = 0.5 * (p(1) - p(0)).cross(p(2) - p(0)).length();
            if area.is_nan() || area <= 0.0 {
                continue;
            }
            // Mean radiance over the triangle from 16 stratified points
            // (where its texture or its alpha mask makes it vary).
            let varies =
                material.emissive_texture.is_some() || matches!(material.alpha, AlphaMode::Mask(_));
            let mean = if varies {
                let mut sum = Vec3::ZERO;
                for i in 0..16 {
                    let u = Vec2::new((i % 4) as f32 + 0.5, (i / 4) as f32 + 0.5) / 4.0;
                    let (b1, b2) = uniform_triangle(u);
                    sum += emission_at(scene, material, [v(0), v(1), v(2)], [1.0 - b1 - b2, b1, b2]);
                }
                sum / 16.0
            } else {
                material.emission
            };
            let sides = if material.double_sided { 2 } else { 1 };
            let power = mean * std::f32::consts::PI * area * sides as f32;
            let weight = luminance(power).max(0.0);
            if weight <= 0.0 {
                continue;
            }
            total += weight;
            e.index.insert(t as u32, e.triangles.len());
            e.triangles.push((t as u32, area, sides));
            e.power.push(power);
            e.cdf.push(total);
        }
        e
    }

    /// No emitters.
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Total power (W, rgb).
    pub fn power(&self) -> Vec3 {
        self.power.iter().sum()
    }

    /// The density per unit area with which [`Emitters::sample`] draws a
    /// point (and side) of scene triangle `triangle`; 0 if it does not emit.
    pub fn pdf_area(&self, triangle: u32) -> f32 {
        let (Some(&i), Some(&total)) = (self.index.get(&triangle), self.cdf.last()) else {
            return 0.0;
        };
        let p_triangle = (self.cdf[i] - if i > 0 { self.cdf[i - 1] } else { 0.0 }) / total;
        let (_, area, sides) = self.triangles[i];
        p_triangle / (area * sides as f32)
    }

    /// A point on an emitter: triangle by power (`u.x` picks it), uniform
    /// on it (`u.yz`), a side (`u.w`, for double-sided ones).
    pub fn sample(&self, scene: &Scene, u: Vec4) -> Option<EmitterSample> {
        let total = *self.cdf.last()?;
        let target = u.x * total;
        let i = self
            .cdf
            .partition_point(|&c| c <= target)
            .min(self.cdf.len() - 1);
        let p_triangle = (self.cdf[i] - if i > 0 { self.cdf[i - 1] } else { 0.0 }) / total;
        let (t, area, sides) = self.triangles[i];
        // Interpolated in object space, the point then moved to the world.
        let (instance, local) = scene.instances().locate(t);
        let mesh = &scene.meshes()[instance.mesh as usize];
        let v = |k: usize| &mesh.vertices[mesh.indices[local as usize * 3 + k] as usize];
        let (b1, b2) = uniform_triangle(Vec2::new(u.y, u.z));
        let b0 = 1.0 - b1 - b2;
        let p = |k: usize| Vec3::from(v(k).position);
        let position = instance
            .placement
            .transform
            .transform_point3(p(0) * b0 + p(1) * b1 + p(2) * b2);
        let material =
            &scene.materials[instance.placement.material.unwrap_or(v(0).material) as usize];
        let front = scene.front_normal(t as usize);
        let normal = if sides == 2 && u.w >= 0.5 {
            -front
        } else {
            front
        };
        Some(EmitterSample {
            position,
            normal,
            radiance: emission_at(scene, material, [v(0), v(1), v(2)], [b0, b1, b2]),
            pdf_area: p_triangle / (area * sides as f32),
            triangle: t,
        })
    }
}

/// The radiance `material` emits at barycentrics `b` of the triangle with
/// corners `v`: its emission (texture included) where its alpha mask keeps
/// the surface, nothing at a cut-out point (which the G-buffer and the path
/// tracer's rays do not see either).
fn emission_at(scene: &Scene, material: &Material, v: [&Vertex; 3], b: [f32; 3]) -> Vec3 {
    let (uv, color) = shading::interpolated_uv_color(v, b);
    if shading::opaque(scene, material, uv, color) {
        shading::emission(scene, material, uv)
    } else {
        Vec3::ZERO
    }
}

/// Barycentrics (of vertices 1 and 2) of a uniform point on a triangle.
pub fn uniform_triangle(u: Vec2) -> (f32, f32) {
    let su = u.x.sqrt();
    (su * (1.0 - u.y), su * u.y)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::MeshData;

    /// A unit emitter (radiance 1, one-sided) whose vertex alpha falls from
    /// 1 at z = 0 to 0 at z = 1 under a 0.5 mask: its half beyond z = 0.5 is
    /// cut out, so it sends half the power, and no sampled point there
    /// emits.
    #[test]
    fn cut_out_parts_of_a_masked_emitter_send_nothing() {
        let mut scene = Scene::new("masked emitter");
        let material = Material {
            emission: Vec3::ONE,
            alpha: AlphaMode::Mask(0.5),
            double_sided: false,
            ..Material::diffuse(Vec3::ONE, None)
        };
        scene.materials.push(material);
        let positions = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let colors = positions.map(|p| Vec4::new(1.0, 1.0, 1.0, 1.0 - p.z));
        let mesh = scene
            .new_mesh(
                MeshData {
                    positions: &positions,
                    colors: &colors,
                    indices: &[0, 2, 1, 0, 3, 2],
                    ..Default::default()
                },
                0,
            )
            .unwrap();
        scene
            .add_object(crate::scene::Object::new(mesh, glam::Mat4::IDENTITY))
            .unwrap();
        let emitters = Emitters::new(&scene);
        // 16 points a triangle estimate 0.75 and 0.25 of their areas.
        let share = emitters.power().x / std::f32::consts::PI;
        assert!((share - 0.5).abs() < 0.07, "power {share} of the unmasked emitter's");
        for i in 0..1000 {
            let u = Vec4::new(
                (i as f32 + 0.5) / 1000.0,
                ((i * 7) % 1000) as f32 / 1000.0,
                ((i * 13) % 997) as f32 / 997.0,
                0.0,
            );
            let e = emitters.sample(&scene, u).unwrap();
            let kept = e.position.z <= 0.5;
            assert!(
                (e.radiance.x > 0.0) == kept || (e.position.z - 0.5).abs() < 1e-4,
                "a point at z = {} emits {}",
                e.position.z,
                e.radiance
            );
        }
    }
}
