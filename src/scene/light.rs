//! Punctual lights in radiometric units.

use super::*;

/// The kind of a punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Radiates `intensity` W/sr in every direction.
    Point,
    /// A point light restricted to a cone, with the glTF smooth falloff
    /// between `inner_cone` and `outer_cone` (half-angles in radians).
    Spot {
        /// Half-angle of full intensity.
        inner_cone: f32,
        /// Half-angle beyond which there is no light.
        outer_cone: f32,
    },
    /// Parallel light of irradiance `intensity` W/m² on a perpendicular surface.
    Directional,
}

/// A punctual light. Units are radiometric: `intensity` is W/sr for point and
/// spot lights and W/m² for directional lights, per RGB channel.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// The kind.
    pub kind: LightKind,
    /// World-space position (ignored for directional lights).
    pub position: Vec3,
    /// Unit direction the light travels (spot axis; directional light direction).
    pub direction: Vec3,
    /// Radiant intensity (W/sr) or irradiance (W/m²) per channel.
    pub intensity: Vec3,
}

impl Light {
    /// Spot falloff factor for a unit direction `dir` from the light, as in
    /// glTF's KHR_lights_punctual: smooth-step of the cosine between the cones.
    pub fn spot_factor(&self, dir: Vec3) -> f32 {
        match self.kind {
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => {
                let cos_outer = outer_cone.cos();
                let cos_inner = inner_cone.cos();
                let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
                let t = ((dir.dot(self.direction) - cos_outer) * scale).clamp(0.0, 1.0);
                t * t
            }
            _ => 1.0,
        }
    }
}
