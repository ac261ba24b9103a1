//! Materials evaluated on the CPU, the twins of `shaders/include/material.glsl`:
//! texture sampling with the glTF sampler's wrap and filter, base colour and
//! alpha mask, emission, the BRDF's parameters, and normal maps.

use glam::{Vec2, Vec3, Vec4};

use super::brdf::Brdf;
use crate::scene::{AlphaMode, Material, Reflectance, Scene, Texture, TextureSampler, Vertex, Wrap};

/// sRGB-encoded 8-bit value to linear.
pub fn srgb_to_linear(c: u8) -> f32 {
    let s = c as f32 / 255.0;
    if s <= 0.04045 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Texel coordinate `i` along an axis of `n` texels, wrapped.
fn wrap(i: i64, n: i64, mode: Wrap) -> i64 {
    match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let period = i.rem_euclid(2 * n);
            if period < n {
                period
            } else {
                2 * n - 1 - period
            }
        }
    }
}

/// Samples `tex` at `uv` (texel centres at (i + 0.5) / size, as Vulkan):
/// RGBA, colour decoded from sRGB if `srgb`, alpha always linear.
pub fn sample(tex: &Texture, sampler: TextureSampler, uv: Vec2, srgb: bool) -> Vec4 {
    sample_rgba8(tex.width, tex.height, &tex.rgba8, sampler, uv, srgb)
}

