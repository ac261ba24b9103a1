//! Headless sequences: one frame per entry of a JSON file, each changing the
//! camera and lights of a [`ResidentScene`] before it is rendered, so that
//! temporal behaviour (history, flicker, lag) can be rendered and checked
//! without a window (`ssbc render SCENE --sequence SEQ.json`).
//!
//! ```json
//! {"frames": [
//!   {"camera": {"position": [0, 1, 3], "target": [0, 1, 0]}},
//!   {"lights": {"0": {"position": [0.1, 1.9, 0]}}},
//!   {"lights": {"0": {"intensity": [0, 0, 0]}}, "time": 0.5}
//! ]}
//! ```
//!
//! Every key is optional and a frame changes only what it names (the rest
//! stays as the frame before left it). A camera's position alone moves the
//! eye and keeps the view direction; its target alone turns the camera. A
//! light is named by its index in the scene; `position`, `direction`
//! (spots, directional lights) and `intensity` (W/sr, or W/m² for
//! directional lights, per channel) replace its own. `time` (seconds) plays
//! the scene file's first glTF animation to that time: the renderer reloads
//! the meshes at that pose (all of the scene's work is redone, and history
//! starts anew; lights and cameras keep what the sequence set).
//!
//! ```
//! let seq = ssbc::sequence::Sequence::parse(
//!     r#"{"frames": [{}, {"lights": {"0": {"position": [0, 1.8, 0]}}}]}"#,
//! ).unwrap();
//! assert_eq!(seq.len(), 2);
//! let mut scene = ssbc::scene::load("cornell").unwrap();
//! scene.ensure_light();
//! let mut resident = ssbc::resident::ResidentScene::new(scene).unwrap();
//! seq.apply(1, &mut resident).unwrap();
//! assert_eq!(resident.scene().lights[0].position.y, 1.8);
//! ```

use std::collections::BTreeMap;
use std::path::Path;

use glam::Vec3;
use serde::Deserialize;

use crate::error::{Error, Result};
use crate::resident::ResidentScene;
use crate::scene::Camera;

/// Most frames a sequence may hold.
pub const MAX_FRAMES: usize = 100_000;
/// Largest sequence file read (bytes).
const MAX_FILE_BYTES: u64 = 64 << 20;

/// A parsed sequence.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sequence {
    frames: Vec<SequenceFrame>,
}

/// What one frame changes.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct SequenceFrame {
    #[serde(default)]
    camera: Option<CameraChange>,
    #[serde(default)]
    lights: BTreeMap<String, LightChange>,
    #[serde(default)]
    time: Option<f64>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraChange {
    position: Option<[f32; 3]>,
    target: Option<[f32; 3]>,
}

#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightChange {
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    intensity: Option<[f32; 3]>,
}

fn vector(v: [f32; 3], what: &str, frame: usize) -> Result<Vec3> {
    let v = Vec3::from(v);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(Error::InvalidParameter(format!(
            "sequence frame {frame}: {what} is not finite"
        )))
    }
}

impl Sequence {
    /// Reads and checks a sequence file.
    pub fn load(path: impl AsRef<Path>) -> Result<Self> {
        let path = path.as_ref();
        let io = |e: std::io::Error| Error::io(path, e);
        let size = std::fs::metadata(path).map_err(io)?.len();
        if size > MAX_FILE_BYTES {
            return Err(Error::InvalidParameter(format!(
                "{}: a sequence file of {size} bytes (at most {MAX_FILE_BYTES})",
                path.display()
            )));
        }
        let text = std::fs::read_to_string(path).map_err(io)?;
        Self::parse(&text).map_err(|e| Error::InvalidParameter(format!("{}: {e}", path.display())))
    }

    /// Parses and checks a sequence from JSON text.
    pub fn parse(text: &str) -> Result<Self> {
        let seq: Sequence = serde_json::from_str(text)
            .map_err(|e| Error::InvalidParameter(format!("sequence: {e}")))?;
        if seq.frames.is_empty() || seq.frames.len() > MAX_FRAMES {
            return Err(Error::InvalidParameter(format!(
                "sequence: {} frames (1 to {MAX_FRAMES})",
                seq.frames.len()
            )));
        }
        for (k, f) in seq.frames.iter().enumerate() {
            for name in f.lights.keys() {
                name.parse::<usize>().map_err(|_| {
                    Error::InvalidParameter(format!(
                        "sequence frame {k}: lights are named by index, not '{name}'"
                    ))
                })?;
            }
            if let Some(t) = f.time {
                if !t.is_finite() {
                    return Err(Error::InvalidParameter(format!(
                        "sequence frame {k}: time {t} is not finite"
                    )));
                }
            }
        }
        Ok(seq)
    }

    /// Number of frames.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    /// Always false (a sequence has at least one frame).
    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The animation time frame `k` names, if any.
    pub fn time(&self, k: usize) -> Option<f64> {
        self.frames.get(k).and_then(|f| f.time)
    }

    /// Applies frame `k`'s changes to `scene` (only what it names; a frame
    /// that names nothing leaves the scene, and its history, as it was).
    pub fn apply(&self, k: usize, scene: &mut ResidentScene) -> Result<()> {
        let frame = self.frames.get(k).ok_or_else(|| {
            Error::InvalidParameter(format!("sequence frame {k} of {}", self.frames.len()))
        })?;
        if let Some(change) = &frame.camera {
            let current = scene.scene().camera(None)?;
            let eye = match change.position {
                Some(p) => vector(p, "camera position", k)?,
                None => current.position,
            };
            let target = match change.target {
                Some(t) => vector(t, "camera target", k)?,
                None => eye + current.forward,
            };
            if (target - eye).length() <= 1e-6 * eye.length().max(1.0) {
                return Err(Error::InvalidParameter(format!(
                    "sequence frame {k}: the camera's target is its position"
                )));
            }
            let mut camera = Camera::look_at(eye, target, current.yfov);
            if change.target.is_none() {
                // Only moved: keep the camera's roll as well.
                camera.forward = current.forward;
                camera.up = current.up;
            }
            scene.set_camera(camera);
        }
        for (name, change) in &frame.lights {
            let index: usize = name.parse().expect("checked by parse");
            let count = scene.scene().lights.len();
            let mut light = scene.scene().lights.get(index).cloned().ok_or_else(|| {
                Error::InvalidParameter(format!(
                    "sequence frame {k}: no light {index} (the scene has {count})"
                ))
            })?;
            if let Some(p) = change.position {
                light.position = vector(p, "light position", k)?;
            }
            if let Some(d) = change.direction {
                light.direction = vector(d, "light direction", k)?
                    .try_normalize()
                    .ok_or_else(|| {
                        Error::InvalidParameter(format!(
                            "sequence frame {k}: light {index}'s direction is zero"
                        ))
                    })?;
            }
            if let Some(i) = change.intensity {
                light.intensity = vector(i, "light intensity", k)?;
            }
            scene.set_light(index, light)?;
        }
        Ok(())
    }
}
