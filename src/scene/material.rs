//! Materials: glTF metallic-roughness with emission, alpha modes and
//! textures (sampled with their wrap modes, UV sets and transforms).

use super::*;

/// How texture coordinates outside [0, 1] wrap (glTF sampler wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// Repeat.
    #[default]
    Repeat,
    /// Clamp to the edge texel.
    ClampToEdge,
    /// Repeat, mirrored every other time.
    MirroredRepeat,
}

/// How a texture is sampled: wrap per axis, and nearest or bilinear
/// magnification (glTF's `magFilter`). Minified, the G-buffer averages a
/// texture over each pixel's footprint from mipmaps, whatever `minFilter`
/// says (docs/conventions.md).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TextureSampler {
    /// Wrap along u.
    pub wrap_s: Wrap,
    /// Wrap along v.
    pub wrap_t: Wrap,
    /// Nearest-texel filtering instead of bilinear.
    pub nearest: bool,
}

/// A texture as a material uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    /// Index into [`Scene::textures`].
    pub index: usize,
    /// How it is sampled.
    pub sampler: TextureSampler,
    /// Where it is read: this affine map of the mesh's texture coordinates
    /// (identity, unless a glTF material's textures have different
    /// `KHR_texture_transform`s: a normal map tiled finer than the base
    /// colour, say). A normal map's generated tangents follow it.
    pub uv: Affine2,
}

impl TextureRef {
    /// Texture `index` read with `sampler` at the mesh's texture coordinates.
    pub fn new(index: usize, sampler: TextureSampler) -> Self {
        Self {
            index,
            sampler,
            uv: Affine2::IDENTITY,
        }
    }
}

/// Which parts of a surface exist (glTF alpha modes).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Everywhere.
    #[default]
    Opaque,
    /// Where base-colour alpha (factor x texture) is at least the cutoff;
    /// glTF's BLEND is read as a mask at 0.5.
    Mask(f32),
}

/// How a material reflects light.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Reflectance {
    /// Lambertian: `f = base / pi` (glTF with `KHR_materials_specular`'s
    /// `specular` 0). Built-in scenes and [`Material::diffuse`] use it.
    #[default]
    Lambertian,
    /// glTF 2.0's metallic-roughness model (its specification's appendix B:
    /// Lambert diffuse under a GGX specular layer for dielectrics, GGX with
    /// the base colour as Fresnel F0 for metals), see `docs/conventions.md`.
    MetallicRoughness {
        /// `metallicFactor` in [0, 1].
        metallic: f32,
        /// `roughnessFactor` in [0, 1] (perceptual; GGX alpha = roughness²).
        roughness: f32,
        /// `metallicRoughnessTexture` (linear; B scales metallic, G roughness).
        texture: Option<TextureRef>,
    },
}

/// A material: its reflectance, emission, normal map and alpha.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Linear base colour (albedo) factor; alpha scales the texture's alpha
    /// for [`AlphaMode::Mask`].
    pub base_color: Vec4,
    /// Index into [`Scene::textures`] of an sRGB base-colour texture.
    pub texture: Option<usize>,
    /// How `texture` is sampled.
    pub sampler: TextureSampler,
    /// Emitted radiance (W/(m² sr)): glTF `emissiveFactor` x
    /// `KHR_materials_emissive_strength`, multiplied by the emissive texture.
    pub emission: Vec3,
    /// sRGB emissive texture.
    pub emissive_texture: Option<TextureRef>,
    /// Tangent-space normal map (linear).
    pub normal_texture: Option<TextureRef>,
    /// Scale of the normal map's x and y.
    pub normal_scale: f32,
    /// Which parts of the surface exist.
    pub alpha: AlphaMode,
    /// Seen (and emitting) from both sides. One-sided surfaces are culled for
    /// the camera when seen from behind and emit only from the front; light
    /// transport treats every surface as a two-sided occluder.
    pub double_sided: bool,
    /// How it reflects (the base colour above is its albedo or F0).
    pub reflectance: Reflectance,
}

impl Material {
    /// A two-sided, opaque, non-emissive material.
    pub fn diffuse(base_color: Vec3, texture: Option<usize>) -> Self {
        Self {
            base_color: base_color.extend(1.0),
            texture,
            sampler: TextureSampler::default(),
            emission: Vec3::ZERO,
            emissive_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            alpha: AlphaMode::Opaque,
            double_sided: true,
            reflectance: Reflectance::Lambertian,
        }
    }

    /// A two-sided, opaque glTF metallic-roughness material.
    pub fn metallic_roughness(base_color: Vec3, metallic: f32, roughness: f32) -> Self {
        Self {
            reflectance: Reflectance::MetallicRoughness {
                metallic,
                roughness,
                texture: None,
            },
            ..Self::diffuse(base_color, None)
        }
    }

    /// The metallic-roughness texture, if it has one.
    pub fn reflectance_texture(&self) -> Option<TextureRef> {
        match self.reflectance {
            Reflectance::MetallicRoughness { texture, .. } => texture,
            Reflectance::Lambertian => None,
        }
    }

    /// Whether the material emits light.
    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }
}

/// An 8-bit sRGB RGBA texture.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texels, row by row, 4 bytes each (sRGB-encoded colour, linear alpha).
    pub rgba8: Vec<u8>,
}
