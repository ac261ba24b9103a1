//! Progressive refinement of a still view: frames with independent VPL sets
//! (each frame the next light paths of the same sequence, so their own ISMs
//! and interleaving) averaged into one image. The direct light is the same in every frame;
//! the indirect light (bounded + SSBC's residual) is the running mean, an
//! estimate with the union of the VPL sets, each VPL's flux divided by the
//! number of frames.

use crate::error::{Error, Result};
use crate::resident::ResidentScene;
use crate::scene::Scene;
use crate::settings::{RenderSettings, Visibility};
use crate::vk::Device;

use super::limits::{self, FrameUse};
use super::sink::ReadBack;
use super::{Frame, Renderer};

impl Renderer {
    /// Renders `frames` frames of `scene`, each tracing the light paths that
    /// follow the previous frame's ([`VplSettings::first_path`](crate::settings::VplSettings::first_path)),
    /// and returns their mean: every layer averaged (G-buffer
    /// layers are the same in each), the VPLs of all frames with their flux
    /// divided by `frames`, the last frame's timings, ISM atlas and bound.
    /// Where the bound is [`Bound::Auto`](crate::settings::Bound::Auto),
    /// later frames clamp less ([`Bound::converging`](crate::settings::Bound::converging)).
    /// `progress(k)` is called after frame k (1-based); `cancel` stops after
    /// the frame in flight and returns the mean so far.
    ///
    /// ```no_run
    /// # fn main() -> ssbc::Result<()> {
    /// let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig::default())?;
    /// let scene = ssbc::scene::load("cornell")?;
    /// let settings = ssbc::RenderSettings::new(320, 240);
    /// let stop = std::sync::atomic::AtomicBool::new(false);
    /// let frame = renderer.render_accumulated(&scene, &settings, 16, &stop, |k| eprint!("{k} "))?;
    /// assert!(frame.accumulated <= 16);
    /// # Ok(()) }
    /// ```
    pub fn render_accumulated(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        frames: u32,
        cancel: &std::sync::atomic::AtomicBool,
        mut progress: impl FnMut(u32),
    ) -> Result<Frame> {
        if frames == 0 {
            return Err(Error::InvalidParameter(
                "accumulated frames must be at least 1".into(),
            ));
        }
        // Resident: the BVH, the scene's GPU copy and the ISM points are
        // made once; each frame traces its own VPLs.
        let resident = ResidentScene::new(scene.clone())?;
        let mut settings = settings.clone();
        // The mean is taken here, of frames that stand alone.
        settings.history.enabled = false;
        if settings.visibility == Visibility::Auto {
            let uses = FrameUse::of::<ReadBack>(false, true, scene);
            resolve_converging(self.device(), scene, &mut settings, uses, true);
        }
        let mut sum: Option<Frame> = None;
        let bound = settings.bound;
        for k in 0..frames {
            settings.bound = bound.converging(k + 1, settings.vpl.count);
            let frame = self.render_resident(&resident, &settings)?;
            settings.vpl.first_path = settings
                .vpl
                .first_path
                .saturating_add(frame.timings.light_paths.max(1));
            sum = Some(match sum {
                None => frame,
                Some(mut sum) => {
                    add_frame(&mut sum, frame);
                    sum
                }
            });
            progress(k + 1);
            if cancel.load(std::sync::atomic::Ordering::Relaxed) {
                break;
            }
        }
        let mut mean = sum.expect("at least one frame");
        let n = mean.accumulated as f32;
        for layer in std::iter::once(&mut mean.image).chain(&mut mean.layers) {
            for (i, v) in layer.rgba.iter_mut().enumerate() {
                // Alpha (geometry coverage) is the same in every frame.
                if i % 4 != 3 {
                    *v /= n;
                }
            }
        }
        for samples in &mut mean.samples {
            samples.iter_mut().for_each(|v| *v /= n);
        }
        for vpl in &mut mean.vpls {
            vpl.flux /= n;
        }
        Ok(mean)
    }
}

/// Adds `frame`'s layers, samples and VPLs to `sum` (the last frame's
/// timings, atlas and bound replace the earlier ones).
fn add_frame(sum: &mut Frame, frame: Frame) {
    let layers = std::iter::once(&mut sum.image).chain(&mut sum.layers);
    for (a, b) in layers.zip(std::iter::once(&frame.image).chain(&frame.layers)) {
        debug_assert_eq!(a.layer, b.layer);
        for (i, (x, y)) in a.rgba.iter_mut().zip(&b.rgba).enumerate() {
            if i % 4 != 3 {
                *x += y;
            }
        }
    }
    for (a, b) in sum.samples.iter_mut().zip(&frame.samples) {
        a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
    }
    sum.vpls.extend(frame.vpls);
    sum.timings = frame.timings;
    sum.ism = frame.ism;
    sum.bound = frame.bound;
    sum.accumulated += 1;
}

/// [`Visibility::Auto`] for frames that converge (an accumulation's, a
/// still view's history frames) of `scene` on `device`, used as `uses`
/// says: exact visibility where possible, else, with `isms`, the ISMs of
/// [`RenderSettings::resolve_auto_for_convergence`] (finer where the
/// device's limits and memory take them); else unchanged.
pub(super) fn resolve_converging(
    device: &Device,
    scene: &Scene,
    settings: &mut RenderSettings,
    uses: FrameUse,
    isms: bool,
) {
    let exact = crate::ray_scene::exact_visibility_possible(device, scene);
    if !exact && !isms {
        return;
    }
    let fits = !exact && {
        let mut finer = settings.clone();
        finer.resolve_auto_for_convergence(false, true);
        limits::check_settings(device, &finer, scene.lights.len(), uses).is_ok()
    };
    settings.resolve_auto_for_convergence(exact, fits);
}
