//! glTF 2.0 loading (`.gltf` with external or embedded buffers, `.glb`),
//! written for untrusted files.
//!
//! The `gltf` crate is used only to parse JSON and GLB containers; accessors,
//! buffers and images are resolved here with bounds checks, so an index or a
//! byte range out of range is an error, not a panic. Buffer and image URIs are
//! resolved relative to the scene's folder and may not leave it (no absolute
//! paths, no `..` escapes, no symlinks out, no `file:` URIs).
//!
//! Work and memory are bounded by the input: nodes must form trees (each
//! visited once, so shared or cyclic children cannot blow up), and the loaded
//! scene (vertices, indices, decoded textures) may take at most
//! `BUDGET_BASE` + `BUDGET_FACTOR` x the bytes read (the file and the
//! buffers and images it names), so a small hostile file cannot make a huge
//! allocation. Textures are PNG or JPEG, at most 8192 texels a side.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::{Affine2, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf::json::{self, accessor::ComponentType, accessor::Type, validation::Checked};

use super::animation::{
    poses_at, Channel, Interpolation, NodeAnimation, Path as AnimPath, PoseNode, PoseOverride,
    Sampler,
};
use super::{deform, Camera, Light, LightKind, Scene, Texture, MAX_TRIANGLES};
use crate::error::{Error, Result};

/// Largest file, buffer or image accepted, in bytes.
const MAX_BYTES: u64 = 1 << 30;
/// Deepest node hierarchy accepted.
const MAX_DEPTH: usize = 256;
/// Largest texture side after decoding.
const MAX_TEXTURE_SIDE: u32 = 8192;
/// Most vertex displacements read for one primitive's morph targets (a
/// file naming one accessor as a million targets would otherwise take
/// minutes).
const MAX_MORPH_READS: usize = 1 << 26;
/// The loaded scene may take this many bytes whatever the input's size...
pub const BUDGET_BASE: u64 = 32 << 20;
/// ...plus this many times the bytes read.
pub const BUDGET_FACTOR: u64 = 64;

/// Material extensions ssbc does not implement: it renders their materials
/// as core metallic-roughness, with one warning per scene naming them.
const APPROXIMATED_EXTENSIONS: [&str; 13] = [
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_dispersion",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_pbrSpecularGlossiness",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_volume",
    "KHR_materials_volume_scatter",
];

/// Extensions ssbc reads.
const IMPLEMENTED_EXTENSIONS: [&str; 4] = [
    "KHR_lights_punctual",
    "KHR_materials_emissive_strength",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
];

/// Loads a glTF or GLB file; with `time`, its first animation's node
/// transforms at that time (seconds).
pub fn load(path: &Path, time: Option<f32>) -> Result<Scene> {
    let name = path.display().to_string();
    let meta = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !meta.is_file() {
        return Err(Error::scene(&name, "not a file"));
    }
    if meta.len() > MAX_BYTES {
        return Err(Error::scene(
            &name,
            format!("file is larger than {MAX_BYTES} bytes"),
        ));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let dir = path
        .parent()
        .map(|p| {
            if p.as_os_str().is_empty() {
                Path::new(".")
            } else {
                p
            }
        })
        .unwrap_or(Path::new("."));
    load_guarded(&name, &bytes, dir, time)
}

/// [`load_bytes`] for any folder `base`, with a panic in a dependency on
/// malformed input turned into an error (the last line of defence).
pub fn load_guarded(name: &str, bytes: &[u8], base: &Path, time: Option<f32>) -> Result<Scene> {
    let base = base.canonicalize().map_err(|e| Error::io(base, e))?;
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        load_bytes(name, bytes, &base, time)
    })) {
        Ok(result) => result,
        Err(_) => Err(Error::scene(
            name,
            "the glTF parser failed on malformed input",
        )),
    }
}

/// Parses glTF/GLB `bytes`; external files are looked up below the
/// canonical folder `base`; `time`: see [`load`].
pub fn load_bytes(name: &str, bytes: &[u8], base: &Path, time: Option<f32>) -> Result<Scene> {
    let err = |m: String| Error::scene(name, m);
    if time.is_some_and(|t| !t.is_finite()) {
        return Err(err("the animation time is not a finite number".into()));
    }
    if bytes.starts_with(b"glTF") {
        check_glb_header(bytes).map_err(err)?;
    } else if bytes.iter().find(|b| !b.is_ascii_whitespace()) != Some(&b'{') {
        return Err(err("not a glTF file (neither JSON nor GLB)".into()));
    }
    let gltf = gltf::Gltf::from_slice_without_validation(bytes)
        .map_err(|e| err(format!("not valid glTF: {e}")))?;
    let blob = gltf.blob.clone();
    let root = gltf.document.into_json();
    Loader {
        name,
        root: &root,
        base,
        blob,
        buffers: Vec::new(),
        input_bytes: std::cell::Cell::new(bytes.len() as u64),
        stored: std::cell::Cell::new(0),
        time,
        poses: HashMap::new(),
        channels: Vec::new(),
        pose_nodes: Vec::new(),
        meshes: HashMap::new(),
        worlds: HashMap::new(),
        skinned: Vec::new(),
        uv_maps: Vec::new(),
    }
    .load()
}

/// Turns TANGENT frames (along +u, the bitangent `cross(n, t) w` along -v)
/// to the uvs a texture transform with linear part `map` made: the
/// direction of the mapped u and the handedness of the mapped v, as tangents
/// generated from the mapped uvs would have (taking the surface's u and v
/// as equally long, all a unit frame says). Without it a rotating transform
/// turned the normal map's slopes with the texture but not with the frame.
fn follow_texture_transform(tangents: &mut [Vec4], normals: &[Vec3], map: glam::Mat2) {
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
        *t = tangent.extend(super::handedness(n, tangent, dp_dv_mapped));
    }
}

/// GLB header and chunk lengths must fit the file (the parser trusts them).
fn check_glb_header(bytes: &[u8]) -> std::result::Result<(), String> {
    let u32_at = |o: usize| {
        bytes
            .get(o..o + 4)
            .map(|b| u32::from_le_bytes(b.try_into().unwrap()))
    };
    let length = u32_at(8).ok_or("truncated GLB header")? as usize;
    if length > bytes.len() {
        return Err(format!(
            "truncated GLB: header says {length} bytes, file has {}",
            bytes.len()
        ));
    }
    let mut offset = 12;
    while offset < length {
        let chunk_len = u32_at(offset).ok_or("truncated GLB chunk header")? as usize;
        let end = offset
            .checked_add(8)
            .and_then(|o| o.checked_add(chunk_len))
            .ok_or("GLB chunk length overflows")?;
        if end > length {
            return Err("truncated GLB: a chunk runs past the end of the file".into());
        }
        offset = end;
    }
    Ok(())
}

