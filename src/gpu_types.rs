//! Rust twins of the structs in `shaders/include/common.glsl` (std430).

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

use crate::scene::{AlphaMode, Light, LightKind, Material, Reflectance, TextureSampler, Wrap};

/// `GpuLight` in common.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuLight {
    /// xyz position, w kind (0 point, 1 spot, 2 directional).
    pub position_kind: [f32; 4],
    /// xyz unit direction the light travels, w cos(outer cone).
    pub direction_cos_outer: [f32; 4],
    /// rgb intensity, w cos(inner cone).
    pub intensity_cos_inner: [f32; 4],
    /// x first shadow-map layer, y layer count.
    pub shadow: [i32; 4],
}

impl GpuLight {
    /// Packs a scene light whose shadow maps start at `first_layer`.
    pub fn new(light: &Light, first_layer: u32, layers: u32) -> Self {
        let (kind, cos_inner, cos_outer) = match light.kind {
            LightKind::Point => (0.0, -1.0, -1.0),
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => (1.0, inner_cone.cos(), outer_cone.cos()),
            LightKind::Directional => (2.0, 1.0, 1.0),
        };
        Self {
            position_kind: light.position.extend(kind).into(),
            direction_cos_outer: light.direction.extend(cos_outer).into(),
            intensity_cos_inner: light.intensity.extend(cos_inner).into(),
            shadow: [first_layer as i32, layers as i32, 0, 0],
        }
    }
}

/// `ShadowView` in common.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ShadowView {
    /// World to clip.
    pub view_proj: [[f32; 4]; 4],
    /// x near, y far, z 1 = orthographic, w texel size (per unit distance when perspective).
    pub params: [f32; 4],
}

impl ShadowView {
    /// Packs a projection and its depth parameters.
    pub fn new(view_proj: Mat4, params: Vec4) -> Self {
        Self {
            view_proj: view_proj.to_cols_array_2d(),
            params: params.into(),
        }
    }
}

/// `GpuMaterial` in common.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuMaterial {
    /// Linear albedo factor (rgb), alpha factor (a).
    pub base_color: [f32; 4],
    /// Emitted radiance (rgb), alpha cutoff (w; < 0: opaque).
    pub emission_cutoff: [f32; 4],
    /// Layers of the base-colour and emissive textures (colour array) and of
    /// the normal map (linear array), -1 for none; w bit 0: double-sided,
    /// bits 1..: the metallic-roughness map's layer + 1 (0: none).
    pub textures: [i32; 4],
    /// Sampler of each texture (see [`sampler_bits`]).
    pub samplers: [i32; 4],
    /// x: normal-map scale; y metallic, z roughness, w the specular layer
    /// (1: glTF metallic-roughness, 0: Lambertian).
    pub normal: [f32; 4],
    /// Where the emissive texture, the normal map and the metallic-roughness
    /// map are read ([`crate::scene::TextureRef::uv`]): each one's linear
    /// part, columns (xy, zw).
    pub uv_linear: [[f32; 4]; 3],
    /// Their offsets: emissive xy, normal map zw; metallic-roughness xy of
    /// the second (zw unused).
    pub uv_offsets: [[f32; 4]; 2],
}

/// A sampler as material.glsl reads it: bits 0-1 wrap s, 2-3 wrap t
/// (0 repeat, 1 clamp, 2 mirror), bit 4 nearest.
pub fn sampler_bits(s: TextureSampler) -> i32 {
    let wrap = |w: Wrap| match w {
        Wrap::Repeat => 0,
        Wrap::ClampToEdge => 1,
        Wrap::MirroredRepeat => 2,
    };
    wrap(s.wrap_s) | (wrap(s.wrap_t) << 2) | ((s.nearest as i32) << 4)
}

