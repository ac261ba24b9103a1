//! Materials and textures: glTF's metallic-roughness material and its
//! extensions, texture references with their UV maps and transforms, and
//! images decoded within the budget.

use super::*;

/// Where a texture is read: a `TEXCOORD_n` set, and the affine map
/// `KHR_texture_transform` applies to it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvMap {
    pub(super) set: u32,
    pub(super) transform: Affine2,
}

/// Where a material's textures are read. Its first texture's map is applied
/// to the mesh's texture coordinates at load (an affine map keeps the
/// G-buffer's uv derivatives right); each other texture is read at its own
/// map of those ([`crate::scene::TextureRef::uv`]), identity where they agree.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct MaterialUvMaps {
    pub(super) mesh: UvMap,
    pub(super) emissive: Affine2,
    pub(super) normal: Affine2,
    pub(super) reflectance: Affine2,
}

/// A material's textures, as its warnings name them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum TextureSlot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Emissive,
}

impl TextureSlot {
    pub(super) fn name(self) -> &'static str {
        match self {
            Self::BaseColor => "baseColorTexture",
            Self::MetallicRoughness => "metallicRoughnessTexture",
            Self::Normal => "normalTexture",
            Self::Emissive => "emissiveTexture",
        }
    }
}

impl Default for UvMap {
    fn default() -> Self {
        Self {
            set: 0,
            transform: Affine2::IDENTITY,
        }
    }
}

/// `KHR_texture_transform`'s offset, rotation and scale as one map,
/// T * R * S. Its rotation turns uv counter-clockwise in uv space, whose v
/// axis points down: the matrix is the usual one for -rotation (the
/// specification's GLSL listing has the sign the other way, KhronosGroup/glTF
/// issue 1563; implementations and the sample model `TextureTransformTest`
/// agree on this one).
pub(super) fn texture_transform(t: &json::extensions::texture::TextureTransform) -> Option<Affine2> {
    let values = [
        t.offset.0[0],
        t.offset.0[1],
        t.rotation.0,
        t.scale.0[0],
        t.scale.0[1],
    ];
    values.iter().all(|v| v.is_finite()).then(|| {
        Affine2::from_scale_angle_translation(
            Vec2::from(t.scale.0),
            -t.rotation.0,
            Vec2::from(t.offset.0),
        )
    })
}

/// Turns TANGENT frames (along +u, the bitangent `cross(n, t) w` along -v)
/// to the uvs a texture transform with linear part `map` made: the
/// direction of the mapped u and the handedness of the mapped v, as tangents
/// generated from the mapped uvs would have (taking the surface's u and v
/// as equally long, all a unit frame says). Without it a rotating transform
/// turned the normal map's slopes with the texture but not with the frame.
pub(super) fn follow_texture_transform(tangents: &mut [Vec4], normals: &[Vec3], map: glam::Mat2) {
    let unmap = map.inverse();
    if map == glam::Mat2::IDENTITY || !unmap.is_finite() {
        return;
    }
    for (t, &n) in tangents.iter_mut().zip(normals) {
        if *t == Vec4::ZERO {
            continue;
        }
        let dp_du = t.truncate();
        let dp_dv = -n.cross(dp_du) * if t.w < 0.0 { -1.0 } else { 1.0 };
        // Columns of the inverse map: (du, dv) per unit of u' and of v'.
        let dp_du_mapped = dp_du * unmap.x_axis.x + dp_dv * unmap.x_axis.y;
        let dp_dv_mapped = dp_du * unmap.y_axis.x + dp_dv * unmap.y_axis.y;
        let tangent = (dp_du_mapped - n * n.dot(dp_du_mapped)).normalize_or_zero();
        *t = tangent.extend(crate::scene::handedness(n, tangent, dp_dv_mapped));
    }
}

/// The media type of a `data:` URI, if any.
pub(super) fn data_uri_media_type(uri: &str) -> Option<String> {
    let rest = uri.strip_prefix("data:")?;
    let media = rest.split([';', ',']).next()?;
    (!media.is_empty()).then(|| media.to_string())
}