struct Loader<'a> {
    name: &'a str,
    root: &'a json::Root,
    base: &'a Path,
    blob: Option<Vec<u8>>,
    buffers: Vec<Option<Vec<u8>>>,
    /// Bytes read so far: the file and every external buffer and image.
    input_bytes: std::cell::Cell<u64>,
    /// Bytes the scene takes so far (meshes, textures, objects).
    stored: std::cell::Cell<u64>,
    /// The time the first animation is played at (None: rest pose).
    time: Option<f32>,
    /// Animated nodes' transforms at that time.
    poses: HashMap<usize, PoseOverride>,
    /// The first animation's channels (read whether or not a time is
    /// given: the scene keeps them for posing later).
    channels: Vec<Channel>,
    /// The nodes visited, parents first (for posing later).
    pose_nodes: Vec<PoseNode>,
    /// Per glTF mesh and morph weights (their bits), the scene meshes made
    /// of its triangle primitives (made once, however many nodes draw it).
    meshes: HashMap<(usize, Vec<u32>), Vec<usize>>,
    /// Every node's world transform, by glTF node index (skins' joints).
    worlds: HashMap<usize, Mat4>,
    /// Nodes drawing a skinned mesh: (node, mesh, skin), posed once every
    /// node's world transform is known.
    skinned: Vec<(usize, usize, usize)>,
    /// Per glTF material, where its textures are read.
    uv_maps: Vec<MaterialUvMaps>,
}

/// Where a texture is read: a `TEXCOORD_n` set, and the affine map
/// `KHR_texture_transform` applies to it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct UvMap {
    set: u32,
    transform: Affine2,
}

/// Where a material's textures are read. Its first texture's map is applied
/// to the mesh's texture coordinates at load (an affine map keeps the
/// G-buffer's uv derivatives right); each other texture is read at its own
/// map of those ([`super::TextureRef::uv`]), identity where they agree.
#[derive(Clone, Copy, Debug, Default)]
struct MaterialUvMaps {
    mesh: UvMap,
    emissive: Affine2,
    normal: Affine2,
    reflectance: Affine2,
}

/// A material's textures, as its warnings name them.
#[derive(Clone, Copy, Debug, PartialEq)]
enum TextureSlot {
    BaseColor,
    MetallicRoughness,
    Normal,
    Emissive,
}

