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
//! 2. The guard band: one layer without and with it, and two (full) with
//!    it, at 320x240 and 640x480 (larger wider frames exceed lavapipe's
//!    128 MiB storage buffers): its margin, step and frame ratios.
//! 3. Accuracy: the hierarchical step against brute force over both
//!    layers (relative RMSE and mean of `residual_1`), 320x240.

mod common;

use ssbc::profile::render_frames;
use ssbc::renderer::{Frame, RenderSettings, Renderer};
use ssbc::settings::Integration;
use ssbc::settings::LayerResolution;

/// One layer; two with the second at half resolution; at full.
const CONFIGS: [(&str, Option<LayerResolution>); 3] = [
    ("1", None),
    ("2, half", Some(LayerResolution::Half)),
    ("2, full", Some(LayerResolution::Full)),
];

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
    s.output_layers = true;
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
    let mut renderer = common::timing_renderer();
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
    for name in scenes {
        let scene = ssbc::scene::load(name).expect("scene");
        let mut scene = scene;
        scene.ensure_light();
        for &size in sizes {
            // Alternate: one frame of each, `frames` times, keeping them all.
            let mut runs: [Vec<Frame>; 3] = Default::default();
            for _ in 0..frames {
                for (k, (_, layer1)) in CONFIGS.into_iter().enumerate() {
                    let s = settings(size, layer1);
                    runs[k].push(render_frames(&mut renderer, &scene, &s, 1, None).expect("frame"));
                }
            }
            let step = |k: usize| median(&runs[k], &|f| pass_ms(f, "ssbc_step_1"));
            let pyramid = |k: usize| median(&runs[k], &|f| pass_ms(f, "ssbc_geometry_mips"));
            let frame = |k: usize| median(&runs[k], &frame_ms);
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
        }
    }

    guard_band_table(&mut renderer, &scenes, frames, args.quick);

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
                f.layer(ssbc::Layer::Residual(1))
                    .expect("residual_1")
                    .rgba
                    .clone()
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

/// Median GPU ms of the whole frame.
fn frame_ms(f: &Frame) -> f64 {
    let stats = f
        .timings
        .stats
        .as_ref()
        .expect("measured with render_frames");
    stats.frame_gpu_ms.expect("timestamps").median
}

/// Median of `f` over `frames`.
fn median(frames: &[Frame], f: &dyn Fn(&Frame) -> f64) -> f64 {
    let mut v: Vec<f64> = frames.iter().map(f).collect();
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[v.len() / 2]
}

/// One layer / one with a guard band / two (full) with one, alternating.
fn guard_band_table(renderer: &mut Renderer, scenes: &[&str], frames: u32, quick: bool) {
    let sizes: &[(u32, u32)] = if quick {
        &[(320, 240)]
    } else {
        &[(320, 240), (640, 480)]
    };
    println!("\n## Guard band\n\nOne layer / one with a guard band / two (full) with a guard band, same runs:\n");
    println!(
        "| scene | size | margin px (pixels) | step ms | step ratios | frame ms | frame ratios |"
    );
    println!("|---|---|---|---|---|---|---|");
    let configs = [
        (None, false),
        (None, true),
        (Some(LayerResolution::Full), true),
    ];
    for name in scenes {
        let mut scene = ssbc::scene::load(name).expect("scene");
        scene.ensure_light();
        for &size in sizes {
            // A configuration the device cannot hold is left out (None).
            let mut runs: [Option<Vec<Frame>>; 3] = Default::default();
            for _ in 0..frames {
                for (k, (layer1, band)) in configs.into_iter().enumerate() {
                    let s = banded(size, layer1, band);
                    match render_frames(renderer, &scene, &s, 1, None) {
                        Ok(f) => runs[k].get_or_insert_with(Vec::new).push(f),
                        Err(e) => eprintln!("{} {size:?} {k}: {e}", scene.name),
                    }
                }
            }
            let step = |k: usize| {
                runs[k]
                    .as_deref()
                    .map(|r| median(r, &|f| pass_ms(f, "ssbc_step_1")))
            };
            let frame = |k: usize| runs[k].as_deref().map(|r| median(r, &frame_ms));
            let show = |v: Option<f64>| v.map_or("n/a".to_string(), |v| format!("{v:.1}"));
            let ratio = |a: Option<f64>, b: Option<f64>| match (a, b) {
                (Some(a), Some(b)) => format!("{:.2}x", a / b),
                _ => "n/a".to_string(),
            };
            let margin = runs[1].as_ref().map_or(0, |r| r[0].timings.guard_band);
            let pixels =
                ((size.0 + 2 * margin) * (size.1 + 2 * margin)) as f64 / (size.0 * size.1) as f64;
            println!(
                "| {} | {}x{} | {margin} ({pixels:.2}x) | {} / {} / {} | {} / {} | {} / {} / {} | {} / {} |",
                scene.name,
                size.0,
                size.1,
                show(step(0)),
                show(step(1)),
                show(step(2)),
                ratio(step(1), step(0)),
                ratio(step(2), step(0)),
                show(frame(0)),
                show(frame(1)),
                show(frame(2)),
                ratio(frame(1), frame(0)),
                ratio(frame(2), frame(0)),
            );
        }
    }
}
