//! Per-pass GPU time from timestamp queries, reported as ratios within one
//! run (machines are shared and noisy). Run with
//! `cargo bench --bench passes` (add `-- --quick` for 512x384, `--frames N`
//! for the median of N warm frames per configuration; default 3).
//!
//! Every configuration is measured as `ssbc render --frames N` does
//! ([`ssbc::profile::render_frames`]): one warm-up frame (pipelines, first
//! touch of memory), then N frames; the tables give medians.
//!
//! Tables:
//! 1. instant radiosity: per-pass GPU ms for cornell and tori, 256 and 1024 VPLs;
//! 2. SSBC: frame GPU ms with 0..3 steps, what a step adds over the 0-step
//!    frame, texels read per pixel and GPU ns per texel read;
//! 3. where one step's time goes (its parts);
//! 4. hierarchical vs brute-force integration: time and texel ratios (at a
//!    quarter of the resolution: brute force is quadratic in the radius).

use ssbc::passes::ssbc::{Integration, SsbcSettings};
use ssbc::profile::{render_frames, FrameStats};
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};
use ssbc::Scene;

fn stats(f: &Frame) -> &FrameStats {
    f.timings
        .stats
        .as_ref()
        .expect("measured with render_frames")
}

/// Median GPU ms of the pass `name` (0 if it did not run).
fn pass_ms(f: &Frame, name: &str) -> f64 {
    stats(f)
        .passes
        .iter()
        .find(|p| p.name == name)
        .map_or(0.0, |p| p.ms.median)
}

/// Median GPU ms of the whole frame.
fn frame_ms(f: &Frame) -> f64 {
    stats(f)
        .frame_gpu_ms
        .expect("this benchmark needs GPU timestamps")
        .median
}

/// Median GPU ms of SSBC step `k` (1-based).
fn step_ms(f: &Frame, k: usize) -> f64 {
    pass_ms(f, &format!("ssbc_step_{k}"))
}

/// One warm-up frame, then `frames` frames (medians in the stats).
fn measure(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    frames: u32,
) -> Frame {
    render_frames(renderer, scene, settings, frames, None).expect("frames")
}