impl TextureSlot {
    fn name(self) -> &'static str {
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
fn texture_transform(t: &json::extensions::texture::TextureTransform) -> Option<Affine2> {
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

fn checked<T: Copy>(c: &Checked<T>) -> Option<T> {
    match c {
        Checked::Valid(v) => Some(*v),
        Checked::Invalid => None,
    }
}

impl Loader<'_> {
    fn err(&self, m: impl Into<String>) -> Error {
        Error::scene(self.name, m)
    }

    /// Bytes the loaded scene may take (see the module documentation).
    fn budget(&self) -> u64 {
        BUDGET_BASE.saturating_add(BUDGET_FACTOR.saturating_mul(self.input_bytes.get()))
    }

    /// Counts `more` bytes the scene is about to take; fails if that
    /// exceeds the budget. (A running total: summing the scene's meshes at
    /// every primitive would be quadratic in a file of many small ones.)
    fn check_budget(&self, more: u64) -> Result<()> {
        let used = self.stored.get().saturating_add(more);
        self.stored.set(used);
        if used > self.budget() {
            return Err(self.err(format!(
                "the scene would take {} MiB, more than {} MiB for {} bytes of input \
                 ({} MiB + {}x the input)",
                used >> 20,
                self.budget() >> 20,
                self.input_bytes.get(),
                BUDGET_BASE >> 20,
                BUDGET_FACTOR
            )));
        }
        Ok(())
    }

    fn load(mut self) -> Result<Scene> {
        // Before anything is decoded.
        self.check_required_extensions()?;
        self.buffers = vec![None; self.root.buffers.len()];
        let mut scene = Scene::new(
            Path::new(self.name)
                .file_name()
                .map(|f| f.to_string_lossy().into_owned())
                .unwrap_or_else(|| self.name.to_string()),
        );
        // Textures are decoded on demand, once each.
        let mut texture_slots: Vec<Option<usize>> = vec![None; self.root.images.len()];
        let mut material_map = Vec::new();
        for (i, m) in self.root.materials.iter().enumerate() {
            let material = self.material(i, m, &mut scene, &mut texture_slots)?;
            scene.materials.push(material);
            material_map.push((scene.materials.len() - 1) as u32);
        }
        // glTF's default material: white, metallic 1, roughness 1, one-sided.
        scene.materials.push(super::Material {
            double_sided: false,
            ..super::Material::metallic_roughness(Vec3::ONE, 1.0, 1.0)
        });
        let default_material = (scene.materials.len() - 1) as u32;
        self.warn_unsupported_extensions();
        self.warn_not_played();
        self.channels = match (self.animation_channels(), self.time) {
            (Ok(c), _) => c,
            (Err(e), Some(_)) => return Err(e),
            // At rest a broken animation is not needed: the file loads.
            (Err(e), None) => {
                log::warn!("{e}; the animation cannot be played");
                Vec::new()
            }
        };
        if let Some(t) = self.time {
            self.poses = poses_at(&self.channels, t);
        }
        scene.animation_end = self.animation_end();

        let roots: Vec<usize> = match (self.root.scene, self.root.scenes.first()) {
            (Some(i), _) => self
                .root
                .scenes
                .get(i.value())
                .ok_or_else(|| self.err(format!("scene index {} out of range", i.value())))?
                .nodes
                .iter()
                .map(|n| n.value())
                .collect(),
            (None, Some(s)) => s.nodes.iter().map(|n| n.value()).collect(),
            // No scenes: every node that is nobody's child is a root.
            (None, None) => {
                let children: HashSet<usize> = self
                    .root
                    .nodes
                    .iter()
                    .flat_map(|n| n.children.iter().flatten().map(|c| c.value()))
                    .collect();
                (0..self.root.nodes.len())
                    .filter(|i| !children.contains(i))
                    .collect()
            }
        };
        let mut visited = HashSet::new();
        for r in roots {
            self.node(
                r,
                (Mat4::IDENTITY, None),
                0,
                &mut visited,
                &mut scene,
                &material_map,
                default_material,
            )?;
        }
        for (node, mesh, skin) in std::mem::take(&mut self.skinned) {
            self.skinned_mesh(node, mesh, skin, &mut scene, &material_map, default_material)?;
        }
        if !self.channels.is_empty() {
            scene.set_animation(NodeAnimation {
                nodes: std::mem::take(&mut self.pose_nodes),
                channels: std::mem::take(&mut self.channels),
            });
        }
        if scene.triangle_count() == 0 {
            return Err(self.err("the scene has no triangles"));
        }
        Ok(scene)
    }

    /// A file that requires an extension ssbc neither reads nor approximates
    /// (compressed meshes or textures, ...) is refused, naming it.
    fn check_required_extensions(&self) -> Result<()> {
        let missing: Vec<&str> = self
            .root
            .extensions_required
            .iter()
            .map(String::as_str)
            .filter(|e| !IMPLEMENTED_EXTENSIONS.contains(e) && !APPROXIMATED_EXTENSIONS.contains(e))
            .collect();
        if missing.is_empty() {
            return Ok(());
        }
        Err(self.err(format!(
            "the file requires {}, which ssbc does not implement",
            missing.join(", ")
        )))
    }

    /// One warning naming the material extensions the file uses that ssbc
    /// does not implement (they change the BRDF).
    fn warn_unsupported_extensions(&self) {
        let used: Vec<&str> = APPROXIMATED_EXTENSIONS
            .into_iter()
            .filter(|e| self.root.extensions_used.iter().any(|u| u == e))
            .collect();
        if !used.is_empty() {
            log::warn!(
                "{}: ignoring {}: materials use glTF's core metallic-roughness model",
                self.name,
                used.join(", ")
            );
        }
    }

    /// One warning naming what moves a glTF scene that ssbc does not play.
    /// Nodes are drawn at their rest transforms (or the first animation's
    /// at the time given), meshes with their morph targets at their
    /// weights, skinned meshes posed by their joints at load; not played:
    /// other animations, animated morph weights, and skins during playback
    /// (posing later moves nodes' objects, not skinned vertices).
    fn warn_not_played(&self) {
        let r = &self.root;
        let animated = !r.animations.is_empty();
        let skinned = r.nodes.iter().filter(|n| n.skin.is_some()).count();
        let weight_channels = r
            .animations
            .iter()
            .flat_map(|a| &a.channels)
            .filter(|c| {
                checked(&c.target.path) == Some(json::animation::Property::MorphTargetWeights)
            })
            .count();
        // With a time, the first animation plays.
        let played = usize::from(self.time.is_some());
        let parts: Vec<String> = [
            (r.animations.len().saturating_sub(played), "animation", "animations"),
            (weight_channels, "morph-weight channel", "morph-weight channels"),
            (
                if animated { skinned } else { 0 },
                "skinned node (posed once, at load)",
                "skinned nodes (posed once, at load)",
            ),
        ]
        .into_iter()
        .filter(|(n, ..)| *n > 0)
        .map(|(n, one, many)| format!("{n} {}", if n == 1 { one } else { many }))
        .collect();
        if !parts.is_empty() {
            log::warn!("{}: not played: {}", self.name, parts.join(", "));
        }
    }

    /// The first animation's last keyframe time, from its input accessors'
    /// declared maxima (reading no data: a file whose animation is broken
    /// still loads at rest).
    fn animation_end(&self) -> Option<f32> {
        let animation = self.root.animations.first()?;
        animation
            .samplers
            .iter()
            .filter_map(|s| self.root.accessors.get(s.input.value())?.max.as_ref())
            .filter_map(|max| max.as_array()?.first()?.as_f64())
            .map(|t| t as f32)
            .filter(|t| t.is_finite() && *t >= 0.0)
            .reduce(f32::max)
    }

    /// The first animation's channels (none without one). Morph-target
    /// weights are not played (warn_not_played).
    fn animation_channels(&mut self) -> Result<Vec<Channel>> {
        let mut channels = Vec::new();
        let root = self.root;
        let Some(animation) = root.animations.first() else {
            if self.time.is_some() {
                log::warn!("{}: a time was given but the file has no animation", self.name);
            }
            return Ok(channels);
        };
        if root.animations.len() > 1 && self.time.is_some() {
            log::warn!(
                "{}: playing animation 0 ('{}') of {}",
                self.name,
                animation.name.as_deref().unwrap_or(""),
                root.animations.len()
            );
        }
        for (c, channel) in animation.channels.iter().enumerate() {
            let what = |m: String| format!("animation 0, channel {c}: {m}");
            let node = channel.target.node.value();
            if node >= root.nodes.len() {
                return Err(self.err(what(format!("targets node {node}, which does not exist"))));
            }
            use json::animation::Property as P;
            let path = match checked(&channel.target.path) {
                Some(P::Translation) => AnimPath::Translation,
                Some(P::Rotation) => AnimPath::Rotation,
                Some(P::Scale) => AnimPath::Scale,
                Some(P::MorphTargetWeights) => continue,
                None => return Err(self.err(what("an unknown target path".into()))),
            };
            let k = channel.sampler.value();
            let s = animation
                .samplers
                .get(k)
                .ok_or_else(|| self.err(what(format!("sampler {k} does not exist"))))?;
            use json::animation::Interpolation as I;
            let interpolation = match checked(&s.interpolation) {
                Some(I::Linear) => Interpolation::Linear,
                Some(I::Step) => Interpolation::Step,
                Some(I::CubicSpline) => Interpolation::CubicSpline,
                None => return Err(self.err(what("an unknown interpolation".into()))),
            };
            let sampler = Sampler {
                times: self.read_floats(s.input.value(), 1)?,
                values: self.read_floats(s.output.value(), path.components())?,
                interpolation,
            };
            sampler
                .check(path.components())
                .map_err(|m| self.err(what(format!("sampler {k}: {m}"))))?;
            channels.push(Channel {
                node,
                path,
                sampler,
            });
        }
        Ok(channels)
    }

    /// Material `index`: base colour, emission (factor x strength, and
    /// texture), normal map, alpha mode and sidedness, each texture with its
    /// sampler. Values glTF forbids are errors.
    fn material(
        &mut self,
        index: usize,
        m: &json::Material,
        scene: &mut Scene,
        slots: &mut [Option<usize>],
    ) -> Result<super::Material> {
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
            None => (None, super::TextureSampler::default()),
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
        use json::material::AlphaMode as A;
        let alpha = match checked(&m.alpha_mode) {
            Some(A::Opaque) => super::AlphaMode::Opaque,
            Some(A::Mask) => {
                let cutoff = m.alpha_cutoff.map(|c| c.0).unwrap_or(0.5);
                if !(0.0..=1.0).contains(&cutoff) {
                    return Err(self.err(format!(
                        "material {index}: alphaCutoff {cutoff} is outside [0, 1]"
                    )));
                }
                super::AlphaMode::Mask(cutoff)
            }
            // Blending is not supported: a cutoff at 0.5 keeps the opaque parts.
            Some(A::Blend) => super::AlphaMode::Mask(0.5),
            None => return Err(self.err(format!("material {index}: invalid alphaMode"))),
        };
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
        let read_at = |t: Option<super::TextureRef>, uv| t.map(|t| super::TextureRef { uv, ..t });
        Ok(super::Material {
            base_color,
            texture,
            sampler,
            emission: factor * strength,
            emissive_texture: read_at(emissive_texture, uv_maps.emissive),
            normal_texture: read_at(normal_texture, uv_maps.normal),
            normal_scale,
            alpha,
            double_sided: m.double_sided,
            reflectance: super::Reflectance::MetallicRoughness {
                metallic,
                roughness,
                texture: read_at(reflectance_texture, uv_maps.reflectance),
            },
        })
    }

    /// Where material `index`'s textures are read (the occlusion texture is
    /// not read, so it does not count): the mesh's map, its first
    /// texture's (the base colour's if it has one), and each texture's
    /// affine map from the mapped coordinates. Textures on another TEXCOORD
    /// set than the first's are read with the first's (a warning says so).
    fn material_uv_maps(&self, index: usize, m: &json::Material) -> Result<MaterialUvMaps> {
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
    fn texture_ref(
        &mut self,
        index: usize,
        scene: &mut Scene,
        slots: &mut [Option<usize>],
    ) -> Result<super::TextureRef> {
        let image = self.texture(index, scene, slots)?;
        let t = &self.root.textures[index];
        let sampler = match t.sampler {
            None => super::TextureSampler::default(),
            Some(s) => {
                let s = self.root.samplers.get(s.value()).ok_or_else(|| {
                    self.err(format!(
                        "texture {index}: sampler {} out of range",
                        s.value()
                    ))
                })?;
                use json::texture::{MagFilter, WrappingMode as W};
                let wrap = |w: &Checked<W>| match checked(w) {
                    Some(W::ClampToEdge) => Ok(super::Wrap::ClampToEdge),
                    Some(W::MirroredRepeat) => Ok(super::Wrap::MirroredRepeat),
                    Some(W::Repeat) => Ok(super::Wrap::Repeat),
                    None => Err(self.err(format!("texture {index}: invalid wrap mode"))),
                };
                super::TextureSampler {
                    wrap_s: wrap(&s.wrap_s)?,
                    wrap_t: wrap(&s.wrap_t)?,
                    nearest: matches!(
                        s.mag_filter.as_ref().and_then(checked),
                        Some(MagFilter::Nearest)
                    ),
                }
            }
        };
        Ok(super::TextureRef::new(image, sampler))
    }

    #[allow(clippy::too_many_arguments)]
    #[allow(clippy::too_many_arguments)]
    fn node(
        &mut self,
        index: usize,
        (parent, parent_slot): (Mat4, Option<usize>),
        depth: usize,
        visited: &mut HashSet<usize>,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<()> {
        let root = self.root;
        let node = root
            .nodes
            .get(index)
            .ok_or_else(|| self.err(format!("node index {index} out of range")))?;
        if depth > MAX_DEPTH {
            return Err(self.err(format!("node hierarchy deeper than {MAX_DEPTH}")));
        }
        // glTF nodes form disjoint trees: a node reached twice is shared or
        // its own ancestor (visiting it again could repeat work without end).
        if !visited.insert(index) {
            return Err(self.err(format!(
                "node {index} is reached twice (nodes must form trees; a cycle or a shared child)"
            )));
        }
        let rest = match node.matrix {
            Some(m) => Mat4::from_cols_array(&m),
            None => Mat4::from_scale_rotation_translation(
                node.scale.map(Vec3::from).unwrap_or(Vec3::ONE),
                node.rotation
                    .map(|q| Quat::from_array(q.0).normalize())
                    .unwrap_or(Quat::IDENTITY),
                node.translation.map(Vec3::from).unwrap_or(Vec3::ZERO),
            ),
        };
        // Animated parts replace the rest pose's (animated nodes have no
        // matrix in valid files; one is decomposed).
        let local = super::animation::local_transform(rest, self.poses.get(&index));
        let world = parent * local;
        let slot = self.pose_nodes.len();
        self.pose_nodes.push(PoseNode {
            node: index,
            parent: parent_slot,
            rest,
        });
        if !world.is_finite() {
            return Err(self.err(format!("node {index} has a non-finite transform")));
        }
        self.worlds.insert(index, world);
        match (node.mesh, node.skin) {
            // Skinned: posed by its joints once their transforms are known.
            (Some(mesh), Some(skin)) => self.skinned.push((index, mesh.value(), skin.value())),
            (Some(mesh), None) => {
                let weights = self.morph_weights(node, mesh.value())?;
                let key = (mesh.value(), weights.iter().map(|w| w.to_bits()).collect());
                let meshes = match self.meshes.get(&key) {
                    Some(m) => m.clone(),
                    None => {
                        let m = self.mesh(mesh.value(), &weights, None, scene, materials, default_material)?;
                        self.meshes.insert(key, m.clone());
                        m
                    }
                };
                for mesh in meshes {
                    self.add_object(scene, super::Object::at_node(mesh, world, index), index)?;
                }
            }
            _ => {}
        }
        if let Some(cam) = node.camera {
            let c = root
                .cameras
                .get(cam.value())
                .ok_or_else(|| self.err(format!("camera index {} out of range", cam.value())))?;
            match &c.perspective {
                Some(p) if p.yfov > 0.0 && p.yfov < std::f32::consts::PI => {
                    let (_, rot, pos) = world.to_scale_rotation_translation();
                    scene.cameras.push(Camera {
                        position: pos,
                        forward: (rot * -Vec3::Z).normalize(),
                        up: (rot * Vec3::Y).normalize(),
                        yfov: p.yfov,
                    });
                }
                _ => log::warn!(
                    "{}: camera {} is not a valid perspective camera; skipped",
                    self.name,
                    cam.value()
                ),
            }
        }
        if let Some(l) = node
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
        {
            scene.lights.push(self.light(l.light.value(), world)?);
        }
        for child in node.children.iter().flatten() {
            self.node(
                child.value(),
                (world, Some(slot)),
                depth + 1,
                visited,
                scene,
                materials,
                default_material,
            )?;
        }
        Ok(())
    }

    /// Adds an object drawn by node `index`, within the world's triangle
    /// and memory budgets.
    fn add_object(&self, scene: &mut Scene, object: super::Object, index: usize) -> Result<()> {
        let added = scene.meshes()[object.mesh].triangle_count();
        if scene.triangle_count() + added > MAX_TRIANGLES {
            return Err(self.err(format!(
                "more than {MAX_TRIANGLES} triangles in the world (node {index} draws mesh {} again)",
                object.mesh
            )));
        }
        self.check_budget(std::mem::size_of::<super::Object>() as u64)?;
        scene
            .add_object(object)
            .map(|_| ())
            .map_err(|e| self.err(format!("node {index}: {e}")))
    }

    /// The morph-target weights node `node` draws mesh `mesh` with: its
    /// own, else the mesh's defaults (glTF 2.0, 3.7.2.2); none without.
    fn morph_weights(&self, node: &json::Node, mesh: usize) -> Result<Vec<f32>> {
        let defaults = self.root.meshes.get(mesh).and_then(|m| m.weights.as_ref());
        let weights = node.weights.as_ref().or(defaults).cloned().unwrap_or_default();
        if weights.iter().any(|w| !w.is_finite()) {
            return Err(self.err(format!("mesh {mesh}: a morph-target weight is not finite")));
        }
        Ok(weights)
    }

    /// Node `index`'s skinned mesh, posed by its skin's joints: each
    /// joint's world transform (animated, at the loaded time) times its
    /// inverse bind matrix. The node's own transform does not apply
    /// (glTF 2.0, 3.7.3.3). The object does not follow later posing
    /// (animation playback moves nodes' objects, not skins' vertices).
    fn skinned_mesh(
        &mut self,
        index: usize,
        mesh: usize,
        skin: usize,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<()> {
        let root = self.root;
        let s = root
            .skins
            .get(skin)
            .ok_or_else(|| self.err(format!("node {index}: skin index {skin} out of range")))?;
        let inverse_binds: Vec<Mat4> = match s.inverse_bind_matrices {
            Some(a) => self
                .read_floats(a.value(), 16)?
                .chunks_exact(16)
                .map(Mat4::from_cols_slice)
                .collect(),
            None => vec![Mat4::IDENTITY; s.joints.len()],
        };
        if inverse_binds.len() < s.joints.len() {
            return Err(self.err(format!(
                "skin {skin}: {} inverse bind matrices for {} joints",
                inverse_binds.len(),
                s.joints.len()
            )));
        }
        let mut joints = Vec::with_capacity(s.joints.len());
        for (j, ibm) in s.joints.iter().zip(&inverse_binds) {
            let Some(world) = self.worlds.get(&j.value()) else {
                return Err(self.err(format!(
                    "skin {skin}: joint node {} is not in the scene drawn",
                    j.value()
                )));
            };
            joints.push(*world * *ibm);
        }
        let weights = self.morph_weights(&root.nodes[index], mesh)?;
        let made = self.mesh(mesh, &weights, Some((&joints, self.worlds[&index])), scene, materials, default_material)?;
        for m in made {
            self.add_object(scene, super::Object::new(m, Mat4::IDENTITY), index)?;
        }
        Ok(())
    }

    fn light(&self, index: usize, world: Mat4) -> Result<Light> {
        use json::extensions::scene::khr_lights_punctual::Type as T;
        let lights = self
            .root
            .extensions
            .as_ref()
            .and_then(|e| e.khr_lights_punctual.as_ref())
            .map(|k| &k.lights[..])
            .unwrap_or(&[]);
        let l = lights
            .get(index)
            .ok_or_else(|| self.err(format!("light index {index} out of range")))?;
        let intensity = Vec3::from(l.color) * l.intensity;
        if !intensity.is_finite() || intensity.min_element() < 0.0 {
            return Err(self.err(format!(
                "light {index} has a negative or non-finite intensity"
            )));
        }
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world.transform_vector3(-Vec3::Z).normalize_or_zero();
        if direction == Vec3::ZERO {
            return Err(self.err(format!("light {index} has a degenerate orientation")));
        }
        let kind = match checked(&l.type_) {
            Some(T::Point) => LightKind::Point,
            Some(T::Directional) => LightKind::Directional,
            Some(T::Spot) => {
                let s = l
                    .spot
                    .as_ref()
                    .ok_or_else(|| self.err(format!("spot light {index} has no cone")))?;
                let (inner, outer) = (s.inner_cone_angle, s.outer_cone_angle);
                if !(0.0..std::f32::consts::FRAC_PI_2).contains(&outer)
                    || !(0.0..=outer).contains(&inner)
                {
                    return Err(self.err(format!("spot light {index} has invalid cone angles")));
                }
                LightKind::Spot {
                    inner_cone: inner,
                    outer_cone: outer,
                }
            }
            None => return Err(self.err(format!("light {index} has an unknown type"))),
        };
        Ok(Light {
            kind,
            position,
            direction,
            intensity,
        })
    }

    /// Adds glTF mesh `index`'s triangle primitives as scene meshes (object
    /// space) and returns their indices.
    /// Mesh `index`'s triangle primitives as scene meshes, with its morph
    /// targets at `weights` and, with `joints` (see skinned_mesh), skinned.
    fn mesh(
        &mut self,
        index: usize,
        weights: &[f32],
        joints: Option<(&[Mat4], Mat4)>,
        scene: &mut Scene,
        materials: &[u32],
        default_material: u32,
    ) -> Result<Vec<usize>> {
        let mut made = Vec::new();
        use json::mesh::{Mode, Semantic};
        let root = self.root;
        let mesh = root
            .meshes
            .get(index)
            .ok_or_else(|| self.err(format!("mesh index {index} out of range")))?;
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let mode = checked(&prim.mode).ok_or_else(|| self.err("invalid primitive mode"))?;
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                log::warn!(
                    "{}: mesh {index} primitive {pi} is not triangles; skipped",
                    self.name
                );
                continue;
            }
            let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
            let pos_acc = attr(Semantic::Positions)
                .ok_or_else(|| self.err(format!("mesh {index} primitive {pi} has no POSITION")))?;
            let mut positions: Vec<Vec3> = self
                .read_floats(pos_acc, 3)?
                .chunks_exact(3)
                .map(Vec3::from_slice)
                .collect();
            let mut normals: Vec<Vec3> = match attr(Semantic::Normals) {
                Some(a) => self
                    .read_floats(a, 3)?
                    .chunks_exact(3)
                    .map(Vec3::from_slice)
                    .collect(),
                None => Vec::new(),
            };
            let uv_maps = match prim.material {
                Some(m) => self.uv_maps.get(m.value()).copied().unwrap_or_default(),
                None => MaterialUvMaps::default(),
            };
            let uv_map = uv_maps.mesh;
            let uvs: Vec<[f32; 2]> = match attr(Semantic::TexCoords(uv_map.set)) {
                Some(a) => self
                    .read_floats(a, 2)?
                    .chunks_exact(2)
                    .map(|c| uv_map.transform.transform_point2(Vec2::new(c[0], c[1])))
                    .map(|uv| uv.is_finite().then_some(uv.into()))
                    .collect::<Option<_>>()
                    .ok_or_else(|| {
                        self.err(format!(
                            "mesh {index} primitive {pi}: KHR_texture_transform takes texture coordinates past the largest float"
                        ))
                    })?,
                None => {
                    if uv_map.set != 0 {
                        log::warn!(
                            "{}: mesh {index} primitive {pi} has no TEXCOORD_{} for its material's textures",
                            self.name,
                            uv_map.set
                        );
                    }
                    Vec::new()
                }
            };
            let mut tangents: Vec<Vec4> = match attr(Semantic::Tangents) {
                Some(a) => self
                    .read_floats(a, 4)?
                    .chunks_exact(4)
                    .map(Vec4::from_slice)
                    .collect(),
                None => Vec::new(),
            };
            let colors = match attr(Semantic::Colors(0)) {
                Some(a) => self.read_colors(a, index, pi)?,
                None => Vec::new(),
            };
            if !normals.is_empty() && normals.len() != positions.len()
                || !uvs.is_empty() && uvs.len() != positions.len()
                || !tangents.is_empty() && tangents.len() != positions.len()
                || !colors.is_empty() && colors.len() != positions.len()
            {
                return Err(self.err(format!(
                    "mesh {index} primitive {pi}: attribute counts differ"
                )));
            }
            if !uvs.is_empty() && normals.len() == tangents.len() {
                // The normal map's own map of the TEXCOORD set.
                let normal_map = uv_maps.normal * uv_map.transform;
                follow_texture_transform(&mut tangents, &normals, normal_map.matrix2);
            }
            let at = format!("mesh {index} primitive {pi}");
            self.morph(&at, prim, weights, &mut positions, &mut normals, &mut tangents)?;
            if let Some(joints) = joints {
                self.skin(&at, prim, joints, &mut positions, &mut normals, &mut tangents)?;
            }
            let raw_indices = match prim.indices {
                Some(a) => self.read_indices(a.value())?,
                None => (0..positions.len() as u32).collect(),
            };
            if let Some(&bad) = raw_indices.iter().find(|&&i| i as usize >= positions.len()) {
                return Err(self.err(format!(
                    "mesh {index} primitive {pi}: index {bad} out of range ({} vertices)",
                    positions.len()
                )));
            }
            let indices = triangulate(mode, &raw_indices);
            let material = match prim.material {
                Some(m) => *materials.get(m.value()).ok_or_else(|| {
                    self.err(format!("material index {} out of range", m.value()))
                })?,
                None => default_material,
            };
            if indices.len() / 3 > MAX_TRIANGLES {
                return Err(self.err(format!("more than {MAX_TRIANGLES} triangles")));
            }
            // Flat normals unshare vertices: three a triangle.
            let vertices = if normals.is_empty() {
                indices.len()
            } else {
                positions.len()
            };
            self.check_budget(
                (vertices * std::mem::size_of::<super::Vertex>() + indices.len() * 4) as u64,
            )?;
            made.push(scene.new_mesh(
                super::MeshData {
                    positions: &positions,
                    normals: &normals,
                    uvs: &uvs,
                    tangents: &tangents,
                    colors: &colors,
                    indices: &indices,
                },
                material,
            )?);
        }
        Ok(made)
    }

    /// Displaces a primitive's vertices by its morph targets at `weights`
    /// (a missing weight is 0). Each target read adds a pass over the
    /// vertices: at most MAX_MORPH_READS vertex reads in all per primitive.
    fn morph(
        &mut self,
        at: &str,
        prim: &json::mesh::Primitive,
        weights: &[f32],
        positions: &mut [Vec3],
        normals: &mut [Vec3],
        tangents: &mut [Vec4],
    ) -> Result<()> {
        let targets = prim.targets.as_deref().unwrap_or_default();
        let applied = targets.iter().zip(weights).filter(|(_, w)| **w != 0.0);
        if applied.clone().count().saturating_mul(positions.len()) > MAX_MORPH_READS {
            return Err(self.err(format!(
                "{at}: more morph-target work than {MAX_MORPH_READS} vertex reads"
            )));
        }
        let n = positions.len();
        for (k, (target, &w)) in applied.enumerate() {
            let read = |loader: &mut Self, a: Option<json::Index<json::Accessor>>| -> Result<Option<Vec<f32>>> {
                let Some(a) = a else { return Ok(None) };
                let d = loader.read_floats(a.value(), 3)?;
                if d.len() != 3 * n {
                    return Err(loader.err(format!("{at}: morph target {k} has {} vertices, not {n}", d.len() / 3)));
                }
                Ok(Some(d))
            };
            if let Some(d) = read(self, target.positions)? {
                deform::add_displacements(positions, &d, w);
            }
            if let Some(d) = read(self, target.normals)? {
                deform::add_displacements(normals, &d, w);
            }
            if let Some(d) = read(self, target.tangents)? {
                deform::add_tangent_displacements(tangents, &d, w);
            }
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(self.err(format!("{at}: morph targets move a vertex past the largest float")));
        }
        deform::renormalize(normals, Vec3::Z);
        Ok(())
    }

    /// Skins a primitive's vertices by `joints` (deform::skin) with its
    /// JOINTS_n / WEIGHTS_n sets; without any, transforms them by `node`,
    /// its node's world transform, as if it were not skinned.
    fn skin(
        &mut self,
        at: &str,
        prim: &json::mesh::Primitive,
        (mut joints, node): (&[Mat4], Mat4),
        positions: &mut [Vec3],
        normals: &mut [Vec3],
        tangents: &mut [Vec4],
    ) -> Result<()> {
        use json::mesh::Semantic;
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|a| a.value());
        let n = positions.len();
        let unposed = [node];
        let (mut joint_sets, mut weight_sets) = (Vec::new(), Vec::new());
        for set in 0.. {
            let (Some(j), Some(w)) = (attr(Semantic::Joints(set)), attr(Semantic::Weights(set))) else {
                break;
            };
            let (j, w) = (self.read_floats(j, 4)?, self.read_floats(w, 4)?);
            if j.len() != 4 * n || w.len() != 4 * n {
                return Err(self.err(format!("{at}: JOINTS_{set} / WEIGHTS_{set} counts differ from its vertices'")));
            }
            if let Some(bad) = j.iter().find(|&&j| !(j >= 0.0 && j.fract() == 0.0 && (j as usize) < joints.len())) {
                return Err(self.err(format!("{at}: joint {bad} is not one of the skin's {} joints", joints.len())));
            }
            joint_sets.push(j);
            weight_sets.push(w);
        }
        if joint_sets.is_empty() {
            // Drawn as if not skinned: by its node's transform.
            log::warn!(
                "{}: {at} is skinned but has no JOINTS_0 / WEIGHTS_0; drawn at its node",
                self.name
            );
            joint_sets.push(vec![0.0; 4 * n]);
            weight_sets.push([1.0, 0.0, 0.0, 0.0].repeat(n));
            joints = &unposed;
        }
        // Vertex-major, as deform::Influences wants.
        let sets = joint_sets.len();
        let mut joint_indices = Vec::with_capacity(4 * sets * n);
        let mut weights = Vec::with_capacity(4 * sets * n);
        for v in 0..n {
            for (j, w) in joint_sets.iter().zip(&weight_sets) {
                joint_indices.extend(j[4 * v..4 * v + 4].iter().map(|&j| j as u32));
                weights.extend(&w[4 * v..4 * v + 4]);
            }
        }
        let influences = deform::Influences { sets, joints: &joint_indices, weights: &weights };
        deform::skin(joints, &influences, positions, normals, tangents);
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(self.err(format!("{at}: skinning moves a vertex past the largest float")));
        }
        Ok(())
    }

