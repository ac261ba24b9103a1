//! Progressive refinement: frames with independent VPL sets averaged into
//! one image converge on the path tracer, and the mean of N frames is, within
//! noise, the image of one frame with N times the VPLs.

mod common;

use std::sync::atomic::AtomicBool;

use ssbc::compare::{block_average, compare};
use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::renderer::RenderSettings;

/// `vpls` VPLs with the visibility `render_accumulated` resolves `Auto`
/// to here (exact where the device has ray queries), so that accumulated
/// and single frames compare.
fn settings(vpls: usize, exact: bool) -> RenderSettings {
    let mut s = RenderSettings::new(64, 48);
    s.vpl.count = vpls;
    s.visibility = if exact {
        ssbc::settings::Visibility::Exact
    } else {
        ssbc::settings::Visibility::Ism
    };
    s
}

/// relMSE of `a` against `b` on 4x4 blocks.
fn block_rel_mse(a: &[f32], b: &[f32]) -> f64 {
    compare(&block_average(a, 64, 48, 4), &block_average(b, 64, 48, 4))
        .unwrap()
        .rel_mse
}

#[test]
fn accumulated_frames_converge_like_more_vpls() {
    let scene = ssbc::scene::load("assets/open-front-box.gltf").unwrap();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let exact = renderer.device().ray_queries().is_some();
    let settings = |vpls| settings(vpls, exact);
    let stop = AtomicBool::new(false);
    let mut progress = Vec::new();
    let eight = renderer
        .render_accumulated(&scene, &settings(64), 8, &stop, |k| progress.push(k))
        .unwrap();
    assert_eq!(eight.accumulated, 8);
    assert_eq!(progress, (1..=8).collect::<Vec<_>>());
    let one = renderer
        .render_accumulated(&scene, &settings(64), 1, &stop, |_| {})
        .unwrap();
    // One frame of the same 512 VPLs' worth: the same light paths (the
    // frames continue the sequence), and two with other paths (the noise).
    let mut single = |seed| {
        let mut s = settings(512);
        s.vpl.seed = seed;
        ssbc::Renderer::render(&mut renderer, &scene, &s).unwrap()
    };
    let (same, a, b) = (single(0), single(100), single(200));
    let truth = Reference::new(
        &scene,
        ReferenceSettings {
            width: 64,
            height: 48,
            spp: 256,
            ..Default::default()
        },
    )
    .unwrap()
    .render(&AtomicBool::new(false), |_| {})
    .0;
    let err = |f: &ssbc::Frame| block_rel_mse(&f.image.rgba, &truth);
    let (e1, e8) = (err(&one), err(&eight));
    let noise = block_rel_mse(&a.image.rgba, &b.image.rgba);
    let between = block_rel_mse(&eight.image.rgba, &same.image.rgba);
    let mean = compare(&eight.image.rgba, &same.image.rgba)
        .unwrap()
        .mean_ratio;
    eprintln!(
        "relMSE(4x4) vs path tracer: 1 frame of 64 VPLs {e1:.4}, 8 frames {e8:.4} ({} VPLs); \
         8 frames vs one frame of the same light paths {between:.5} (two frames of 512 VPLs \
         on other paths: {noise:.4}), mean ratio {mean:.4}",
        eight.vpls.len()
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
    assert!(e8 < 0.7 * e1, "8 frames did not converge: {e1} -> {e8}");
    assert!((mean - 1.0).abs() < 0.01, "mean ratio {mean}");
    // Not 0: each frame thins its own few VPLs past the count (measured
    // 0.00073 against 0.0030).
    assert!(
        between < 0.5 * noise,
        "8 frames of 64 VPLs differ from one frame of their 512 by {between}, \
         against {noise} between independent frames"
    );
}
