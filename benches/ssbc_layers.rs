//! SSBC with a second G-buffer layer against one layer, in one run (the
//! machines are shared: only ratios within a run mean much). Run with
//! `cargo bench --bench ssbc_layers` (`-- --frames N`: median of N warm
//! frames, default 3; `--quick`: 320x240 only).
//!
//! 1. Cost, at the defaults otherwise: one SSBC step with two layers (the
//!    second at half and at full resolution) against one layer, and what
//!    the second layer's own passes cost (its G-buffer by depth peeling,
//!    direct and bounded VPL lighting, its geometry pyramid), against the
//!    one-layer frame. Configurations alternate frame by frame, so drift
//!    hits all alike.
//!    With a guard band (one layer, and two at full resolution): its
//!    margin and the same ratios.
//! 2. Accuracy: the hierarchical step against brute force over both
//!    layers (relative RMSE and mean of `residual_1`), 320x240.

mod common;

use ssbc::passes::ssbc::Integration;
use ssbc::profile::render_frames;
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};
use ssbc::settings::LayerResolution;

/// One layer; two with the second at half resolution; at full (the
/// accuracy section compares these three)...
const CONFIGS: [(&str, Option<LayerResolution>); 3] = [
    ("1", None),
    ("2, half", Some(LayerResolution::Half)),
    ("2, full", Some(LayerResolution::Full)),
];

/// ...and with a guard band: one layer, two at full.
const BANDED: [Option<LayerResolution>; 2] = [None, Some(LayerResolution::Full)];

/// Median GPU ms of the pass `name` (0 if it did not run).
fn pass_ms(f: &Frame, name: &str) -> f64 {
    f.timings
        .stats
        .as_ref()
        .expect("measured with render_frames")
        .passes
        .iter()
        .find(|p| p.name == name)
        .map_or(0.0, |p| p.ms.median)
}

fn settings(size: (u32, u32), layer1: Option<LayerResolution>) -> RenderSettings {
    banded(size, layer1, false)
}

fn banded(size: (u32, u32), layer1: Option<LayerResolution>, guard_band: bool) -> RenderSettings {
    let mut s = RenderSettings::new(size.0, size.1);
    s.ssbc.guard_band = guard_band;
    s.ssbc.layers = 1 + layer1.is_some() as u32;
    s.ssbc.layer1_resolution = layer1.unwrap_or_default();
    s
}

