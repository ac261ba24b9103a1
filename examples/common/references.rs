//! What the temporal examples (flicker, pan) share: path-traced references
//! kept on disk, and the indirect light's error on 4x4 blocks.

use std::sync::atomic::AtomicBool;

use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::{Frame, Scene};

/// A fixed-seed path tracing of `scene` (`bounces` 0: direct light only),
/// read from `path` if it is there at this size, else rendered and written.
pub fn reference(scene: &Scene, size: (u32, u32), spp: u32, bounces: u32, path: &str) -> Vec<f32> {
    if let Ok((w, h, rgba)) = ssbc::output::read_exr_rgb(path.as_ref()) {
        if (w, h) == size {
            return rgba;
        }
    }
    let settings = ReferenceSettings {
        width: size.0,
        height: size.1,
        spp,
        bounces,
        seed: 7,
        ..Default::default()
    };
    let r = Reference::new(scene, settings).expect("reference");
    let (rgba, _) = r.render(&AtomicBool::new(false), |_| {});
    ssbc::output::write_exr(path.as_ref(), size.0, size.1, &rgba, &[]).expect("write");
    rgba
}

/// `a - b`, element by element.
pub fn minus(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// A frame's indirect light: the final image minus the direct light.
pub fn indirect(frame: &Frame) -> Vec<f32> {
    let direct = &frame.layer(ssbc::Layer::Direct).expect("layer").rgba;
    minus(&frame.image.rgba, direct)
}

/// mean |a - t| / mean t on 4x4 blocks (RGB mean).
pub fn block_error(a: &[f32], t: &[f32], size: (u32, u32)) -> f64 {
    let (a, t) = (
        ssbc::compare::block_average(a, size.0, size.1, 4),
        ssbc::compare::block_average(t, size.0, size.1, 4),
    );
    let rgb = |v: &[f32], i: usize| (v[i * 4] + v[i * 4 + 1] + v[i * 4 + 2]) as f64 / 3.0;
    let n = a.len() / 4;
    let err: f64 = (0..n).map(|i| (rgb(&a, i) - rgb(&t, i)).abs()).sum();
    let sum: f64 = (0..n).map(|i| rgb(&t, i).abs()).sum();
    err / sum.max(1e-30)
}
