//! In frames with glossy receivers, SSBC evaluates the points and fallback
//! pixels at glossy receivers and at the others in one dispatch on a GPU
//! and in two kernels, one after the other, on a CPU device (lavapipe);
//! `ssbc.receiver_dispatch` overrides the choice. CI has only lavapipe, so
//! the GPU's way is run here by the override: both ways give the same
//! image, validation and synchronization validation clean, and the one
//! dispatch stays in bounds under GPU-assisted validation.

mod common;

use ssbc::renderer::Layer;
use ssbc::settings::{Integration, LayerResolution, ReceiverDispatch};

#[test]
fn one_dispatch_and_two_kernels_give_the_same_image() {
    let scene = ssbc::scene::builtin::spheres();
    for (layers, integration) in [(2, Integration::Hierarchical), (1, Integration::Brute)] {
        let mut s = common::small(128, 96);
        s.debug_readback = true;
        s.vpl.count = 64;
        s.ssbc.steps = 2;
        s.ssbc.layers = layers;
        s.ssbc.integration = integration;
        let mut frames = Vec::new();
        for dispatch in [ReceiverDispatch::One, ReceiverDispatch::Two] {
            s.ssbc.receiver_dispatch = dispatch;
            frames.push(common::render_validated(&scene, &s));
        }
        let (one, two) = (&frames[0], &frames[1]);
        // The glossy kernel is timed apart only where it follows the other.
        let has = |f: &ssbc::renderer::Frame, name: &str| {
            f.timings.timed_passes().iter().any(|p| p.name == name)
        };
        for step in 1..=2 {
            let fallback = format!("ssbc_step_{step}/fallback/glossy");
            assert!(has(two, &fallback), "two kernels: no {fallback}");
            assert!(!has(one, &fallback), "one dispatch: {fallback}");
        }
        let difference = common::max_relative_difference(one, two);
        eprintln!("{layers} layer(s), {integration:?}: largest difference {difference:.2e}");
        assert!(difference < 1e-5, "largest difference {difference}");
        // Glossy receivers are there and SSBC adds light at them.
        let residual = one.layer(Layer::Residual(1)).expect("residual layer");
        assert!(residual.rgba.iter().any(|&v| v > 0.0));
    }
    // The one dispatch under GPU-assisted validation (an odd size with a
    // half-resolution second layer, and a full-resolution one).
    let mut renderer = common::gpu_assisted_renderer();
    for (size, layer1) in [
        ((130, 98), LayerResolution::Half),
        ((64, 48), LayerResolution::Full),
    ] {
        let mut s = common::small(size.0, size.1);
        s.vpl.count = 16;
        s.points_per_vpl = 256;
        s.ism_tile = 16;
        s.shadow_map_size = 64;
        s.ssbc.steps = 2;
        s.ssbc.layers = 2;
        s.ssbc.layer1_resolution = layer1;
        s.ssbc.receiver_dispatch = ReceiverDispatch::One;
        let frame = renderer.render(&scene, &s).expect("render");
        let has_both = frame
            .timings
            .timed_passes()
            .iter()
            .any(|p| p.name == "ssbc_step_1/fallback/glossy");
        assert!(!has_both, "the renderer did not take one dispatch");
    }
    common::finish_clean(renderer);
}
