//! Temporal stability of stateless renders: the point light of a scene
//! (default: assets/open-front-box.gltf) moves 8 times by 1 cm along x;
//! every position is rendered independently, and path-traced with one
//! fixed seed (correlated noise: its frame-to-frame change is nearly
//! noise-free). On 4x4 blocks, with dS_t = S_{t+1} - S_t for ours and dR_t
//! for the reference:
//!   temporal error = mean_t mean|dS_t - dR_t| / mean R,
//!   change ratio   = sum|dS| / sum|dR|,
//! for the indirect light (final minus direct; the reference's direct is a
//! 0-bounce path tracing with the same seed) and for the final image. Also
//! what moves the VPLs between positions: paths whose VPL count changed
//! (crossing an edge), VPLs that left their position by more than 5 cm.
//!
//! With `--history`, the positions are frames of one resident scene with
//! temporal history (after `--still N`, default 8, frames of the still
//! view), as in the viewer or `ssbc render --sequence`; then the light jumps
//! by half the scene's diagonal towards its centre, and switches off:
//! the indirect light's mean against the new truth's and its error on 4x4
//! blocks (mean |ours - truth| / mean truth) against a frame standing
//! alone, for the 3 frames after each. `--light-frames N` and
//! `--light-change X` set the history's weighting of light-changed frames.
//!
//! `cargo run --release --example flicker -- [SCENE] [--size WxH] [--spp N] [--history] [-- render options]`
//! e.g. `... --example flicker -- --vpls 1024 --steps 1`. References are kept in
//! out/flicker/ (keyed by scene, size, spp and position).

use std::collections::HashMap;

use glam::Vec3;
use ssbc::renderer::{RenderSettings, Renderer, RendererConfig};
use ssbc::resident::ResidentScene;
use ssbc::settings::Gather;
use ssbc::Scene;

#[path = "common/references.rs"]
mod references;
use references::{block_error, indirect, minus, reference};

const MOVES: usize = 8;
const STEP: f32 = 0.01;
const BLOCK: u32 = 4;

/// (temporal error, change ratio) of the sequence `s` against `r` (RGBA
/// images, luminance-free: the mean over RGB of 4x4 block means).
fn stability(s: &[Vec<f32>], r: &[Vec<f32>], size: (u32, u32)) -> (f64, f64) {
    let blocks = |img: &Vec<f32>| ssbc::compare::block_average(img, size.0, size.1, BLOCK);
    let (s, r): (Vec<_>, Vec<_>) = (
        s.iter().map(blocks).collect(),
        r.iter().map(blocks).collect(),
    );
    let rgb = |v: &[f32], i: usize| (v[i * 4] + v[i * 4 + 1] + v[i * 4 + 2]) as f64 / 3.0;
    let n = s[0].len() / 4;
    let mean_r = r
        .iter()
        .map(|img| (0..n).map(|i| rgb(img, i)).sum::<f64>())
        .sum::<f64>()
        / (n * r.len()) as f64;
    let (mut err, mut ds_sum, mut dr_sum) = (0.0, 0.0, 0.0);
    for t in 0..s.len() - 1 {
        for i in 0..n {
            let ds = rgb(&s[t + 1], i) - rgb(&s[t], i);
            let dr = rgb(&r[t + 1], i) - rgb(&r[t], i);
            err += (ds - dr).abs();
            ds_sum += ds.abs();
            dr_sum += dr.abs();
        }
    }
    let steps = (s.len() - 1) as f64;
    (err / (steps * n as f64) / mean_r, ds_sum / dr_sum)
}