fn geometry_pixels(f: &Frame) -> usize {
    f.image.rgba.chunks_exact(4).filter(|p| p[3] != 0.0).count()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let reps: u32 = args
        .iter()
        .position(|a| a == "--frames")
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let (w, h) = if quick { (512, 384) } else { (1024, 768) };
    let mut renderer = Renderer::new(&RendererConfig::default()).expect("renderer");
    let device = renderer.device().name().to_string();
    println!("# ssbc benchmark on {device}, {w}x{h}, median of {reps} warm frames\n");
    let scenes = ["cornell", "tori"];
    let settings =
        |vpls: usize, steps: u32, integration: Integration, size: (u32, u32)| RenderSettings {
            width: size.0,
            height: size.1,
            vpl: ssbc::cpu::vpl::VplSettings {
                count: vpls,
                ..Default::default()
            },
            ssbc: SsbcSettings {
                steps,
                integration,
                ..Default::default()
            },
            ..Default::default()
        };

    println!("## Instant radiosity: GPU ms per pass (no SSBC)\n");
    let passes = [
        "shadow_maps",
        "ism_splat",
        "ism_pullpush",
        "gbuffer",
        "direct_lighting",
        "indirect_bounded",
    ];
    println!("| scene | VPLs | {} | frame |", passes.join(" | "));
    println!("|---|---|{}---|", "---|".repeat(passes.len()));
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for vpls in [256, 1024] {
            let f = measure(
                &mut renderer,
                &scene,
                &settings(vpls, 0, Integration::Hierarchical, (w, h)),
                reps,
            );
            let cells: Vec<String> = passes
                .iter()
                .map(|p| format!("{:.1}", pass_ms(&f, p)))
                .collect();
            println!(
                "| {scene_name} | {} | {} | {:.1} |",
                f.timings.vpl_count,
                cells.join(" | "),
                frame_ms(&f)
            );
        }
    }

    println!("\n## SSBC: frame GPU ms with K steps, and what a step adds to the 0-step frame\n");
    println!(
        "SSBC ms: the geometry pyramid and the K steps, from the frame's own timestamps; \
         per step / rest: (SSBC ms / K) over the rest of the same frame (robust to the \
         machine's noise); per step / 0-step: (frame - 0-step frame) / K over the 0-step \
         frame (two frames). Texels: read per geometry pixel by step 1 (average, most of \
         any one pixel); ns/texel: GPU ns of step 1 per texel read.\n"
    );
    println!("| scene | VPLs | K | frame ms | SSBC ms | per step / rest | per step / 0-step | texels/px avg | max | ns/texel |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut parts = Vec::new();
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for vpls in [256, 1024] {
            let frames: Vec<Frame> = (0..4)
                .map(|k| {
                    measure(
                        &mut renderer,
                        &scene,
                        &settings(vpls, k, Integration::Hierarchical, (w, h)),
                        reps,
                    )
                })
                .collect();
            let base = frame_ms(&frames[0]);
            for (k, f) in frames.iter().enumerate() {
                if k == 0 {
                    println!("| {scene_name} | {vpls} | 0 | {base:.1} | — | — | — | — | — | — |");
                    continue;
                }
                let ssbc_ms =
                    pass_ms(f, "ssbc_geometry_mips") + (1..=k).map(|j| step_ms(f, j)).sum::<f64>();
                let rest = frame_ms(f) - ssbc_ms;
                let per_step = (frame_ms(f) - base) / k as f64;
                let step = &f.timings.ssbc_steps[0];
                let reads = step.samples_per_pixel_avg * geometry_pixels(f) as f64;
                println!(
                    "| {scene_name} | {vpls} | {k} | {:.1} | {ssbc_ms:.1} | {:.0}% | {:.0}% | {:.1} | {:.0} | {:.1} |",
                    frame_ms(f),
                    100.0 * ssbc_ms / k as f64 / rest,
                    100.0 * per_step / base,
                    step.samples_per_pixel_avg,
                    step.samples_per_pixel_max,
                    step_ms(f, 1) * 1e6 / reads.max(1.0)
                );
            }
            if vpls == 256 {
                parts.push((scene_name, frames[1].clone()));
            }
        }
    }

    println!("\n## One step's parts (256 VPLs, K = 1): GPU ms\n");
    for (scene_name, f) in &parts {
        let cells: Vec<String> = std::iter::once(format!(
            "ssbc_geometry_mips {:.1}",
            pass_ms(f, "ssbc_geometry_mips")
        ))
        .chain(
            stats(f)
                .passes
                .iter()
                .filter(|p| p.name.starts_with("ssbc_step_1/"))
                .map(|p| format!("{} {:.1}", &p.name["ssbc_step_1/".len()..], p.ms.median)),
        )
        .collect();
        let step = &f.timings.ssbc_steps[0];
        println!(
            "- {scene_name}: {}; evaluation points from level {}, {:.1}% of pixels evaluated alone",
            cells.join(", "),
            step.eval_level,
            step.fallback_fraction * 100.0
        );
    }

    let (bw, bh) = (w / 4, h / 4);
    println!("\n## Hierarchical vs brute force, one step at {bw}x{bh}\n");
    println!("| scene | hierarchical ms | brute ms | time ratio | texels/px hier | brute | texel ratio |");
    println!("|---|---|---|---|---|---|---|");
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        let hier = measure(
            &mut renderer,
            &scene,
            &settings(256, 1, Integration::Hierarchical, (bw, bh)),
            reps,
        );
        let brute = measure(
            &mut renderer,
            &scene,
            &settings(256, 1, Integration::Brute, (bw, bh)),
            reps,
        );
        let (th, tb) = (step_ms(&hier, 1), step_ms(&brute, 1));
        let (sh, sb) = (
            hier.timings.ssbc_steps[0].samples_per_pixel_avg,
            brute.timings.ssbc_steps[0].samples_per_pixel_avg,
        );
        println!(
            "| {scene_name} | {th:.1} | {tb:.1} | {:.1}x | {sh:.1} | {sb:.1} | {:.1}x |",
            tb / th,
            sb / sh
        );
    }
}
