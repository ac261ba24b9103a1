//! Which history a resident frame reads and how it folds in (see
//! [`HistorySettings`](crate::settings::HistorySettings)): the renderer
//! compares the frame with the last one that wrote history.

use glam::Mat4;

use crate::passes::temporal::HistoryStep;
use crate::resident::SceneVersions;
use crate::scene::{Camera, Light, Scene};
use crate::settings::RenderSettings;

/// What changed since the last history frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Motion {
    /// No usable history: the first frame, a cut, other surfaces,
    /// materials or settings.
    Reset,
    /// Lights changed or objects moved (perhaps the camera too): the same
    /// light paths in the changed scene; pixels whose surface moved start
    /// anew (the reprojection's surface test), the others keep a few
    /// frames where the indirect light changed little.
    Lights,
    /// Only the camera.
    Camera,
    /// Nothing: the frame adds an independent VPL set.
    Still,
}

/// The last frame that wrote history.
struct LastFrame {
    slot: usize,
    versions: SceneVersions,
    /// Its settings as the host gave them (before the light-path offset).
    settings: RenderSettings,
    /// Its camera and lights: a host that sets the same ones again (a new
    /// version) has not moved them.
    cameras: Vec<Camera>,
    lights: Vec<Light>,
    view_proj: Mat4,
    /// Its eye.
    camera: glam::Vec3,
    /// Light paths its VPLs took.
    light_paths: u64,
}

/// The renderer's history bookkeeping.
#[derive(Default)]
pub(super) struct History {
    last: Option<LastFrame>,
    /// Frames of a still view the history averages (1 after any change).
    accumulated: u32,
    /// Light paths the still view's earlier frames traced: the next frame
    /// starts its paths after them (its own VPL set).
    path_offset: u64,
}

/// How one frame uses history.
#[derive(Clone, Copy, Debug)]
pub(super) struct HistoryPlan {
    pub motion: Motion,
    /// The slot whose history and G-buffer it reads.
    pub previous_slot: Option<usize>,
    /// Added to the VPL settings' `first_path`.
    pub path_offset: u64,
    /// The still view's frame count after this frame.
    pub accumulated: u32,
}

impl History {
    /// Forgets every earlier frame (the next frame starts anew).
    pub fn reset(&mut self) {
        self.last = None;
    }

    /// Frames a still view's history averages (0 before any history frame).
    pub fn accumulated(&self) -> u32 {
        if self.last.is_some() {
            self.accumulated
        } else {
            0
        }
    }

    /// How a frame in `slot` of `scene` at `versions` with `settings` uses
    /// history.
    pub fn plan(
        &self,
        slot: usize,
        (scene, versions): (&Scene, SceneVersions),
        settings: &RenderSettings,
    ) -> HistoryPlan {
        // New versions of equal lights or an equal camera are no change.
        let lights_moved =
            |l: &LastFrame| l.versions.lights != versions.lights && l.lights != scene.lights;
        // A new jitter alone is no move: the reprojection places it.
        let unjittered = |cameras: &[Camera]| {
            cameras
                .iter()
                .map(Camera::without_jitter)
                .collect::<Vec<_>>()
        };
        let camera_moved = |l: &LastFrame| {
            l.versions.camera != versions.camera
                && unjittered(&l.cameras) != unjittered(&scene.cameras)
        };
        let motion = match &self.last {
            None => Motion::Reset,
            Some(last)
                if last.slot == slot
                    || last.versions.geometry != versions.geometry
                    || last.versions.materials != versions.materials
                    || last.versions.history != versions.history
                    || !same_image(&last.settings, settings) =>
            {
                Motion::Reset
            }
            Some(last) if lights_moved(last) || last.versions.objects != versions.objects => {
                Motion::Lights
            }
            Some(last) if camera_moved(last) => Motion::Camera,
            Some(_) => Motion::Still,
        };
        let last = self.last.as_ref().filter(|_| motion != Motion::Reset);
        HistoryPlan {
            motion,
            previous_slot: last.map(|l| l.slot),
            path_offset: match (motion, last) {
                (Motion::Reset, _) | (_, None) => 0,
                (Motion::Still, Some(l)) => self.path_offset.saturating_add(l.light_paths.max(1)),
                (Motion::Camera, Some(l)) if settings.history.new_vpls_while_moving => {
                    self.path_offset.saturating_add(l.light_paths.max(1))
                }
                _ => self.path_offset,
            },
            accumulated: match motion {
                Motion::Still => self.accumulated.saturating_add(1),
                _ => 1,
            },
        }
    }

    /// The fold of a planned frame whose view is `view_proj` from `camera`.
    pub fn step(
        &self,
        plan: &HistoryPlan,
        settings: &RenderSettings,
        (view_proj, camera): (Mat4, glam::Vec3),
    ) -> HistoryStep {
        let h = &settings.history;
        let max_frames = match plan.motion {
            Motion::Reset => 1,
            Motion::Lights => h.light_frames,
            Motion::Camera => h.moving_frames,
            Motion::Still => h.max_frames,
        };
        HistoryStep {
            max_frames,
            light_change: (plan.motion == Motion::Lights).then_some(h.light_change),
            previous_view_proj: self.last.as_ref().map_or(view_proj, |l| l.view_proj),
            previous_camera: self.last.as_ref().map_or(camera, |l| l.camera),
        }
    }

    /// Records a submitted frame that wrote history.
    pub fn commit(
        &mut self,
        plan: &HistoryPlan,
        slot: usize,
        (scene, versions): (&Scene, SceneVersions),
        settings: &RenderSettings,
        (view_proj, camera): (Mat4, glam::Vec3),
        light_paths: u64,
    ) {
        self.accumulated = plan.accumulated;
        self.path_offset = plan.path_offset;
        self.last = Some(LastFrame {
            slot,
            versions,
            settings: settings.clone(),
            cameras: scene.cameras.clone(),
            lights: scene.lights.clone(),
            view_proj,
            camera,
            light_paths,
        });
    }
}

/// Whether two frames' settings make the same image (what a frame reads
/// back or hands out besides does not matter).
fn same_image(a: &RenderSettings, b: &RenderSettings) -> bool {
    let image = |s: &RenderSettings| RenderSettings {
        output_layers: false,
        debug_readback: false,
        ..s.clone()
    };
    image(a) == image(b)
}
