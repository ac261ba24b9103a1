//! A scene that stays resident between frames: the host edits it through
//! small calls that mark what changed, and [`crate::Renderer::render_resident`]
//! redoes only the work those changes require.
//!
//! | change | redone |
//! |---|---|
//! | camera | the screen-space passes (nothing on the CPU) |
//! | lights | VPL tracing, shadow-map and ISM data, the passes |
//! | materials | GPU scene copy, BVH (alpha masks), VPLs, ISM points |
//! | objects moved, shown, hidden ([`ResidentScene::set_transform`], [`ResidentScene::set_visible`]) | the BVH's top level, the objects' transforms on the GPU, VPL tracing (keeping the light paths and ISM rays that pass nowhere near the objects), the passes; ISM points move with their objects; meshes stay uploaded |
//! | objects added or removed ([`ResidentScene::add_object`], [`ResidentScene::remove_object`]) | as a move, and the ISM points are sampled again |
//! | meshes, textures ([`ResidentScene::edit`]) | everything |
//!
//! Frames also keep a temporal history of the indirect light (a running
//! mean that converges while nothing moves, reprojected when the camera
//! does; see [`HistorySettings`](crate::settings::HistorySettings)).
//!
//! Nothing else is rebuilt, and the renderer's images, buffers and
//! descriptor pools are reused until the size or settings change.
//!
//! ```no_run
//! # fn main() -> ssbc::Result<()> {
//! use ssbc::resident::ResidentScene;
//! use ssbc::scene::Camera;
//! let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig::default())?;
//! let mut scene = ssbc::scene::load("cornell")?;
//! scene.ensure_light();
//! let mut resident = ResidentScene::new(scene)?;
//! let settings = ssbc::RenderSettings::new(640, 480);
//! for i in 0..10 {
//!     let eye = glam::Vec3::new(0.1 * i as f32, 1.0, 3.0);
//!     resident.set_camera(Camera::look_at(eye, glam::Vec3::new(0.0, 1.0, 0.0), 0.8));
//!     // A camera move: no VPL tracing, no ISM points rebuilt on the CPU.
//!     let frame = renderer.render_resident(&resident, &settings)?;
//!     println!("frame {i}: {:?} ms on the GPU", frame.timings.frame_gpu_ms);
//! }
//! # Ok(()) }
//! ```

use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{Error, Result};
use crate::scene::{Camera, Light, Material, Object, Scene};

static NEXT_VERSION: AtomicU64 = AtomicU64::new(1);

/// A version number unique in the process (so versions of different scenes
/// never compare equal).
pub(crate) fn next_version() -> u64 {
    NEXT_VERSION.fetch_add(1, Ordering::Relaxed)
}

/// Versions of a scene's parts: a part's version changes whenever it does.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SceneVersions {
    /// Meshes, textures, the list of objects.
    pub geometry: u64,
    /// Objects' transforms and visibility.
    pub objects: u64,
    /// Materials.
    pub materials: u64,
    /// Lights.
    pub lights: u64,
    /// Cameras.
    pub camera: u64,
    /// Temporal history: changes when the host cuts it
    /// ([`ResidentScene::reset_history`]).
    pub history: u64,
}

impl SceneVersions {
    /// Fresh versions for every part (nothing cached matches).
    pub fn fresh() -> Self {
        Self {
            geometry: next_version(),
            objects: next_version(),
            materials: next_version(),
            lights: next_version(),
            camera: next_version(),
            history: next_version(),
        }
    }
}

/// A scene kept between frames, with change tracking.
pub struct ResidentScene {
    scene: Scene,
    versions: SceneVersions,
}

impl ResidentScene {
    /// Takes `scene` (validated here once, not every frame).
    pub fn new(scene: Scene) -> Result<Self> {
        scene.validate()?;
        Ok(Self {
            scene,
            versions: SceneVersions::fresh(),
        })
    }

    /// The scene as it is now.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The current versions (what a renderer compares with its caches).
    pub fn versions(&self) -> SceneVersions {
        self.versions
    }

    /// Replaces the camera frames use (the scene's first camera).
    pub fn set_camera(&mut self, camera: Camera) {
        match self.scene.cameras.first_mut() {
            Some(c) => *c = camera,
            None => self.scene.cameras.push(camera),
        }
        self.versions.camera = next_version();
    }

    /// Cuts the temporal history: the next frame starts anew, as after a
    /// change of geometry, but redoes only the screen-space work (for a
    /// cut in a sequence, or to compare frames without history).
    pub fn reset_history(&mut self) {
        self.versions.history = next_version();
    }