/// [`sample`] on raw RGBA8 texels, `width` x `height`.
pub fn sample_rgba8(
    width: u32,
    height: u32,
    rgba8: &[u8],
    sampler: TextureSampler,
    uv: Vec2,
    srgb: bool,
) -> Vec4 {
    let (w, h) = (width.max(1) as i64, height.max(1) as i64);
    let texel = |xi: i64, yi: i64| {
        let (xi, yi) = (wrap(xi, w, sampler.wrap_s), wrap(yi, h, sampler.wrap_t));
        let i = ((yi * w + xi) * 4) as usize;
        let c = |k: usize| {
            if srgb {
                srgb_to_linear(rgba8[i + k])
            } else {
                rgba8[i + k] as f32 / 255.0
            }
        };
        Vec4::new(c(0), c(1), c(2), rgba8[i + 3] as f32 / 255.0)
    };
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    if !x.is_finite() || !y.is_finite() {
        return texel(0, 0);
    }
    if sampler.nearest {
        return texel((x + 0.5).floor() as i64, (y + 0.5).floor() as i64);
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let (x0, y0) = (x0 as i64, y0 as i64);
    let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
    let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
    top.lerp(bottom, fy)
}

/// The texture coordinate and vertex colour at barycentrics `b` of the
/// triangle with corners `v`.
pub fn interpolated_uv_color(v: [&Vertex; 3], b: [f32; 3]) -> (Vec2, Vec4) {
    let uv = Vec2::from(v[0].uv) * b[0] + Vec2::from(v[1].uv) * b[1] + Vec2::from(v[2].uv) * b[2];
    let color = v[0].color() * b[0] + v[1].color() * b[1] + v[2].color() * b[2];
    (uv, color)
}

/// Linear albedo (rgb) and alpha of `m` at `uv`, where the interpolated
/// vertex colour (glTF's COLOR_0; white without) is `vertex_color`.
pub fn base_color(scene: &Scene, m: &Material, uv: Vec2, vertex_color: Vec4) -> Vec4 {
    let factor = m.base_color * vertex_color;
    match m.texture {
        Some(t) => factor * sample(&scene.textures[t], m.sampler, uv, true),
        None => factor,
    }
}

/// The BRDF of `m` at `uv` (vertex colour `vertex_color`): base colour
/// (texture and vertex colour included), and for glTF's metallic-roughness
/// model metallic and roughness, each factor times its channel (B, G) of
/// the linear metallic-roughness texture.
pub fn brdf(scene: &Scene, m: &Material, uv: Vec2, vertex_color: Vec4) -> Brdf {
    let base = base_color(scene, m, uv, vertex_color).truncate();
    match m.reflectance {
        Reflectance::Lambertian => Brdf::lambertian(base),
        Reflectance::MetallicRoughness {
            metallic,
            roughness,
            texture,
        } => {
            let (mut metallic, mut roughness) = (metallic, roughness);
            if let Some(t) = texture {
                let texel = sample(&scene.textures[t.index], t.sampler, t.uv.transform_point2(uv), false);
                metallic *= texel.z;
                roughness *= texel.y;
            }
            Brdf {
                base,
                metallic,
                roughness,
                specular: 1.0,
            }
        }
    }
}

/// Whether the surface of `m` exists at `uv` (its alpha mask; vertex
/// colour `vertex_color`).
pub fn opaque(scene: &Scene, m: &Material, uv: Vec2, vertex_color: Vec4) -> bool {
    match m.alpha {
        AlphaMode::Opaque => true,
        AlphaMode::Mask(cutoff) => base_color(scene, m, uv, vertex_color).w >= cutoff,
    }
}

/// Emitted radiance (W/(m² sr)) of `m` at `uv`.
pub fn emission(scene: &Scene, m: &Material, uv: Vec2) -> Vec3 {
    match m.emissive_texture {
        Some(t) => {
            let texel = sample(&scene.textures[t.index], t.sampler, t.uv.transform_point2(uv), true);
            m.emission * texel.truncate()
        }
        None => m.emission,
    }
}

/// The shading normal: the interpolated normal `n`, perturbed by the
/// normal map of `m` in the frame of `tangent` (xyz, w handedness).
pub fn shading_normal(scene: &Scene, m: &Material, uv: Vec2, n: Vec3, tangent: Vec4) -> Vec3 {
    let Some(t) = m.normal_texture else {
        return n;
    };
    let tangent_xyz = tangent.truncate();
    if tangent_xyz.length_squared() < 1e-12 {
        return n;
    }
    let tex = sample(&scene.textures[t.index], t.sampler, t.uv.transform_point2(uv), false);
    let local = Vec3::new(
        (tex.x * 2.0 - 1.0) * m.normal_scale,
        (tex.y * 2.0 - 1.0) * m.normal_scale,
        tex.z * 2.0 - 1.0,
    );
    let t_axis = (tangent_xyz - n * n.dot(tangent_xyz)).normalize_or_zero();
    let b_axis = n.cross(t_axis) * if tangent.w < 0.0 { -1.0 } else { 1.0 };
    (t_axis * local.x + b_axis * local.y + n * local.z)
        .try_normalize()
        .unwrap_or(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strip() -> Texture {
        // 4 x 1: red, green, blue, white (alpha 0, 85, 170, 255).
        Texture {
            width: 4,
            height: 1,
            rgba8: vec![
                255, 0, 0, 0, 0, 255, 0, 85, 0, 0, 255, 170, 255, 255, 255, 255,
            ],
        }
    }

    #[test]
    fn wrap_modes_and_nearest_filtering() {
        let t = strip();
        let nearest = |wrap_s| TextureSampler {
            wrap_s,
            wrap_t: Wrap::Repeat,
            nearest: true,
        };
        // u = 1.125 is texel 4.5 - 0.5 = 4: repeat -> texel 0, clamp -> 3, mirror -> 3.
        let at = |s| sample(&t, s, Vec2::new(1.125, 0.5), false);
        assert_eq!(at(nearest(Wrap::Repeat)), Vec4::new(1.0, 0.0, 0.0, 0.0));
        assert_eq!(at(nearest(Wrap::ClampToEdge)), Vec4::ONE);
        assert_eq!(at(nearest(Wrap::MirroredRepeat)), Vec4::ONE);
        // u = 1.375 is texel 5: repeat -> 1, clamp -> 3, mirror -> 2.
        let at = |s| sample(&t, s, Vec2::new(1.375, 0.5), false);
        assert_eq!(at(nearest(Wrap::Repeat)).y, 1.0);
        assert_eq!(at(nearest(Wrap::ClampToEdge)), Vec4::ONE);
        assert_eq!(at(nearest(Wrap::MirroredRepeat)).z, 1.0);
        // Bilinear halfway between texels 0 and 1.
        let mid = sample(&t, TextureSampler::default(), Vec2::new(0.25, 0.5), false);
        assert!((mid - Vec4::new(0.5, 0.5, 0.0, 85.0 / 510.0)).length() < 1e-6);
    }
}