impl GpuMaterial {
    /// Packs a scene material; `color_layer[t]` and `linear_layer[t]` are the
    /// layers of scene texture t in the two arrays (-1 if it is not there).
    pub fn new(m: &Material, color_layer: &[i32], linear_layer: &[i32]) -> Self {
        let layer =
            |map: &[i32], t: Option<usize>| t.and_then(|t| map.get(t).copied()).unwrap_or(-1);
        let cutoff = match m.alpha {
            AlphaMode::Opaque => -1.0,
            AlphaMode::Mask(c) => c,
        };
        let (metallic, roughness, specular) = match m.reflectance {
            Reflectance::Lambertian => (0.0, 1.0, 0.0),
            Reflectance::MetallicRoughness {
                metallic,
                roughness,
                ..
            } => (metallic, roughness, 1.0),
        };
        let reflectance_texture = m.reflectance_texture();
        Self {
            base_color: m.base_color.into(),
            emission_cutoff: m.emission.extend(cutoff).into(),
            textures: [
                layer(color_layer, m.texture),
                layer(color_layer, m.emissive_texture.map(|t| t.index)),
                layer(linear_layer, m.normal_texture.map(|t| t.index)),
                m.double_sided as i32
                    | (layer(linear_layer, reflectance_texture.map(|t| t.index)) + 1) << 1,
            ],
            samplers: [
                sampler_bits(m.sampler),
                m.emissive_texture
                    .map(|t| sampler_bits(t.sampler))
                    .unwrap_or(0),
                m.normal_texture
                    .map(|t| sampler_bits(t.sampler))
                    .unwrap_or(0),
                reflectance_texture
                    .map(|t| sampler_bits(t.sampler))
                    .unwrap_or(0),
            ],
            normal: [m.normal_scale, metallic, roughness, specular],
            uv_linear: [m.emissive_texture, m.normal_texture, reflectance_texture].map(|t| {
                t.map_or(glam::Mat2::IDENTITY, |t| t.uv.matrix2)
                    .to_cols_array()
            }),
            uv_offsets: {
                let offset = |t: Option<crate::scene::TextureRef>| {
                    t.map_or(glam::Vec2::ZERO, |t| t.uv.translation)
                };
                let (e, n, r) = (
                    offset(m.emissive_texture),
                    offset(m.normal_texture),
                    offset(reflectance_texture),
                );
                [[e.x, e.y, n.x, n.y], [r.x, r.y, 0.0, 0.0]]
            },
        }
    }
}

#[cfg(test)]
mod tests {
    /// The GLSL struct definitions and the Rust ones have the same fields in
    /// the same order with the same sizes (all vec4/ivec4/mat4 so std430 has
    /// no padding surprises).
    #[test]
    fn gpu_types_match_glsl() {
        let glsl = include_str!("../shaders/include/common.glsl");
        let fields = |name: &str| -> Vec<(String, usize)> {
            let start = glsl
                .find(&format!("struct {name} {{"))
                .expect("struct in common.glsl");
            let body = &glsl[start..start + glsl[start..].find("};").unwrap()];
            body.lines()
                .skip(1)
                .filter_map(|l| {
                    let l = l.split("//").next().unwrap().trim();
                    let (ty, rest) = l.split_once(' ')?;
                    let size = match ty {
                        "vec4" | "ivec4" | "uvec4" => 16,
                        "mat4" => 64,
                        other => panic!("unexpected GLSL type {other}"),
                    };
                    let name = rest.trim_end_matches(';');
                    // An array of n: n x the element (std430 pads none of these).
                    let count = name
                        .split_once('[')
                        .map_or(1, |(_, n)| n.trim_end_matches(']').parse().expect("array length"));
                    Some((name.to_string(), size * count))
                })
                .collect()
        };
        let check = |name: &str, rust: &[&str], size: usize| {
            let f = fields(name);
            let names: Vec<&str> = f.iter().map(|(n, _)| n.as_str()).collect();
            assert_eq!(names, rust, "{name} field order");
            assert_eq!(f.iter().map(|(_, s)| s).sum::<usize>(), size, "{name} size");
        };
        check(
            "GpuLight",
            &[
                "position_kind",
                "direction_cos_outer",
                "intensity_cos_inner",
                "shadow",
            ],
            std::mem::size_of::<super::GpuLight>(),
        );
        check(
            "ShadowView",
            &["view_proj", "params"],
            std::mem::size_of::<super::ShadowView>(),
        );
        check(
            "GpuObject",
            &["model", "normal_matrix", "params"],
            std::mem::size_of::<super::GpuObject>(),
        );
        check(
            "GpuMaterial",
            &[
                "base_color",
                "emission_cutoff",
                "textures",
                "samplers",
                "normal",
                "uv_linear[3]",
                "uv_offsets[2]",
            ],
            std::mem::size_of::<super::GpuMaterial>(),
        );
    }
}