/// Mean over RGB and geometry of an indirect image.
fn mean_rgb(img: &[f32]) -> f64 {
    img.chunks(4)
        .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
        .sum::<f64>()
        / (img.len() / 4) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let split = args.iter().position(|a| a == "--").unwrap_or(args.len());
    let (ours, render_args) = (&args[..split], args.get(split + 1..).unwrap_or(&[]));
    let value = |list: &[String], flag: &str| {
        let i = list.iter().position(|a| a == flag)?;
        list.get(i + 1).cloned()
    };
    let valued = [
        "--size",
        "--spp",
        "--still",
        "--light-frames",
        "--light-change",
    ];
    let scene_path = ours
        .iter()
        .enumerate()
        .find(|(i, a)| !a.starts_with("--") && (*i == 0 || !valued.contains(&ours[i - 1].as_str())))
        .map(|(_, a)| a.clone())
        .unwrap_or_else(|| "assets/open-front-box.gltf".into());
    let size = value(ours, "--size")
        .and_then(|s| {
            let (w, h) = s.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or((320, 240));
    let spp: u32 = value(ours, "--spp")
        .and_then(|v| v.parse().ok())
        .unwrap_or(1024);
    let mut settings = RenderSettings::new(size.0, size.1);
    settings.output_layers = true;
    let num = |flag: &str| value(render_args, flag).and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = num("--vpls") {
        settings.vpl.count = v as usize;
    }
    if let Some(v) = num("--steps") {
        settings.ssbc.steps = v as u32;
    }
    if let Some(v) = num("--ism-res") {
        settings.ism_tile = v as u32;
    }
    if let Some(v) = num("--points-per-vpl") {
        settings.points_per_vpl = v as u32;
    }
    if let Some(v) = num("--interleave") {
        settings.interleave = v as u32;
    }
    if value(render_args, "--gather").as_deref() == Some("full") {
        settings.gather = Gather::Full;
    }
    if let Some(v) = num("--bound") {
        settings.bound = ssbc::renderer::Bound::Value(v as f32);
    }
    let history = ours.iter().any(|a| a == "--history");
    settings.history.enabled = history;
    if let Some(v) = value(ours, "--light-frames").and_then(|v| v.parse().ok()) {
        settings.history.light_frames = v;
    }
    if let Some(v) = value(ours, "--light-change").and_then(|v| v.parse().ok()) {
        settings.history.light_change = v;
    }
    let still: usize = value(ours, "--still")
        .and_then(|v| v.parse().ok())
        .unwrap_or(8);
    let mut scene = ssbc::scene::load(&scene_path)?;
    scene.ensure_light();
    let start = scene.lights[0].position;
    std::fs::create_dir_all("out/flicker")?;
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    let (mut finals, mut indirects, mut ref_finals, mut ref_indirects) =
        (vec![], vec![], vec![], vec![]);
    let mut vpl_sets = Vec::new();
    let mut resident = ResidentScene::new(scene.clone())?;
    if history {
        for _ in 1..still {
            renderer.render_resident(&resident, &settings)?;
        }
    }
    for t in 0..=MOVES {
        scene.lights[0].position = start + Vec3::X * (STEP * t as f32);
        let frame = if history {
            resident.set_lights(scene.lights.clone())?;
            renderer.render_resident(&resident, &settings)?
        } else {
            renderer.render(&scene, &settings)?
        };
        indirects.push(indirect(&frame));
        finals.push(frame.image.rgba.clone());
        vpl_sets.push(frame.vpls.clone());
        let key = format!("out/flicker/{}-{}x{}-{spp}-{t}", scene.name, size.0, size.1);
        let full = reference(
            &scene,
            size,
            spp,
            ssbc::settings::DEFAULT_BOUNCES,
            &format!("{key}.exr"),
        );
        let direct = reference(&scene, size, spp, 0, &format!("{key}-direct.exr"));
        ref_indirects.push(minus(&full, &direct));
        ref_finals.push(full);
    }
    let (e_ind, c_ind) = stability(&indirects, &ref_indirects, size);
    let (e_fin, c_fin) = stability(&finals, &ref_finals, size);
    // What moved the VPLs: per path, its VPL count and positions.
    let (mut paths_changed, mut moved, mut total) = (0usize, 0usize, 0usize);
    for pair in vpl_sets.windows(2) {
        let by_path = |vpls: &[ssbc::cpu::vpl::Vpl]| {
            let mut m: HashMap<(u64, u32), Vec3> = HashMap::new();
            for v in vpls {
                m.insert((v.path, v.bounce), v.position);
            }
            m
        };
        let (a, b) = (by_path(&pair[0]), by_path(&pair[1]));
        let count = |m: &HashMap<(u64, u32), Vec3>, p: u64| m.keys().filter(|k| k.0 == p).count();
        let paths: std::collections::HashSet<u64> = a.keys().chain(b.keys()).map(|k| k.0).collect();
        paths_changed += paths
            .iter()
            .filter(|&&p| count(&a, p) != count(&b, p))
            .count();
        for (k, pa) in &a {
            total += 1;
            if b.get(k).is_none_or(|pb| (*pb - *pa).length() > 0.05) {
                moved += 1;
            }
        }
    }
    if history {
        lag(&mut renderer, &mut resident, &scene, &settings, spp)?;
    }
    println!(
        "| {} | {}x{} | {} | indirect: {:.2}% / {:.2}x | final: {:.2}% / {:.2}x | paths changing length per move {:.1} | VPLs moved > 5 cm {:.2}% |",
        scene.name,
        size.0,
        size.1,
        render_args.join(" "),
        100.0 * e_ind,
        c_ind,
        100.0 * e_fin,
        c_fin,
        paths_changed as f64 / MOVES as f64,
        100.0 * moved as f64 / total.max(1) as f64,
    );
    Ok(())
}

/// After the moves: the light jumps by half the scene's diagonal towards
/// the centre of its bounds, then switches off; for the 3 frames after
/// each, the indirect light against the new truth, and a frame standing
/// alone (the same light paths, no history).
fn lag(
    renderer: &mut Renderer,
    resident: &mut ResidentScene,
    scene: &Scene,
    settings: &RenderSettings,
    spp: u32,
) -> Result<(), Box<dyn std::error::Error>> {
    let size = (settings.width, settings.height);
    let bounds = scene.bounds();
    let from = scene.lights[0].position;
    let towards = (bounds.center() - from).normalize_or_zero();
    let mut jumped = scene.clone();
    jumped.lights[0].position = from + towards * bounds.radius();
    let key = format!(
        "out/flicker/{}-{}x{}-{spp}-jump",
        scene.name, size.0, size.1
    );
    let full = reference(
        &jumped,
        size,
        spp,
        ssbc::settings::DEFAULT_BOUNCES,
        &format!("{key}.exr"),
    );
    let direct = reference(&jumped, size, spp, 0, &format!("{key}-direct.exr"));
    let truth = minus(&full, &direct);
    let mut alone_settings = settings.clone();
    alone_settings.vpl.first_path = 0;
    alone_settings.history.enabled = false;
    let mut other = Renderer::new(&RendererConfig::default())?;
    resident.set_lights(jumped.lights.clone())?;
    for k in 1..=3 {
        let frame = renderer.render_resident(resident, settings)?;
        let ours = indirect(&frame);
        // A frame standing alone (other light paths; the same error in
        // expectation).
        let alone = indirect(&other.render(&jumped, &alone_settings)?);
        println!(
            "jump, frame {k}: mean indirect / truth {:.3}, 4x4-block error {:.2}% (a fresh frame {:.2}%, mean {:.3})",
            mean_rgb(&ours) / mean_rgb(&truth),
            100.0 * block_error(&ours, &truth, size),
            100.0 * block_error(&alone, &truth, size),
            mean_rgb(&alone) / mean_rgb(&truth),
        );
    }
    let before = mean_rgb(&indirect(&renderer.render_resident(resident, settings)?));
    let mut dark = jumped.lights.clone();
    dark[0].intensity = Vec3::ZERO;
    resident.set_lights(dark)?;
    for k in 1..=3 {
        let ours = indirect(&renderer.render_resident(resident, settings)?);
        println!(
            "light off, frame {k}: mean indirect {:.2e} of what it was ({before:.3e})",
            mean_rgb(&ours) / before
        );
    }
    Ok(())
}