fn main() {
    let args = common::BenchArgs::parse(3);
    let frames = args.frames;
    let sizes = args.sizes();
    let scenes = ["cornell", "tori", "assets/open-front-box.gltf"];
    let mut renderer = Renderer::new(&RendererConfig::default()).expect("renderer");
    println!(
        "# SSBC layers on {}, defaults, median of {frames} warm frames\n",
        renderer.device().name()
    );
    println!("Per configuration (1 layer / 2, layer 1 at half resolution / 2, at full):\n");
    println!("| scene | size | step ms | step ratios | layer 1: G-buffer + direct + bounded ms | geometry pyramids ms | frame ms | frame ratios |");
    println!("|---|---|---|---|---|---|---|---|");
    let layer1_passes = [
        "gbuffer_layer1",
        "direct_lighting_layer1",
        "indirect_bounded_layer1",
    ];
    let mut band_rows = Vec::new();
    for name in scenes {
        let scene = ssbc::scene::load(name).expect("scene");
        let mut scene = scene;
        scene.ensure_light();
        for &size in sizes {
            // Alternate: one frame of each, `frames` times, keeping them all.
            let mut runs: [Vec<Frame>; 5] = Default::default();
            let all = CONFIGS
                .map(|(_, layer1)| banded(size, layer1, false))
                .into_iter()
                .chain(BANDED.map(|layer1| banded(size, layer1, true)));
            let all: Vec<RenderSettings> = all.collect();
            for _ in 0..frames {
                for (k, s) in all.iter().enumerate() {
                    runs[k].push(render_frames(&mut renderer, &scene, s, 1, None).expect("frame"));
                }
            }
            let median = |frames: &[Frame], f: &dyn Fn(&Frame) -> f64| {
                let mut v: Vec<f64> = frames.iter().map(f).collect();
                v.sort_by(|a, b| a.partial_cmp(b).unwrap());
                v[v.len() / 2]
            };
            let step = |k: usize| median(&runs[k], &|f| pass_ms(f, "ssbc_step_1"));
            let pyramid = |k: usize| median(&runs[k], &|f| pass_ms(f, "ssbc_geometry_mips"));
            let frame = |k: usize| {
                median(&runs[k], &|f| {
                    f.timings
                        .stats
                        .as_ref()
                        .unwrap()
                        .frame_gpu_ms
                        .unwrap()
                        .median
                })
            };
            let own = |k: usize| {
                median(&runs[k], &|f| {
                    layer1_passes.iter().map(|p| pass_ms(f, p)).sum()
                })
            };
            println!(
                "| {} | {}x{} | {:.1} / {:.1} / {:.1} | {:.2}x / {:.2}x | {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.1} / {:.1} / {:.1} | {:.2}x / {:.2}x |",
                scene.name,
                size.0,
                size.1,
                step(0),
                step(1),
                step(2),
                step(1) / step(0),
                step(2) / step(0),
                own(1),
                own(2),
                pyramid(0),
                pyramid(1),
                pyramid(2),
                frame(0),
                frame(1),
                frame(2),
                frame(1) / frame(0),
                frame(2) / frame(0),
            );
            let margin = runs[3][0].timings.guard_band;
            band_rows.push(format!(
                "| {} | {}x{} | {margin} ({:.2}x) | {:.1} / {:.1} / {:.1} | {:.2}x / {:.2}x | {:.1} / {:.1} / {:.1} | {:.2}x / {:.2}x |",
                scene.name,
                size.0,
                size.1,
                ((size.0 + 2 * margin) * (size.1 + 2 * margin)) as f64 / (size.0 * size.1) as f64,
                step(0),
                step(3),
                step(4),
                step(3) / step(0),
                step(4) / step(0),
                frame(0),
                frame(3),
                frame(4),
                frame(3) / frame(0),
                frame(4) / frame(0),
            ));
        }
    }
    println!("\n## Guard band\n\nOne layer / one with a guard band / two (full) with a guard band, same runs:\n");
    println!(
        "| scene | size | margin px (pixels) | step ms | step ratios | frame ms | frame ratios |"
    );
    println!("|---|---|---|---|---|---|---|");
    for row in band_rows {
        println!("{row}");
    }

    println!("\n## Hierarchical vs brute force (over every layer), one step, 320x240\n");
    println!("| scene | layers | relative RMSE of residual_1 | mean ratio |\n|---|---|---|---|");
    for name in scenes {
        let mut scene = ssbc::scene::load(name).expect("scene");
        scene.ensure_light();
        for (layers, layer1) in CONFIGS {
            let residual = |renderer: &mut Renderer, integration| {
                let mut s = settings((320, 240), layer1);
                s.ssbc.integration = integration;
                s.debug_readback = true;
                let f = renderer.render(&scene, &s).expect("frame");
                f.layer("residual_1").expect("residual_1").rgba.clone()
            };
            let hier = residual(&mut renderer, Integration::Hierarchical);
            let brute = residual(&mut renderer, Integration::Brute);
            // As tests/ssbc.rs measures against the CPU twin: sqrt(sum |h -
            // b|² / sum |b|²) and sum h / sum b over RGB.
            let (mut num, mut den, mut sum_h, mut sum_b) = (0f64, 0f64, 0f64, 0f64);
            for (h, b) in hier.chunks_exact(4).zip(brute.chunks_exact(4)) {
                for c in 0..3 {
                    let (h, b) = (h[c] as f64, b[c] as f64);
                    num += (h - b) * (h - b);
                    den += b * b;
                    sum_h += h;
                    sum_b += b;
                }
            }
            println!(
                "| {} | {layers} | {:.2}% | {:.4} |",
                scene.name,
                100.0 * (num / den.max(1e-300)).sqrt(),
                sum_h / sum_b.max(1e-300)
            );
        }
    }
}