/// `GpuObject` in common.glsl: how an object's vertices (and ISM points)
/// reach world space.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuObject {
    /// Object to world.
    pub model: [f32; 16],
    /// The inverse transpose of the linear part (normals), as a 4x4.
    pub normal_matrix: [f32; 16],
    /// x: the material override (`u32::MAX`: the mesh's own); y: visible
    /// (1) or hidden (0); z: the bits of the handedness (-1 for a mirror,
    /// else 1); w: its mesh.
    pub params: [u32; 4],
}

impl GpuObject {
    /// Packs a scene object.
    pub fn new(o: &crate::scene::Object) -> Self {
        let p = crate::scene::Placement::new(o);
        Self {
            model: p.transform.to_cols_array(),
            normal_matrix: glam::Mat4::from_mat3(p.normal_matrix).to_cols_array(),
            params: [
                o.material.unwrap_or(u32::MAX),
                o.visible as u32,
                p.handedness.to_bits(),
                o.mesh as u32,
            ],
        }
    }
}

/// `GpuVpl` in ism.glsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GpuVpl {
    /// xyz position; w: the bits of the index of the block of ISM points it
    /// splats (`u32`).
    pub position: [f32; 4],
    /// xyz unit normal; w: the bits of its ISM tile's column | row << 16.
    pub normal: [f32; 4],
    /// rgb: base colour x flux (W) for a Lambertian VPL (it sends
    /// `power / pi` per unit G), the flux for a glossy one; w: -1 for a
    /// Lambertian VPL, else its metallic.
    pub power: [f32; 4],
    /// A glossy VPL's base colour (rgb) and roughness (w).
    pub base: [f32; 4],
    /// A glossy VPL's incident direction (xyz); w: every VPL's radius (m),
    /// which widens glossy lobes towards and from it. (A glossy VPL's
    /// specular layer is glTF's, 1.)
    pub incident: [f32; 4],
}

impl GpuVpl {
    /// Packs the CPU VPL at `index` of `count` that splats ISM point block
    /// `point_block`.
    pub fn new(v: &crate::cpu::vpl::Vpl, index: u32, count: u32, point_block: u32) -> Self {
        let per_row = ism_tiles_per_row(count);
        let cell = (index % per_row) | (index / per_row) << 16;
        debug_assert!(v.brdf.is_lambertian() || v.brdf.specular == 1.0);
        Self {
            position: v.position.extend(f32::from_bits(point_block)).into(),
            normal: v.normal.extend(f32::from_bits(cell)).into(),
            // w: -2 for a Lambertian VPL with a shading normal (in
            // incident.xyz), -1 for one without.
            power: if v.brdf.is_lambertian() {
                let shaded = v.shading_normal != glam::Vec3::ZERO;
                (v.brdf.base * v.flux).extend(if shaded { -2.0 } else { -1.0 })
            } else {
                v.flux.extend(v.brdf.metallic)
            }
            .into(),
            base: v.brdf.base.extend(v.brdf.roughness).into(),
            incident: if v.brdf.is_lambertian() && v.shading_normal != glam::Vec3::ZERO {
                v.shading_normal
            } else {
                v.incident
            }
            .extend(v.radius)
            .into(),
        }
    }
}

/// Tiles per row of the ISM atlas of `count` VPLs (a square-ish grid; VPL i
/// has tile i in row-major order).
pub fn ism_tiles_per_row(count: u32) -> u32 {
    (count.max(1) as f64).sqrt().ceil() as u32
}

#[cfg(test)]
#[test]
fn gpu_vpl_matches_glsl() {
    let glsl = include_str!("../shaders/include/ism.glsl");
    let start = glsl.find("struct GpuVpl {").unwrap();
    let body = &glsl[start..start + glsl[start..].find("};").unwrap()];
    let names: Vec<&str> = body
        .lines()
        .skip(1)
        .filter_map(|l| l.split("//").next().unwrap().trim().strip_prefix("vec4 "))
        .map(|n| n.trim_end_matches(';'))
        .collect();
    assert_eq!(names, ["position", "normal", "power", "base", "incident"]);
    assert_eq!(std::mem::size_of::<GpuVpl>(), 80);
}
