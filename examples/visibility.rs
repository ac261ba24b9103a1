//! How right the VPLs' visibility is: the GPU's ISM test replayed on the
//! CPU against exact ray casts, over (pixel, VPL) pairs that exchange light
//! (both cosines positive), each pair weighted by what it carries to the
//! bounded gather: the VPL's flux (luminance) times min(G, b).
//!
//! - passed: the weighted share of the exactly visible light the ISMs let
//!   through (1 is right; below is false shadow);
//! - leaked: the weighted share of the exactly occluded light they let
//!   through (0 is right; above is light through walls);
//! - of the leaked weight, the part where the stored depth lies beyond the
//!   receiver (a hole or a coarse block) rather than within the tolerance;
//! - with `--back-faces`, of the pairs the front map passes, the share
//!   whose texel is flagged: where the gather reads its back-face map (a
//!   count of the option's cost; 0 without).
//!
//! With `--why`, each texel's centre ray (the one its distance is measured
//! along) is cast exactly too, and the wrong answers are split by what it
//! meets: of the visible light rejected, the share where the centre ray
//! meets an occluder the receiver's own ray passes (the occluder's edge
//! crosses the texel) and where the texel stores a surface more than a
//! footprint nearer than anything the centre ray meets (a splat that
//! overhangs its surface); of the leaked light, the share where the centre
//! ray passes the occluder (its edge crosses the texel), where it meets it
//! but the texel stores something more than a footprint beyond (a hole in
//! the occluder's splats), and where the texel holds the occluder but the
//! test's tolerance reaches past it. It also splits the leaked light by
//! what the texel holds: the ray-cast layer's block (no normal), a
//! surface of the receiver's own orientation (|cos| > 0.9: a floor that
//! runs on beyond a wall's foot), or one that turns across it; each
//! within the relative tolerance or beyond it (passed by the slope term
//! or by following the stored plane). `--bias B` replays another
//! relative tolerance than `ism_bias`'s (Lambertian receivers; narrow glossy
//! lobes scale it as the gathers do), `--lift-all` the lifted test
//! (`IsmTest::lifted`) for every receiver, `--back-faces` ISMs with
//! back-face maps (`RenderSettings::ism_back_faces`), `--visibility traced` the
//! ISMs whose texels are ray-traced (devices with ray queries), `--region`
//! only the pixels of one box of the image. `--map DIR` writes
//! `DIR/SCENE.png` (4x4 screen pixels a pixel), per pixel the rejected visible light in red, the leaked
//! light in green and the visible light in blue (square roots, full at a
//! quarter of a lit pixel's mean visible light; blue at a twentieth).
//!
//! `cargo run --release --example visibility -- [SCENE ...] [--size WxH] [--vpls N] [--stride N] [--ism-res N] [--points N] [--bias B] [--lift-all] [--region X0,Y0,X1,Y1] [--visibility ism|traced] [--back-faces] [--why] [--map DIR]`
//! (default: spheres, the slab rooms and the open box at 160x120, the
//! defaults' VPLs for that size, every 3rd geometry pixel).

use ssbc::cpu::bvh::SceneBvh;
use ssbc::cpu::emitters::luminance;
use ssbc::passes::indirect_bounded::{ism_bias, ism_test_for};
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};

/// The weighted replay of one frame.
#[derive(Default)]
struct Replay {
    visible: f64,
    passed: f64,
    occluded: f64,
    leaked: f64,
    leaked_beyond: f64,
    /// Pairs the front map passes whose texel carries the back-face flag
    /// (the gather reads its back face), and pairs it passes.
    flagged: usize,
    front_passed: usize,
    /// `--why`: rejected visible light where the centre ray meets an
    /// occluder, and where the texel stores a surface the centre ray does
    /// not meet; leaked light where the centre ray passes the occluder,
    /// where it meets it but the texel stores more, and where the
    /// tolerance reaches past it.
    rejected_edge: f64,
    rejected_overhang: f64,
    leaked_edge: f64,
    leaked_hole: f64,
    leaked_tolerance: f64,
    /// `--why`: leaked light by what its texel holds (the ray-cast layer, a
    /// surface of the receiver's orientation, one across it), each within
    /// and beyond the relative tolerance.
    leaked_by_texel: [f64; 6],
    pairs: usize,
    /// Per pixel: rejected visible, leaked and visible weight.
    map: Vec<[f64; 3]>,
}

/// What the replay asks for.
struct Options {
    stride: usize,
    /// The relative tolerance for Lambertian receivers.
    bias: f32,
    why: bool,
    /// `--lift-all`: the lifted test for every receiver, not only narrow
    /// glossy lobes.
    lift_all: bool,
    /// `--region X0,Y0,X1,Y1`: only the pixels in that box (X1, Y1 excluded).
    region: Option<[usize; 4]>,
}

