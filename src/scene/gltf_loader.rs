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

mod accessors;
mod materials;
mod meshes;
mod nodes;

use materials::{follow_texture_transform, MaterialUvMaps};

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
        // What the file made must render (geometry within MAX_COORDINATE,
        // ...): a default light is placed by ray casts before any frame.
        scene.validate()?;
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

}

