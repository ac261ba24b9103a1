//! Temporal history under camera motion: after `--still N` (default 8)
//! frames of a still view, the camera pans (turns about the vertical by
//! 1.5 degrees a frame and moves sideways by 0.5% of the scene's diagonal)
//! for 16 frames, with temporal history (reprojected) and standing alone
//! (each frame its own). Against a path tracing of every pose (fixed seed,
//! `--spp`, default 512; kept in out/pan/): the indirect light's error on
//! 4x4 blocks, mean |ours - truth| / mean truth, per frame, for both; and
//! against ssbc's own converged image of the pose (32 accumulated frames:
//! the method's bias cancels, what is left is the VPL sets' noise and what
//! reprojection adds).
//!
//! `cargo run --release --example pan -- [SCENE] [--size WxH] [--spp N] [--still N] [--moving-frames N] [--new-vpls]`

use std::sync::atomic::AtomicBool;

use glam::Quat;
use ssbc::renderer::{RenderSettings, Renderer, RendererConfig};
use ssbc::resident::ResidentScene;

const FRAMES: usize = 16;

#[path = "common/references.rs"]
mod references;
use references::{block_error, indirect, minus, reference};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).cloned()
    };
    let flags = ["--size", "--spp", "--still", "--moving-frames"];
    let scene_path = args
        .iter()
        .enumerate()
        .find(|(i, a)| !a.starts_with("--") && (*i == 0 || !flags.contains(&args[i - 1].as_str())))
        .map(|(_, a)| a.clone())
        .unwrap_or_else(|| "assets/open-front-box.gltf".into());
    let size = value("--size")
        .and_then(|s| {
            let (w, h) = s.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or((160, 120));
    let spp: u32 = value("--spp").and_then(|v| v.parse().ok()).unwrap_or(512);
    let still: usize = value("--still").and_then(|v| v.parse().ok()).unwrap_or(8);
    let mut scene = ssbc::scene::load(&scene_path)?;
    scene.ensure_light();
    let mut settings = RenderSettings::new(size.0, size.1);
    settings.output_layers = true;
    if let Some(n) = value("--moving-frames").and_then(|v| v.parse().ok()) {
        settings.history.moving_frames = n;
    }
    settings.history.new_vpls_while_moving = args.iter().any(|a| a == "--new-vpls");
    let mut alone = settings.clone();
    alone.history.enabled = false;
    std::fs::create_dir_all("out/pan")?;
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    let mut other = Renderer::new(&RendererConfig::default())?;
    let mut resident = ResidentScene::new(scene.clone())?;
    for _ in 0..still {
        renderer.render_resident(&resident, &settings)?;
    }
    let mut camera = scene.camera(None)?;
    let step = 0.005 * 2.0 * scene.bounds().radius();
    let turn = Quat::from_rotation_y(1.5f32.to_radians());
    println!(
        "| frame | vs truth: history | alone | ratio | vs converged: history | alone | ratio |"
    );
    println!("|---|---|---|---|---|---|---|");
    let (mut sum_h, mut sum_a, mut worst) = (0.0, 0.0, 0.0f64);
    let (mut sum_hc, mut sum_ac, mut worst_c) = (0.0, 0.0, 0.0f64);
    let stop = AtomicBool::new(false);
    for t in 1..=FRAMES {
        let right = camera.forward.cross(camera.up).normalize();
        camera.position += right * step;
        camera.forward = (turn * camera.forward).normalize();
        camera.up = (turn * camera.up).normalize();
        resident.set_camera(camera.clone());
        let ours = indirect(&renderer.render_resident(&resident, &settings)?);
        let mut posed = scene.clone();
        posed.cameras = vec![camera.clone()];
        let fresh = indirect(&other.render(&posed, &alone)?);
        let key = format!("out/pan/{}-{}x{}-{spp}-{t}", scene.name, size.0, size.1);
        let full = reference(
            &posed,
            size,
            spp,
            ssbc::settings::DEFAULT_BOUNCES,
            &format!("{key}.exr"),
        );
        let direct = reference(&posed, size, spp, 0, &format!("{key}-direct.exr"));
        let truth = minus(&full, &direct);
        let converged = indirect(&other.render_accumulated(&posed, &alone, 32, &stop, |_| {})?);
        let (eh, ea) = (
            block_error(&ours, &truth, size),
            block_error(&fresh, &truth, size),
        );
        let (ehc, eac) = (
            block_error(&ours, &converged, size),
            block_error(&fresh, &converged, size),
        );
        println!(
            "| {t} | {:.2}% | {:.2}% | {:.2} | {:.2}% | {:.2}% | {:.2} |",
            100.0 * eh,
            100.0 * ea,
            eh / ea,
            100.0 * ehc,
            100.0 * eac,
            ehc / eac
        );
        sum_h += eh;
        sum_a += ea;
        worst = worst.max(eh / ea);
        sum_hc += ehc;
        sum_ac += eac;
        worst_c = worst_c.max(ehc / eac);
    }
    println!(
        "against the converged image: history {:.2}%, alone {:.2}% ({:.2}x); worst frame's ratio {worst_c:.2}",
        100.0 * sum_hc / FRAMES as f64,
        100.0 * sum_ac / FRAMES as f64,
        sum_hc / sum_ac
    );
    println!(
        "mean error: history {:.2}%, alone {:.2}% ({:.2}x); worst frame's ratio {worst:.2} ({}x{}, {still} still frames first, {spp}-spp references)",
        100.0 * sum_h / FRAMES as f64,
        100.0 * sum_a / FRAMES as f64,
        sum_h / sum_a,
        size.0,
        size.1
    );
    Ok(())
}