fn replay(scene: &ssbc::Scene, frame: &Frame, options: &Options) -> Replay {
    let bvh = SceneBvh::new(scene);
    let ism = frame.ism.as_ref().expect("debug readback");
    let layer = |name: &str| {
        &frame
            .layer(name.parse().expect("a layer name"))
            .expect("debug readback")
            .rgba
    };
    let (pos, nrm, alb) = (
        layer("gbuffer_position"),
        layer("gbuffer_normal"),
        layer("gbuffer_albedo"),
    );
    let v = |img: &[f32], i: usize| glam::Vec3::new(img[i * 4], img[i * 4 + 1], img[i * 4 + 2]);
    let width = frame.width as usize;
    let mut r = Replay {
        map: vec![[0.0; 3]; width * frame.height as usize],
        ..Default::default()
    };
    let in_region = |i: usize| {
        options.region.is_none_or(|[x0, y0, x1, y1]| {
            (x0..x1).contains(&(i % width)) && (y0..y1).contains(&(i / width))
        })
    };
    let geometry = (0..(frame.width * frame.height) as usize)
        .filter(|&i| pos[i * 4 + 3] != 0.0 && in_region(i));
    for i in geometry.step_by(options.stride) {
        let (x, n) = (v(pos, i), v(nrm, i));
        let albedo = glam::Vec4::from_slice(&alb[i * 4..i * 4 + 4]);
        let brdf = ssbc::cpu::brdf::Brdf::from_gbuffer(albedo, nrm[i * 4 + 3]);
        for (k, vpl) in frame.vpls.iter().enumerate() {
            let d = x - vpl.position;
            let d2 = d.length_squared();
            if d2 < 1e-10 {
                continue;
            }
            let w = d / d2.sqrt();
            let (cos_z, cos_x) = (vpl.normal.dot(w), -n.dot(w));
            if cos_z <= 0.0 || cos_x <= 0.0 {
                continue;
            }
            let weight = (luminance(vpl.flux) * (cos_z * cos_x / d2).min(frame.bound)) as f64;
            r.pairs += 1;
            let exact = !bvh.occluded(vpl.position + vpl.normal * 1e-4, x + n * 1e-4);
            let mut test = ism_test_for(&brdf, options.bias);
            test.lifted |= options.lift_all;
            let approx = ism.visible(k, vpl, x, n, test);
            if ism.front_visible(k, vpl, x, n, test) {
                r.front_passed += 1;
                r.flagged += ism.back_face_flagged(k, vpl, x) as usize;
            }
            let pixel = &mut r.map[i];
            match (exact, approx) {
                (true, true) => pixel[2] += weight,
                (true, false) => (pixel[0], pixel[2]) = (pixel[0] + weight, pixel[2] + weight),
                (false, true) => pixel[1] += weight,
                (false, false) => {}
            }
            if exact {
                r.visible += weight;
                r.passed += weight * approx as u8 as f64;
            } else {
                r.occluded += weight;
                if approx {
                    r.leaked += weight;
                    r.leaked_beyond += weight * ism.stored_beyond(k, vpl, x) as u8 as f64;
                }
            }
            if options.why && exact != approx {
                let from = vpl.position + vpl.normal * 1e-4;
                let (ray, stored) = ism.texel_centre_ray(k, vpl, x);
                let centre = bvh
                    .intersect(from, ray, 0.0, f32::MAX)
                    .map_or(f32::MAX, |h| h.t);
                let footprint = (d2.sqrt() * 4.0 / ism.tile as f32).max(ism.point_radius);
                if exact {
                    if centre < d2.sqrt() - footprint {
                        r.rejected_edge += weight;
                    } else if stored < centre - footprint {
                        r.rejected_overhang += weight;
                    }
                } else {
                    let occluder = bvh.intersect(from, w, 0.0, d2.sqrt()).map_or(0.0, |h| h.t);
                    if centre > occluder + footprint {
                        r.leaked_edge += weight;
                    } else if stored > centre + footprint {
                        r.leaked_hole += weight;
                    } else {
                        r.leaked_tolerance += weight;
                    }
                    let holds = match ism.stored_normal(k, vpl, x) {
                        None => 0,
                        Some(m) if m.dot(n).abs() > 0.9 => 1,
                        Some(_) => 2,
                    };
                    let relative = test.relative_bias * d2.sqrt() + 1e-3;
                    let beyond = d2.sqrt() > stored + relative;
                    r.leaked_by_texel[holds * 2 + beyond as usize] += weight;
                }
            }
        }
    }
    r
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).cloned()
    };
    let flags = [
        "--size",
        "--vpls",
        "--stride",
        "--ism-res",
        "--points",
        "--bias",
        "--region",
        "--visibility",
        "--map",
    ];
    let flag_values: Vec<String> = flags.iter().filter_map(|f| value(f)).collect();
    let mut scenes: Vec<String> = args
        .iter()
        .filter(|a| !a.starts_with("--") && !flag_values.contains(a))
        .cloned()
        .collect();
    if scenes.is_empty() {
        scenes = [
            "spheres",
            "tests/scenes/slabs-room.gltf",
            "tests/scenes/slabs-room-1mm.gltf",
            "assets/open-front-box.gltf",
        ]
        .map(String::from)
        .to_vec();
    }
    let (width, height) = value("--size")
        .and_then(|s| {
            let (w, h) = s.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or((160, 120));
    let visibility: ssbc::settings::Visibility = match value("--visibility") {
        Some(v) => v.parse()?,
        None => ssbc::settings::Visibility::Ism,
    };
    let options = Options {
        stride: value("--stride").and_then(|v| v.parse().ok()).unwrap_or(3),
        bias: value("--bias")
            .and_then(|v| v.parse().ok())
            .unwrap_or(ism_bias(visibility)),
        why: args.iter().any(|a| a == "--why"),
        lift_all: args.iter().any(|a| a == "--lift-all"),
        region: value("--region").and_then(|v| {
            let c: Vec<usize> = v.split(',').filter_map(|c| c.parse().ok()).collect();
            c.try_into().ok()
        }),
    };
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    print!("| scene | passed (of visible) | leaked (of occluded) | net (ISM light / exact) | leaked beyond the stored depth | pairs | back faces read (of pairs the front map passes) |");
    if options.why {
        print!(" rejected: edge / overhang | leaked: edge / hole / tolerance | leaked, within / beyond the relative tolerance: layer; own orientation; across |");
    }
    println!();
    println!(
        "|---|---|---|---|---|---|---|{}",
        if options.why { "---|---|---|" } else { "" }
    );
    for name in &scenes {
        let mut scene = ssbc::scene::load(name)?;
        scene.ensure_light();
        let mut settings = RenderSettings::new(width, height);
        if let Some(n) = value("--vpls").and_then(|v| v.parse().ok()) {
            settings.vpl.count = n;
        }
        if let Some(n) = value("--ism-res").and_then(|v| v.parse().ok()) {
            settings.ism_tile = n;
        }
        if let Some(n) = value("--points").and_then(|v| v.parse().ok()) {
            settings.points_per_vpl = n;
        }
        settings.debug_readback = true;
        settings.ssbc.steps = 0;
        settings.visibility = visibility;
        settings.ism_back_faces = args.iter().any(|a| a == "--back-faces");
        let frame = renderer.render(&scene, &settings)?;
        let r = replay(&scene, &frame, &options);
        if let Some(dir) = value("--map") {
            let file = std::path::Path::new(&dir).join(format!("{}.png", scene.name));
            write_map(&r, frame.width, frame.height, &file)?;
        }
        print!(
            "| {} | {:.4} | {:.4} | {:.4} | {:.0}% | {} | {:.1}% |",
            scene.name,
            r.passed / r.visible.max(1e-30),
            r.leaked / r.occluded.max(1e-30),
            (r.passed + r.leaked) / r.visible.max(1e-30),
            100.0 * r.leaked_beyond / r.leaked.max(1e-30),
            r.pairs,
            100.0 * r.flagged as f64 / r.front_passed.max(1) as f64,
        );
        if options.why {
            let rejected = (r.visible - r.passed).max(1e-30);
            print!(
                " {:.0}% / {:.0}% | {:.0}% / {:.0}% / {:.0}% |",
                100.0 * r.rejected_edge / rejected,
                100.0 * r.rejected_overhang / rejected,
                100.0 * r.leaked_edge / r.leaked.max(1e-30),
                100.0 * r.leaked_hole / r.leaked.max(1e-30),
                100.0 * r.leaked_tolerance / r.leaked.max(1e-30),
            );
            let share = r.leaked_by_texel.map(|w| 100.0 * w / r.leaked.max(1e-30));
            print!(
                " {:.0}% / {:.0}%; {:.0}% / {:.0}%; {:.0}% / {:.0}% |",
                share[0], share[1], share[2], share[3], share[4], share[5]
            );
        }
        println!();
    }
    Ok(())
}

/// `--map`: where the replay's errors lie in the image.
fn write_map(
    r: &Replay,
    width: u32,
    height: u32,
    file: &std::path::Path,
) -> Result<(), Box<dyn std::error::Error>> {
    let lit = r.map.iter().filter(|m| m[2] > 0.0).count().max(1);
    let mean = r.visible / lit as f64;
    let level = |x: f64| (255.0 * (4.0 * x / mean).sqrt().min(1.0)) as u8;
    let rgb: Vec<u8> = r
        .map
        .iter()
        .flat_map(|m| [level(m[0]), level(m[1]), level(m[2] / 20.0)])
        .collect();
    let map = image::RgbImage::from_raw(width, height, rgb).ok_or("map size")?;
    // Four screen pixels a pixel: small frames stay readable.
    let filter = image::imageops::FilterType::Nearest;
    image::imageops::resize(&map, width * 4, height * 4, filter).save(file)?;
    Ok(())
}
