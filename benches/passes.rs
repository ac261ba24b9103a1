//! Per-pass GPU time from timestamp queries, reported as ratios within one
//! run (machines are shared and noisy). Run with
//! `cargo bench --bench passes` (add `-- --quick` for 512x384).
//!
//! Tables:
//! 1. instant radiosity: per-pass GPU ms for cornell and tori, 256 and 1024 VPLs;
//! 2. SSBC: frame GPU ms with 0..3 steps and each step's overhead relative
//!    to the 0-step frame;
//! 3. hierarchical vs brute-force integration: time and sample ratios (at a
//!    quarter of the resolution: brute force is quadratic in the radius).

use ssbc::passes::ssbc::{Integration, SsbcSettings};
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};

fn pass_ms(f: &Frame, name: &str) -> f64 {
    f.timings
        .passes
        .iter()
        .filter(|p| p.name == name)
        .map(|p| p.gpu_ms)
        .sum()
}

fn main() {
    let quick = std::env::args().any(|a| a == "--quick");
    let (w, h) = if quick { (512, 384) } else { (1024, 768) };
    let mut renderer = Renderer::new(&RendererConfig::default()).expect("renderer");
    let device = renderer.device().name().to_string();
    println!("# ssbc benchmark on {device}, {w}x{h}\n");
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
            let f = renderer
                .render(
                    &scene,
                    &settings(vpls, 0, Integration::Hierarchical, (w, h)),
                )
                .unwrap();
            let cells: Vec<String> = passes
                .iter()
                .map(|p| format!("{:.1}", pass_ms(&f, p)))
                .collect();
            println!(
                "| {scene_name} | {} | {} | {:.1} |",
                f.timings.vpl_count,
                cells.join(" | "),
                f.timings.frame_gpu_ms
            );
        }
    }

    println!("\n## SSBC steps: frame GPU ms and overhead over the 0-step frame (256 VPLs)\n");
    println!("| scene | 0 steps | 1 step | 2 steps | 3 steps | step 1 | step 2 | step 3 | samples/pixel (avg, max) |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        let frames: Vec<Frame> = (0..4)
            .map(|k| {
                renderer
                    .render(&scene, &settings(256, k, Integration::Hierarchical, (w, h)))
                    .unwrap()
            })
            .collect();
        let base = frames[0].timings.frame_gpu_ms;
        let f3 = &frames[3];
        let step_overheads: Vec<String> = f3
            .timings
            .ssbc_steps
            .iter()
            .map(|s| {
                format!(
                    "{:.1}%",
                    100.0 * (s.gpu_ms + pass_ms(f3, "ssbc_geometry_mips") / 3.0) / base
                )
            })
            .collect();
        let samples = &f3.timings.ssbc_steps[0];
        println!(
            "| {scene_name} | {:.1} | {:.1} ({:+.1}%) | {:.1} ({:+.1}%) | {:.1} ({:+.1}%) | {} | {:.1}, {} |",
            base,
            frames[1].timings.frame_gpu_ms,
            100.0 * (frames[1].timings.frame_gpu_ms / base - 1.0),
            frames[2].timings.frame_gpu_ms,
            100.0 * (frames[2].timings.frame_gpu_ms / base - 1.0),
            f3.timings.frame_gpu_ms,
            100.0 * (f3.timings.frame_gpu_ms / base - 1.0),
            step_overheads.join(" | "),
            samples.samples_per_pixel_avg,
            samples.samples_per_pixel_max
        );
    }

    let (bw, bh) = (w / 4, h / 4);
    println!("\n## Hierarchical vs brute force, one step at {bw}x{bh}\n");
    println!("| scene | hierarchical ms | brute ms | time ratio | samples/pixel hier | brute | sample ratio |");
    println!("|---|---|---|---|---|---|---|");
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        let hier = renderer
            .render(
                &scene,
                &settings(256, 1, Integration::Hierarchical, (bw, bh)),
            )
            .unwrap();
        let brute = renderer
            .render(&scene, &settings(256, 1, Integration::Brute, (bw, bh)))
            .unwrap();
        let (th, tb) = (
            hier.timings.ssbc_steps[0].gpu_ms,
            brute.timings.ssbc_steps[0].gpu_ms,
        );
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
