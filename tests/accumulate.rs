//! Progressive refinement: frames with independent VPL sets averaged into
//! one image converge on the path tracer, and the mean of N frames is, within
//! noise, the image of one frame with N times the VPLs.

mod common;

use std::sync::atomic::AtomicBool;

use ssbc::compare::{block_average, compare};
use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::renderer::RenderSettings;
use ssbc::settings::Bound;

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

/// A view that converges clamps less as it averages more VPLs: frame k of
/// an accumulation of 2048-VPL frames takes Auto's b x sqrt(k)
/// (`Bound::Converging`), so less of the light rests on SSBC, and a still
/// view's history frames take the same bounds (it converges where the
/// accumulation does).
#[test]
fn the_bound_grows_as_a_view_converges() {
    let scene = ssbc::scene::load("assets/open-front-box.gltf").unwrap();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut s = settings(ssbc::settings::BOUND_VPLS, false);
    s.output_layers = true;
    let stop = AtomicBool::new(false);
    let four = renderer
        .render_accumulated(&scene, &s, 4, &stop, |_| {})
        .unwrap();
    let one = renderer.render(&scene, &s).unwrap();
    let grown = four.bound / one.bound;
    assert!(
        (grown - 2.0).abs() < 1e-4,
        "the 4th frame's bound is {grown} x Auto's"
    );
    // The same frames (the same VPLs) with Auto's b throughout.
    let mut fixed = s.clone();
    fixed.bound = Bound::Value(one.bound);
    let four_fixed = renderer
        .render_accumulated(&scene, &fixed, 4, &stop, |_| {})
        .unwrap();
    assert_eq!(four_fixed.bound, one.bound);
    // Less light clamped: more of it bounded, less left to SSBC.
    let mean = |f: &ssbc::Frame, layer| {
        let l = f.layer(layer).expect("read back");
        l.rgba
            .iter()
            .enumerate()
            .filter(|(i, _)| i % 4 != 3)
            .map(|(_, v)| *v as f64)
            .sum::<f64>()
    };
    let bounded = ssbc::Layer::IndirectBounded;
    let (grown_bounded, fixed_bounded) = (mean(&four, bounded), mean(&four_fixed, bounded));
    let ratio = compare(&four.image.rgba, &four_fixed.image.rgba)
        .unwrap()
        .mean_ratio;
    eprintln!(
        "4 frames of 2048 VPLs, bound growing / fixed: bounded light {:.4}, final image {ratio:.4}",
        grown_bounded / fixed_bounded
    );
    // Measured 1.0071 (the image 1.0015).
    assert!(
        grown_bounded > 1.003 * fixed_bounded,
        "the bounded light did not grow"
    );
    assert!(
        ratio > 1.0 && ratio < 1.02,
        "the image's mean changed by {ratio}"
    );
    // A still view's frames take the accumulation's bounds.
    let resident = ssbc::resident::ResidentScene::new(scene.clone()).unwrap();
    let mut last = None;
    for _ in 0..4 {
        last = Some(renderer.render_resident(&resident, &s).unwrap());
    }
    let last = last.unwrap();
    assert_eq!(last.accumulated, 4);
    assert_eq!(last.bound, four.bound);
    let d = compare(&last.image.rgba, &four.image.rgba).unwrap();
    assert!(
        d.rel_mse < 1e-8,
        "the still view differs from the accumulation by {}",
        d.rel_mse
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}
