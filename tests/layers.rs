//! A frame's layers are what its passes offer: the read-back order, the
//! indirect-light pass (`Layer::Indirect`, `Final - Direct`) made only when
//! a frame hands out every output or asks for it on the GPU, and the same
//! image in a host's command buffer as read back.

mod common;

use ssbc::resident::ResidentScene;
use ssbc::Layer;

fn rgba(frame: &ssbc::Frame, layer: Layer) -> &[f32] {
    &frame
        .layer(layer)
        .unwrap_or_else(|| panic!("{layer} read back"))
        .rgba
}

/// Largest absolute difference of the RGB channels, over the largest value.
fn relative_difference(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    let rgb = |v: &[f32]| -> Vec<f32> { v.chunks(4).flat_map(|p| p[..3].to_vec()).collect() };
    let (a, b) = (rgb(a), rgb(b));
    let peak = b.iter().fold(0f32, |m, v| m.max(v.abs()));
    let worst = a
        .iter()
        .zip(&b)
        .fold(0f32, |m, (x, y)| m.max((x - y).abs()));
    worst / peak
}

#[test]
fn a_frame_reads_back_the_layers_its_passes_offer() {
    let mut scene = ssbc::scene::load("cornell").unwrap();
    scene.ensure_light();
    let mut s = common::tiny_settings();
    s.ssbc.layers = 2;
    s.debug_readback = true;
    let frame = common::render_validated(&scene, &s);
    let read: Vec<String> = std::iter::once(&frame.image)
        .chain(&frame.layers)
        .map(|l| l.layer.to_string())
        .collect();
    let expected = [
        "final",
        "direct",
        "indirect_bounded",
        "residual_1",
        "residual_2",
        "indirect",
        "gbuffer_position",
        "gbuffer_normal",
        "gbuffer_albedo",
        "gbuffer_emission",
        "sources",
        "layer1_position",
        "layer1_normal",
        "layer1_albedo",
        "layer1_sources",
    ];
    assert_eq!(read, expected);
    // Without output layers only the final image.
    s.debug_readback = false;
    s.output_layers = false;
    let frame = common::render_validated(&scene, &s);
    assert!(frame.layers.is_empty());
    assert!(frame.layer(Layer::Indirect).is_none());
}

/// The indirect layer is the final image less the direct light, and the
/// sum of the bounded VPL light and every step's residual.
#[test]
fn the_indirect_layer_is_final_less_direct() {
    let mut scene = ssbc::scene::load("cornell").unwrap();
    scene.ensure_light();
    let s = common::tiny_settings();
    let frame = common::render_validated(&scene, &s);
    let indirect = rgba(&frame, Layer::Indirect);
    let (fin, direct) = (rgba(&frame, Layer::Final), rgba(&frame, Layer::Direct));
    let less: Vec<f32> = fin.iter().zip(direct).map(|(f, d)| f - d).collect();
    let d = relative_difference(indirect, &less);
    assert!(d < 1e-6, "indirect vs final - direct: {d}");
    let parts = [
        Layer::IndirectBounded,
        Layer::Residual(1),
        Layer::Residual(2),
    ];
    let mut sum = vec![0f32; indirect.len()];
    for part in parts {
        for (t, v) in sum.iter_mut().zip(rgba(&frame, part)) {
            *t += v;
        }
    }
    let d = relative_difference(indirect, &sum);
    assert!(d < 1e-5, "indirect vs bounded + residuals: {d}");
    // Cornell's walls are lit indirectly everywhere: some of every channel.
    for c in 0..3 {
        let mean = indirect.chunks(4).map(|p| p[c]).sum::<f32>() / (64.0 * 48.0);
        assert!(mean > 0.0, "channel {c}: mean {mean}");
    }
    // Alpha is the final image's (1 on geometry).
    assert!(indirect
        .chunks(4)
        .zip(fin.chunks(4))
        .all(|(i, f)| i[3] == f[3]));
}

/// Asked for on the GPU (a host's command buffer), the indirect layer is
/// made without `output_layers` and is the image a read-back frame gives.
#[test]
fn a_host_frame_hands_over_the_indirect_light() {
    let mut scene = ssbc::scene::load("cornell").unwrap();
    scene.ensure_light();
    let mut s = common::tiny_settings();
    s.output_layers = false;
    s.history.enabled = false;
    let resident = ResidentScene::new(scene).unwrap();
    let mut own = common::validated_renderer();
    let mut renderer = common::validated_renderer();
    let logs = [own.validation_log(), renderer.validation_log()];
    let mut host = common::host_frame::HostFrames::new(&renderer, &s);
    let theirs = host.frame_layer(&mut renderer, &resident, &s, (0, Layer::Indirect));
    let mut with_outputs = s.clone();
    with_outputs.output_layers = true;
    let mine = own.render_resident(&resident, &with_outputs).unwrap();
    let d = relative_difference(&theirs, rgba(&mine, Layer::Indirect));
    assert!(d < 1e-5, "the host's indirect light differs by {d}");
    drop(host);
    common::finish_clean(renderer);
    common::finish_clean(own);
    for log in logs {
        assert_eq!(log.total(), 0);
    }
}

/// A frame that keeps no residual images (no output asks for them) sums the
/// same final image: each step adds its residual to S0's image either way.
#[test]
fn the_final_image_does_not_depend_on_the_layers_kept() {
    let mut scene = ssbc::scene::load("spheres").unwrap();
    scene.ensure_light();
    let mut s = common::tiny_settings();
    s.ssbc.layers = 2;
    let every = common::render_validated(&scene, &s);
    s.output_layers = false;
    let final_only = common::render_validated(&scene, &s);
    assert!(final_only.layers.is_empty());
    assert_eq!(final_only.image.rgba, every.image.rgba);
    let held = |f: &ssbc::Frame| f.timings.memory.measured;
    assert!(held(&final_only).ssbc_images < held(&every).ssbc_images);
    // (The slot's transient memory counts as its largest phase's part:
    // the gather's, lighting, once the direct light is transient in it.)
    assert!(held(&final_only).total() < held(&every).total());
}