/// Names common image formats from their first bytes (for the error).
pub(super) fn sniff_image_format(bytes: &[u8]) -> Option<&'static str> {
    let starts = |magic: &[u8]| bytes.starts_with(magic);
    let at = |offset: usize, magic: &[u8]| bytes.get(offset..offset + magic.len()) == Some(magic);
    Some(if starts(b"\x89PNG") {
        "PNG"
    } else if starts(b"\xff\xd8\xff") {
        "JPEG"
    } else if starts(b"GIF8") {
        "GIF"
    } else if starts(b"RIFF") && at(8, b"WEBP") {
        "WebP"
    } else if starts(b"\xabKTX 2") {
        "KTX2"
    } else if starts(b"\xabKTX 1") {
        "KTX"
    } else if starts(b"DDS ") {
        "DDS"
    } else if starts(b"BM") {
        "BMP"
    } else if starts(b"II*\0") || starts(b"MM\0*") {
        "TIFF"
    } else if at(4, b"ftypavif") || at(4, b"ftypheic") {
        "AVIF/HEIF"
    } else if starts(b"sB") {
        "Basis Universal"
    } else {
        return None;
    })
}

impl Loader<'_> {
    /// Material `index`: base colour, emission (factor x strength, and
    /// texture), normal map, alpha mode and sidedness, each texture with its
    /// sampler. Values glTF forbids are errors.
    pub(super) fn material(
        &mut self,
        index: usize,
        m: &json::Material,
        scene: &mut Scene,
        slots: &mut [Option<usize>],
    ) -> Result<crate::scene::Material> {
        let pbr = &m.pbr_metallic_roughness;
        let base_color = Vec4::from(pbr.base_color_factor.0);
        if !base_color.is_finite() || base_color.min_element() < 0.0 {
            return Err(self.err(format!(
                "material {index}: baseColorFactor {base_color} is negative or not finite"
            )));
        }
        let (texture, sampler) = match &pbr.base_color_texture {
            Some(info) => {
                let t = self.texture_ref(info.index.value(), scene, slots)?;
                (Some(t.index), t.sampler)
            }
            None => (None, crate::scene::TextureSampler::default()),
        };
        let strength = m
            .extensions
            .as_ref()
            .and_then(|e| e.emissive_strength.as_ref())
            .map(|s| s.emissive_strength.0)
            .unwrap_or(1.0);
        if !(strength.is_finite() && strength >= 0.0) {
            return Err(self.err(format!(
                "material {index}: KHR_materials_emissive_strength {strength} must be a finite number >= 0"
            )));
        }
        let factor = Vec3::from(m.emissive_factor.0);
        if !factor.is_finite() || factor.min_element() < 0.0 {
            return Err(self.err(format!(
                "material {index}: emissiveFactor {factor} is negative or not finite"
            )));
        }
        let emissive_texture = match &m.emissive_texture {
            Some(info) => Some(self.texture_ref(info.index.value(), scene, slots)?),
            None => None,
        };
        let (normal_texture, normal_scale) = match &m.normal_texture {
            Some(n) => {
                if !n.scale.is_finite() {
                    return Err(self.err(format!(
                        "material {index}: normal texture scale {} is not finite",
                        n.scale
                    )));
                }
                (
                    Some(self.texture_ref(n.index.value(), scene, slots)?),
                    n.scale,
                )
            }
            None => (None, 1.0),
        };
        let alpha = self.alpha_mode(index, m)?;
        let (metallic, roughness) = (pbr.metallic_factor.0, pbr.roughness_factor.0);
        for (name, v) in [("metallicFactor", metallic), ("roughnessFactor", roughness)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(self.err(format!("material {index}: {name} {v} is outside [0, 1]")));
            }
        }
        let reflectance_texture = match &pbr.metallic_roughness_texture {
            Some(info) => Some(self.texture_ref(info.index.value(), scene, slots)?),
            None => None,
        };
        let uv_maps = self.material_uv_maps(index, m)?;
        self.uv_maps.push(uv_maps);
        let read_at = |t: Option<crate::scene::TextureRef>, uv| t.map(|t| crate::scene::TextureRef { uv, ..t });
        Ok(crate::scene::Material {
            base_color,
            texture,
            sampler,
            emission: factor * strength,
            emissive_texture: read_at(emissive_texture, uv_maps.emissive),
            normal_texture: read_at(normal_texture, uv_maps.normal),
            normal_scale,
            alpha,
            double_sided: m.double_sided,
            reflectance: crate::scene::Reflectance::MetallicRoughness {
                metallic,
                roughness,
                texture: read_at(reflectance_texture, uv_maps.reflectance),
            },
        })
    }

    /// Material `index`'s alpha mode (blending becomes a mask at 0.5).
    pub(super) fn alpha_mode(&self, index: usize, m: &json::Material) -> Result<crate::scene::AlphaMode> {
        use json::material::AlphaMode as A;
        Ok(match checked(&m.alpha_mode) {
            Some(A::Opaque) => crate::scene::AlphaMode::Opaque,
            Some(A::Mask) => {
                let cutoff = m.alpha_cutoff.map(|c| c.0).unwrap_or(0.5);
                if !(0.0..=1.0).contains(&cutoff) {
                    return Err(self.err(format!(
                        "material {index}: alphaCutoff {cutoff} is outside [0, 1]"
                    )));
                }
                crate::scene::AlphaMode::Mask(cutoff)
            }
            // Blending is not supported: a cutoff at 0.5 keeps the opaque parts.
            Some(A::Blend) => crate::scene::AlphaMode::Mask(0.5),
            None => return Err(self.err(format!("material {index}: invalid alphaMode"))),
        })
    }

    /// Where material `index`'s textures are read (the occlusion texture is
    /// not read, so it does not count): the mesh's map, its first
    /// texture's (the base colour's if it has one), and each texture's
    /// affine map from the mapped coordinates. Textures on another TEXCOORD
    /// set than the first's are read with the first's (a warning says so).
    pub(super) fn material_uv_maps(&self, index: usize, m: &json::Material) -> Result<MaterialUvMaps> {
        use json::extensions::texture::TextureTransform;
        let pbr = &m.pbr_metallic_roughness;
        let info = |i: &json::texture::Info| (i.tex_coord, i.extensions.as_ref().and_then(|e| e.texture_transform.clone()));
        // The normal texture's extensions are not typed by the gltf crate.
        let normal = m.normal_texture.as_ref().map(|n| {
            let transform = n
                .extensions
                .as_ref()
                .and_then(|e| e.others.get("KHR_texture_transform"))
                .map(|v| serde_json::from_value::<TextureTransform>(v.clone()));
            (n.tex_coord, transform)
        });
        let mut used: Vec<(TextureSlot, u32, Option<TextureTransform>)> = Vec::new();
        if let Some(i) = &pbr.base_color_texture {
            let (set, t) = info(i);
            used.push((TextureSlot::BaseColor, set, t));
        }
        if let Some(i) = &pbr.metallic_roughness_texture {
            let (set, t) = info(i);
            used.push((TextureSlot::MetallicRoughness, set, t));
        }
        if let Some((set, t)) = normal {
            let t = t.transpose().map_err(|e| {
                self.err(format!("material {index}: normalTexture's KHR_texture_transform: {e}"))
            })?;
            used.push((TextureSlot::Normal, set, t));
        }
        if let Some(i) = &m.emissive_texture {
            let (set, t) = info(i);
            used.push((TextureSlot::Emissive, set, t));
        }
        let mut maps = Vec::with_capacity(used.len());
        for (slot, tex_coord, transform) in used {
            let map = match transform {
                None => UvMap { set: tex_coord, transform: Affine2::IDENTITY },
                Some(t) => UvMap {
                    set: t.tex_coord.unwrap_or(tex_coord),
                    transform: texture_transform(&t).ok_or_else(|| {
                        self.err(format!(
                            "material {index}: {}'s KHR_texture_transform holds a non-finite number",
                            slot.name()
                        ))
                    })?,
                },
            };
            maps.push((slot, map));
        }
        let mut out = MaterialUvMaps::default();
        let Some(&(first, mesh)) = maps.first() else {
            return Ok(out);
        };
        out.mesh = mesh;
        // Another transform of the same set: the mesh's coordinates mapped
        // back, then by the texture's own map.
        let unmap = mesh.transform.inverse();
        let mut differ = Vec::new();
        for &(slot, map) in &maps[1..] {
            let relative = map.transform * unmap;
            let relative = if map == mesh {
                Affine2::IDENTITY
            } else if map.set == mesh.set && relative.is_finite() {
                relative
            } else {
                differ.push(slot.name());
                Affine2::IDENTITY
            };
            match slot {
                TextureSlot::MetallicRoughness => out.reflectance = relative,
                TextureSlot::Normal => out.normal = relative,
                TextureSlot::Emissive => out.emissive = relative,
                TextureSlot::BaseColor => {}
            }
        }
        if !differ.is_empty() {
            log::warn!(
                "{}: material {index}: {} use another TEXCOORD set than {} (or its \
                 KHR_texture_transform cannot be undone); ssbc reads a material's \
                 textures from one set, {}'s",
                self.name,
                differ.join(", "),
                first.name(),
                first.name()
            );
        }
        Ok(out)
    }

    /// Texture `index`: its image (decoded once) and its sampler.
    pub(super) fn texture_ref(
        &mut self,
        index: usize,
        scene: &mut Scene,
        slots: &mut [Option<usize>],
    ) -> Result<crate::scene::TextureRef> {
        let image = self.texture(index, scene, slots)?;
        let t = &self.root.textures[index];
        let sampler = match t.sampler {
            None => crate::scene::TextureSampler::default(),
            Some(s) => {
                let s = self.root.samplers.get(s.value()).ok_or_else(|| {
                    self.err(format!(
                        "texture {index}: sampler {} out of range",
                        s.value()
                    ))
                })?;
                use json::texture::{MagFilter, WrappingMode as W};
                let wrap = |w: &Checked<W>| match checked(w) {
                    Some(W::ClampToEdge) => Ok(crate::scene::Wrap::ClampToEdge),
                    Some(W::MirroredRepeat) => Ok(crate::scene::Wrap::MirroredRepeat),
                    Some(W::Repeat) => Ok(crate::scene::Wrap::Repeat),
                    None => Err(self.err(format!("texture {index}: invalid wrap mode"))),
                };
                crate::scene::TextureSampler {
                    wrap_s: wrap(&s.wrap_s)?,
                    wrap_t: wrap(&s.wrap_t)?,
                    nearest: matches!(
                        s.mag_filter.as_ref().and_then(checked),
                        Some(MagFilter::Nearest)
                    ),
                }
            }
        };
        Ok(crate::scene::TextureRef::new(image, sampler))
    }

    /// Decodes texture `index` into the scene (once) and returns its slot.
    pub(super) fn texture(
        &mut self,
        index: usize,
        scene: &mut Scene,
        slots: &mut [Option<usize>],
    ) -> Result<usize> {
        let t = self
            .root
            .textures
            .get(index)
            .ok_or_else(|| self.err(format!("texture index {index} out of range")))?;
        let image_index = t.source.value();
        let image = self
            .root
            .images
            .get(image_index)
            .ok_or_else(|| self.err(format!("image index {image_index} out of range")))?;
        if let Some(slot) = slots[image_index] {
            return Ok(slot);
        }
        let bytes = match (&image.uri, image.buffer_view) {
            (Some(uri), _) => self.read_uri(uri)?,
            (None, Some(v)) => self.view(v.value())?.0.to_vec(),
            (None, None) => {
                return Err(self.err(format!(
                    "image {image_index} has neither uri nor bufferView"
                )))
            }
        };
        let reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| self.err(format!("image {image_index}: {e}")))?;
        if !matches!(
            reader.format(),
            Some(image::ImageFormat::Png | image::ImageFormat::Jpeg)
        ) {
            let declared = image
                .mime_type
                .as_ref()
                .map(|m| m.0.clone())
                .or_else(|| data_uri_media_type(image.uri.as_deref()?));
            let what = match (sniff_image_format(&bytes), declared) {
                (Some(f), _) => f.to_string(),
                (None, Some(m)) => format!("'{m}' (not recognised from its bytes)"),
                (None, None) => "of an unknown format".into(),
            };
            return Err(self.err(format!(
                "image {image_index} is {what}; ssbc reads PNG and JPEG textures"
            )));
        }
        // Dimensions first (from the header): nothing is allocated for an
        // image that is too large or would exceed the scene's budget.
        let (width, height) = reader
            .into_dimensions()
            .map_err(|e| self.err(format!("image {image_index} cannot be decoded: {e}")))?;
        if width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
            return Err(self.err(format!(
                "image {image_index} is {width}x{height}; textures may be at most \
                 {MAX_TEXTURE_SIDE} texels a side"
            )));
        }
        let rgba_bytes = width as u64 * height as u64 * 4;
        self.check_budget(rgba_bytes)?;
        let mut reader = image::ImageReader::new(std::io::Cursor::new(&bytes[..]))
            .with_guessed_format()
            .map_err(|e| self.err(format!("image {image_index}: {e}")))?;
        let mut limits = image::Limits::default();
        limits.max_image_width = Some(MAX_TEXTURE_SIDE);
        limits.max_image_height = Some(MAX_TEXTURE_SIDE);
        // The decoder's own buffers: the image at its stored depth, then RGBA.
        limits.max_alloc = Some(2 * rgba_bytes + (1 << 20));
        reader.limits(limits);
        let decoded = reader
            .decode()
            .map_err(|e| self.err(format!("image {image_index} cannot be decoded: {e}")))?
            .into_rgba8();
        scene.textures.push(Texture {
            width: decoded.width(),
            height: decoded.height(),
            rgba8: decoded.into_raw(),
        });
        let slot = scene.textures.len() - 1;
        slots[image_index] = Some(slot);
        Ok(slot)
    }
}