    /// Replaces light `index` (position, direction, intensity, kind).
    pub fn set_light(&mut self, index: usize, light: Light) -> Result<()> {
        let count = self.scene.lights.len();
        let slot = self.scene.lights.get_mut(index).ok_or_else(|| {
            Error::InvalidParameter(format!("no light {index} (the scene has {count})"))
        })?;
        *slot = light;
        self.check_lights()?;
        self.versions.lights = next_version();
        Ok(())
    }

    /// Replaces every light.
    pub fn set_lights(&mut self, lights: Vec<Light>) -> Result<()> {
        let old = std::mem::replace(&mut self.scene.lights, lights);
        if let Err(e) = self.check_lights() {
            self.scene.lights = old;
            return Err(e);
        }
        self.versions.lights = next_version();
        Ok(())
    }

    fn check_lights(&self) -> Result<()> {
        for (i, l) in self.scene.lights.iter().enumerate() {
            let finite =
                l.position.is_finite() && l.direction.is_finite() && l.intensity.is_finite();
            if !finite || l.intensity.min_element() < 0.0 {
                return Err(Error::InvalidParameter(format!(
                    "light {i} has a non-finite or negative value"
                )));
            }
        }
        Ok(())
    }

    /// Replaces material `index` (parameters and texture references; the
    /// textures themselves are geometry: see [`ResidentScene::edit`]).
    pub fn set_material(&mut self, index: usize, material: Material) -> Result<()> {
        let count = self.scene.materials.len();
        let slot = self.scene.materials.get_mut(index).ok_or_else(|| {
            Error::InvalidParameter(format!("no material {index} (the scene has {count})"))
        })?;
        let old = std::mem::replace(slot, material);
        if let Err(e) = self.scene.validate() {
            self.scene.materials[index] = old;
            return Err(e);
        }
        self.versions.materials = next_version();
        Ok(())
    }

    /// Moves object `index` to `transform` (object to world; finite and
    /// invertible). The next frame rebuilds the BVH's top level, writes the
    /// objects' transforms and traces VPLs again; nothing is uploaded but
    /// the transforms and VPLs, no resource is created.
    /// Setting the transform an object has is no change (engines set
    /// every transform every frame).
    pub fn set_transform(&mut self, index: usize, transform: glam::Mat4) -> Result<()> {
        if self.scene.object(index)?.transform != transform {
            self.scene.set_transform(index, transform)?;
            self.versions.objects = next_version();
        }
        Ok(())
    }

    /// Shows or hides object `index` (as cheap as a move; a hidden object's
    /// ISM points are skipped, not redistributed).
    pub fn set_visible(&mut self, index: usize, visible: bool) -> Result<()> {
        if self.scene.object(index)?.visible != visible {
            self.scene.set_visible(index, visible)?;
            self.versions.objects = next_version();
        }
        Ok(())
    }

    /// Adds an object drawing one of the scene's meshes. The meshes stay
    /// as they are (their BVHs and GPU copies are kept): the next frame
    /// rebuilds the BVH's top level, samples the ISM points again and
    /// traces VPLs again.
    pub fn add_object(&mut self, object: Object) -> Result<usize> {
        let index = self.scene.add_object(object)?;
        self.versions.objects = next_version();
        Ok(index)
    }

    /// Removes object `index` (later objects move down by one); as cheap as
    /// adding one. A scene needs a visible triangle left.
    pub fn remove_object(&mut self, index: usize) -> Result<Object> {
        let visible_left = self.scene.objects().iter().enumerate().any(|(i, o)| {
            i != index && o.visible && !self.scene.meshes()[o.mesh].indices.is_empty()
        });
        if index < self.scene.objects().len() && !visible_left {
            return Err(Error::InvalidParameter(format!(
                "removing object {index} would leave the scene without triangles"
            )));
        }
        let removed = self.scene.remove_object(index)?;
        self.versions.objects = next_version();
        Ok(removed)
    }

    /// Any other change (meshes, textures, objects' materials): everything
    /// is redone on the next frame. The
    /// scene is validated after `f`; on an error it is left as `f` made it
    /// but every part is marked changed, and frames refuse it until fixed.
    pub fn edit<T>(&mut self, f: impl FnOnce(&mut Scene) -> T) -> Result<T> {
        let value = f(&mut self.scene);
        self.versions = SceneVersions::fresh();
        self.scene.validate()?;
        Ok(value)
    }
}
