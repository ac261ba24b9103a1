//! Loading scenes: built-in names and glTF files (untrusted input).

use super::*;

/// Loads a scene: a built-in name (`cornell`, `tori`) or a `.gltf`/`.glb`
/// path. glTF files are untrusted input: nothing outside the scene's
/// folder is read, and malformed files are errors, never panics.
///
/// ```
/// let scene = ssbc::scene::load("cornell").unwrap();
/// assert!(scene.triangle_count() > 0);
/// assert!(ssbc::scene::load("/nonexistent.gltf").is_err());
/// ```
pub fn load(name_or_path: &str) -> Result<Scene> {
    if let Some(scene) = builtin::by_name(name_or_path) {
        return Ok(scene);
    }
    gltf_loader::load(existing_file(name_or_path)?, None)
}

/// `name_or_path` as a path that exists (else the error `load` gives).
fn existing_file(name_or_path: &str) -> Result<&std::path::Path> {
    let path = std::path::Path::new(name_or_path);
    if !path.exists() {
        return Err(Error::scene(
            name_or_path,
            format!(
                "no such file, and not a built-in scene ({})",
                builtin::NAMES.join(", ")
            ),
        ));
    }
    Ok(path)
}

/// [`load`] with the file's first glTF animation played to `time` seconds
/// (node translation, rotation and scale; step, linear and cubic-spline
/// keyframes; clamped to the animation's span). Built-in scenes do not
/// move.
///
/// ```
/// let scene = ssbc::scene::load_at("cornell", 1.5).unwrap();
/// assert!(ssbc::scene::load_at("cornell", f32::NAN).is_err());
/// ```
pub fn load_at(name_or_path: &str, time: f32) -> Result<Scene> {
    if !time.is_finite() {
        return Err(Error::InvalidParameter(format!(
            "the animation time {time} is not a finite number"
        )));
    }
    if let Some(scene) = builtin::by_name(name_or_path) {
        return Ok(scene);
    }
    gltf_loader::load(existing_file(name_or_path)?, Some(time))
}

/// Parses a glTF or GLB file already in memory (`name` names it in errors);
/// external buffers and images are looked up in the folder `base`, and
/// nothing outside it is read.
pub fn load_gltf_bytes(name: &str, bytes: &[u8], base: &std::path::Path) -> Result<Scene> {
    gltf_loader::load_guarded(name, bytes, base, None)
}

/// [`load_gltf_bytes`] with the first animation played to `time` (see
/// [`load_at`]).
pub fn load_gltf_bytes_at(
    name: &str,
    bytes: &[u8],
    base: &std::path::Path,
    time: f32,
) -> Result<Scene> {
    gltf_loader::load_guarded(name, bytes, base, Some(time))
}
