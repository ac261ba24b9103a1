//! Imperfect shadow maps: cost per VPL against agreement with exact
//! visibility, for ISM tile sides and points per VPL. For each setting: the
//! GPU ms of `ism_splat` (ray-cast layer + points; median of warm frames) per 1000
//! VPLs, and the share of (pixel, VPL) pairs on which the ISM test agrees
//! with a ray cast (pairs that exchange light at cosines of at least 0.1 on
//! both ends, every 13th geometry pixel), as `tests/instant_radiosity.rs`
//! measures it.
//!
//! `cargo run --release --example ism_tradeoff -- [SCENE ...] [--size WxH] [--vpls N] [--frames N] [--tiles 16,32,64] [--points 256,512,1024,2048]`
//! (default: assets/open-front-box.gltf and tori, 320x240, 1024 VPLs, 3
//! frames, the tiles and points shown).

use ssbc::cpu::bvh::SceneBvh;
use ssbc::profile::render_frames;
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};

/// Agreement of the frame's ISM test with ray casts, the shares of pairs it
/// wrongly shadows and wrongly lights, and the number of pairs.
fn agreement(scene: &ssbc::Scene, frame: &Frame) -> (f64, f64, f64, usize) {
    let bvh = SceneBvh::new(scene);
    let ism = frame.ism.as_ref().expect("debug readback");
    let layer = |name: &str| {
        &frame
            .layer(name.parse().expect("a layer name"))
            .expect("debug readback")
            .rgba
    };
    let (pos, nrm) = (layer("gbuffer_position"), layer("gbuffer_normal"));
    let v = |img: &[f32], i: usize| glam::Vec3::new(img[i * 4], img[i * 4 + 1], img[i * 4 + 2]);
    let (mut agree, mut pairs, mut shadowed, mut lit) = (0usize, 0usize, 0usize, 0usize);
    let geometry = (0..(frame.width * frame.height) as usize).filter(|&i| pos[i * 4 + 3] != 0.0);
    for i in geometry.step_by(13) {
        let (x, n) = (v(pos, i), v(nrm, i));
        for (k, vpl) in frame.vpls.iter().enumerate() {
            let w = (x - vpl.position).normalize();
            if vpl.normal.dot(w) < 0.1 || -n.dot(w) < 0.1 {
                continue;
            }
            pairs += 1;
            let exact = !bvh.occluded(vpl.position + vpl.normal * 1e-4, x + n * 1e-4);
            let test = ssbc::passes::indirect_bounded::IsmTest {
                relative_bias: ssbc::passes::indirect_bounded::ISM_BIAS,
                lifted: false,
            };
            let approx = ism.visible(k, vpl, x, n, test);
            agree += (exact == approx) as usize;
            shadowed += (exact && !approx) as usize;
            lit += (!exact && approx) as usize;
        }
    }
    let share = |n: usize| n as f64 / pairs.max(1) as f64;
    (share(agree), share(shadowed), share(lit), pairs)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).cloned()
    };
    let flag_values: Vec<String> = ["--size", "--vpls", "--frames", "--tiles", "--points"]
        .iter()
        .filter_map(|f| value(f))
        .collect();
    let mut scenes: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with("--") && !flag_values.contains(a))
        .cloned()
        .collect();
    if scenes.is_empty() {
        scenes = vec!["assets/open-front-box.gltf".into(), "tori".into()];
    }
    let (width, height) = value("--size")
        .and_then(|s| {
            let (w, h) = s.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or((320, 240));
    let vpls: usize = value("--vpls").and_then(|v| v.parse().ok()).unwrap_or(1024);
    let frames: u32 = value("--frames").and_then(|v| v.parse().ok()).unwrap_or(3);
    let list = |flag: &str, default: &[u32]| -> Vec<u32> {
        value(flag).map_or(default.to_vec(), |v| {
            v.split(',').filter_map(|n| n.parse().ok()).collect()
        })
    };
    let (tiles, point_counts) = (
        list("--tiles", &[16, 32, 64]),
        list("--points", &[256, 512, 1024, 2048]),
    );
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    println!("| scene | tile | points/VPL | ISM ms (layer + splat) | ms per 1000 VPLs | agreement | false shadows | leaks | pairs |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for name in &scenes {
        let mut scene = ssbc::scene::load(name)?;
        scene.ensure_light();
        for &tile in &tiles {
            for &points in &point_counts {
                let mut settings = RenderSettings {
                    width,
                    height,
                    ism_tile: tile,
                    points_per_vpl: points,
                    debug_readback: true,
                    ..Default::default()
                };
                settings.vpl.count = vpls;
                settings.ssbc.steps = 0;
                let frame = render_frames(&mut renderer, &scene, &settings, frames, None)?;
                let stats = frame.timings.stats.as_ref().expect("stats");
                let ms = |pass: &str| {
                    stats
                        .passes
                        .iter()
                        .find(|p| p.name == pass)
                        .map_or(f64::NAN, |p| p.ms.median)
                };
                let splat = ms("ism_splat");
                let (agree, shadowed, lit, pairs) = agreement(&scene, &frame);
                println!(
                    "| {} | {tile} | {points} | {splat:.1} | {:.1} | {:.2}% | {:.2}% | {:.2}% | {pairs} |",
                    scene.name,
                    splat * 1000.0 / frame.vpls.len() as f64,
                    100.0 * agree,
                    100.0 * shadowed,
                    100.0 * lit,
                );
            }
        }
    }
    Ok(())
}