    /// The bytes of buffer `index` (GLB blob, data URI, or file in the scene folder).
    fn buffer(&mut self, index: usize) -> Result<&[u8]> {
        if self.buffers.get(index).is_none() {
            return Err(self.err(format!("buffer index {index} out of range")));
        }
        if self.buffers[index].is_none() {
            let b = &self.root.buffers[index];
            let data = match &b.uri {
                None => self.blob.clone().ok_or_else(|| {
                    self.err(format!(
                        "buffer {index} has no URI and there is no GLB binary chunk"
                    ))
                })?,
                Some(uri) => self.read_uri(uri)?,
            };
            if (data.len() as u64) < b.byte_length.0 {
                return Err(self.err(format!(
                    "buffer {index} is {} bytes, shorter than its byteLength {}",
                    data.len(),
                    b.byte_length.0
                )));
            }
            self.buffers[index] = Some(data);
        }
        Ok(self.buffers[index].as_deref().unwrap())
    }

    /// Reads a data URI, or a relative file path inside the scene's folder.
    fn read_uri(&self, uri: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (_, payload) = rest
                .split_once(";base64,")
                .ok_or_else(|| self.err("only base64 data URIs are supported"))?;
            if payload.len() as u64 > MAX_BYTES * 4 / 3 {
                return Err(self.err("data URI too large"));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload)
                .map_err(|e| self.err(format!("bad base64 data URI: {e}")));
        }
        if uri.contains(':') {
            return Err(self.err(format!(
                "refusing URI '{uri}': only relative paths and data URIs are read"
            )));
        }
        let decoded = percent_encoding::percent_decode_str(uri)
            .decode_utf8()
            .map_err(|_| self.err(format!("URI '{uri}' is not valid percent-encoded UTF-8")))?;
        let relative = PathBuf::from(decoded.as_ref());
        if relative.is_absolute() || relative.has_root() {
            return Err(self.err(format!(
                "refusing absolute path '{uri}' (outside the scene's folder)"
            )));
        }
        // Lexical check first (the file need not exist to be refused), then
        // the canonical path (catches symlinks out of the folder).
        let mut depth = 0i32;
        for c in relative.components() {
            match c {
                std::path::Component::ParentDir => depth -= 1,
                std::path::Component::Normal(_) => depth += 1,
                _ => {}
            }
            if depth < 0 {
                return Err(self.err(format!(
                    "refusing '{uri}': it points outside the scene's folder"
                )));
            }
        }
        let path = self.base.join(&relative);
        let resolved = path
            .canonicalize()
            .map_err(|e| self.err(format!("cannot open '{uri}': {e}")))?;
        if !resolved.starts_with(self.base) {
            return Err(self.err(format!(
                "refusing '{uri}': it points outside the scene's folder"
            )));
        }
        let len = std::fs::metadata(&resolved)
            .map_err(|e| Error::io(&resolved, e))?
            .len();
        if len > MAX_BYTES {
            return Err(self.err(format!("'{uri}' is larger than {MAX_BYTES} bytes")));
        }
        let bytes = std::fs::read(&resolved).map_err(|e| Error::io(&resolved, e))?;
        self.input_bytes
            .set(self.input_bytes.get().saturating_add(bytes.len() as u64));
        Ok(bytes)
    }

    /// The byte range of buffer view `index` (checked), and its stride.
    fn view(&mut self, index: usize) -> Result<(&[u8], Option<usize>)> {
        let v = self
            .root
            .buffer_views
            .get(index)
            .ok_or_else(|| self.err(format!("bufferView index {index} out of range")))?;
        let (offset, length) = (v.byte_offset.map(|o| o.0).unwrap_or(0), v.byte_length.0);
        let stride = v.byte_stride.map(|s| s.0);
        let buffer_index = v.buffer.value();
        let name = self.name;
        let data = self.buffer(buffer_index)?;
        let end = offset
            .checked_add(length)
            .filter(|&e| e <= data.len() as u64)
            .ok_or_else(|| {
                Error::scene(
                    name,
                    format!("bufferView {index} runs past the end of buffer {buffer_index}"),
                )
            })?;
        Ok((&data[offset as usize..end as usize], stride))
    }

    /// Reads accessor `index` as elements of `components` numbers each: its
    /// component type and the elements' bytes, packed without stride.
    fn accessor_elements(
        &mut self,
        index: usize,
        components: usize,
    ) -> Result<(ComponentType, Vec<u8>)> {
        let a = self
            .root
            .accessors
            .get(index)
            .ok_or_else(|| self.err(format!("accessor index {index} out of range")))?;
        let ty = checked(&a.type_)
            .ok_or_else(|| self.err(format!("accessor {index} has an invalid type")))?;
        let expected = match ty {
            Type::Scalar => 1,
            Type::Vec2 => 2,
            Type::Vec3 => 3,
            Type::Vec4 => 4,
            // Inverse bind matrices (floats: no column padding).
            Type::Mat4 => 16,
            _ => 0,
        };
        if expected != components {
            return Err(self.err(format!(
                "accessor {index} has type {ty:?}, expected {components} components"
            )));
        }
        let ct = checked(&a.component_type)
            .ok_or_else(|| self.err(format!("accessor {index} has an invalid component type")))?
            .0;
        let count = a.count.0 as usize;
        if count == 0 || count > 3 * MAX_TRIANGLES {
            return Err(self.err(format!(
                "accessor {index} has an unreasonable count {count}"
            )));
        }
        let elem = ct.size() * components;
        // Zeros, or a bufferView's elements, then a sparse substitution.
        let mut packed = match a.buffer_view {
            None => {
                // Nothing is read, so the input does not bound it: the
                // scene's whole budget does.
                if (count * elem) as u64 > self.budget() {
                    return Err(self.err(format!(
                        "accessor {index}: {count} elements without a bufferView exceed the scene's budget"
                    )));
                }
                vec![0u8; count * elem]
            }
            Some(view) => {
                let offset = a.byte_offset.map(|o| o.0 as usize).unwrap_or(0);
                let (bytes, stride) = self.view(view.value())?;
                let stride = stride.unwrap_or(elem);
                if stride < elem {
                    return Err(Error::scene(
                        self.name,
                        format!("accessor {index}: byteStride {stride} smaller than an element"),
                    ));
                }
                let needed = stride
                    .checked_mul(count - 1)
                    .and_then(|n| n.checked_add(offset))
                    .and_then(|n| n.checked_add(elem));
                if needed.is_none_or(|n| n > bytes.len()) {
                    return Err(Error::scene(
                        self.name,
                        format!("accessor {index} runs past the end of its bufferView"),
                    ));
                }
                let mut packed = Vec::with_capacity(count * elem);
                for i in 0..count {
                    packed.extend_from_slice(&bytes[offset + i * stride..offset + i * stride + elem]);
                }
                packed
            }
        };
        if let Some(sparse) = &a.sparse {
            self.substitute_sparse(index, sparse, elem, &mut packed)?;
        }
        Ok((ct, packed))
    }

    /// Overwrites the elements of accessor `index` (`packed`, `elem` bytes
    /// each) that its sparse part lists.
    fn substitute_sparse(
        &mut self,
        index: usize,
        sparse: &json::accessor::sparse::Sparse,
        elem: usize,
        packed: &mut [u8],
    ) -> Result<()> {
        let count = packed.len() / elem;
        let n = sparse.count.0 as usize;
        if n == 0 || n > count {
            return Err(self.err(format!(
                "accessor {index}: sparse count {n} is not in 1..={count}"
            )));
        }
        let ict = checked(&sparse.indices.component_type)
            .ok_or_else(|| self.err(format!("accessor {index}: invalid sparse index type")))?
            .0;
        let ranges = [
            (&sparse.indices.buffer_view, sparse.indices.byte_offset.0, ict.size()),
            (&sparse.values.buffer_view, sparse.values.byte_offset.0, elem),
        ];
        let name = self.name;
        let mut read = Vec::with_capacity(2);
        for (view, offset, size) in ranges {
            let (bytes, _) = self.view(view.value())?;
            let range = (offset as usize)..(offset as usize).saturating_add(n * size);
            let chunk = bytes.get(range).ok_or_else(|| {
                Error::scene(
                    name,
                    format!("accessor {index}: sparse data runs past the end of its bufferView"),
                )
            })?;
            read.push(chunk.to_vec());
        }
        for (k, value) in read[1].chunks_exact(elem).enumerate() {
            let at = &read[0][k * ict.size()..(k + 1) * ict.size()];
            let i = match ict {
                ComponentType::U8 => at[0] as usize,
                ComponentType::U16 => u16::from_le_bytes([at[0], at[1]]) as usize,
                _ => u32::from_le_bytes([at[0], at[1], at[2], at[3]]) as usize,
            };
            let target = packed.get_mut(i * elem..(i + 1) * elem).ok_or_else(|| {
                Error::scene(
                    self.name,
                    format!("accessor {index}: sparse index {i} out of range ({count} elements)"),
                )
            })?;
            target.copy_from_slice(value);
        }
        Ok(())
    }

    /// Attribute data as floats, flattened: float, or integers (signed or
    /// unsigned, 8 or 16 bits) normalized or not, as the core specification
    /// and `KHR_mesh_quantization` allow them (a node's transform then
    /// usually scales quantized positions back).
    fn read_floats(&mut self, index: usize, components: usize) -> Result<Vec<f32>> {
        let normalized = self
            .root
            .accessors
            .get(index)
            .map(|a| a.normalized)
            .unwrap_or(false);
        let (ct, packed) = self.accessor_elements(index, components)?;
        let mut out = Vec::with_capacity(packed.len() / ct.size());
        for c in packed.chunks_exact(ct.size()) {
            // Signed normalized values map -max and -max - 1 both to -1.
            let scaled = |v: f32, max: f32| if normalized { (v / max).max(-1.0) } else { v };
            let v = match ct {
                ComponentType::F32 => f32::from_le_bytes([c[0], c[1], c[2], c[3]]),
                ComponentType::U8 => scaled(c[0] as f32, 255.0),
                ComponentType::I8 => scaled(c[0] as i8 as f32, 127.0),
                ComponentType::U16 => scaled(u16::from_le_bytes([c[0], c[1]]) as f32, 65535.0),
                ComponentType::I16 => scaled(i16::from_le_bytes([c[0], c[1]]) as f32, 32767.0),
                ComponentType::U32 => {
                    return Err(self.err(format!(
                        "accessor {index}: component type {ct:?} not supported here"
                    )))
                }
            };
            if !v.is_finite() {
                return Err(self.err(format!("accessor {index} holds a non-finite number")));
            }
            out.push(v);
        }
        Ok(out)
    }

    /// COLOR_0 of mesh `mesh` primitive `pi` (accessor `index`): RGB or
    /// RGBA, float or normalized integers, as RGBA. Floats outside [0, 1]
    /// are clamped, with a warning.
    fn read_colors(&mut self, index: usize, mesh: usize, pi: usize) -> Result<Vec<Vec4>> {
        let components = match self.root.accessors.get(index).map(|a| checked(&a.type_)) {
            Some(Some(Type::Vec3)) => 3,
            Some(Some(Type::Vec4)) => 4,
            Some(_) => {
                return Err(self.err(format!(
                    "mesh {mesh} primitive {pi}: COLOR_0 must be VEC3 or VEC4"
                )))
            }
            None => return Err(self.err(format!("accessor index {index} out of range"))),
        };
        let raw = self.read_floats(index, components)?;
        let colors: Vec<Vec4> = raw
            .chunks_exact(components)
            .map(|c| Vec4::new(c[0], c[1], c[2], c.get(3).copied().unwrap_or(1.0)))
            .collect();
        if colors.iter().any(|c| c.min_element() < 0.0 || c.max_element() > 1.0) {
            log::warn!(
                "{}: mesh {mesh} primitive {pi}: COLOR_0 values outside [0, 1] are clamped",
                self.name
            );
        }
        Ok(colors
            .into_iter()
            .map(|c| c.clamp(Vec4::ZERO, Vec4::ONE))
            .collect())
    }

    /// Index data (u8, u16 or u32).
    fn read_indices(&mut self, index: usize) -> Result<Vec<u32>> {
        let (ct, packed) = self.accessor_elements(index, 1)?;
        packed
            .chunks_exact(ct.size())
            .map(|e| match ct {
                ComponentType::U8 => Ok(e[0] as u32),
                ComponentType::U16 => Ok(u16::from_le_bytes([e[0], e[1]]) as u32),
                ComponentType::U32 => Ok(u32::from_le_bytes([e[0], e[1], e[2], e[3]])),
                _ => Err(self.err(format!(
                    "accessor {index}: indices must be unsigned integers"
                ))),
            })
            .collect()
    }

    /// Decodes texture `index` into the scene (once) and returns its slot.
    fn texture(
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

/// The media type of a `data:` URI, if any.
fn data_uri_media_type(uri: &str) -> Option<String> {
    let rest = uri.strip_prefix("data:")?;
    let media = rest.split([';', ',']).next()?;
    (!media.is_empty()).then(|| media.to_string())
}

/// Names common image formats from their first bytes (for the error).
fn sniff_image_format(bytes: &[u8]) -> Option<&'static str> {
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

/// Triangle list indices for a triangle list, strip or fan.
fn triangulate(mode: json::mesh::Mode, idx: &[u32]) -> Vec<u32> {
    use json::mesh::Mode;
    match mode {
        Mode::TriangleStrip => (2..idx.len())
            .flat_map(|i| {
                if i % 2 == 0 {
                    [idx[i - 2], idx[i - 1], idx[i]]
                } else {
                    [idx[i - 1], idx[i - 2], idx[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..idx.len())
            .flat_map(|i| [idx[0], idx[i - 1], idx[i]])
            .collect(),
        _ => idx[..idx.len() / 3 * 3].to_vec(),
    }
}
