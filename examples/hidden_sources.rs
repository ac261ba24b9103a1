//! Where SSBC's missing light comes from: how much of the energy clamping
//! removed one to three SSBC steps give back, over the whole image and in
//! its centre (its middle half in each direction), and the ceiling of a
//! screen-space method: the share of the true residual whose sources are
//! surfaces the camera sees (layer 0), the nearest surface at least a
//! separation behind them, back faces included (a deep G-buffer's layer 1),
//! and surfaces just outside the image (a guard band of 1/sqrt(b) projected
//! at the nearest visible depth).
//!
//! The true residual at a visible point x is Kollig & Keller's first hop:
//! a cosine-sampled ray to y, weighted by albedo(x) (1 - b/G) where G > b,
//! times the path-traced radiance leaving y. Recovery compares the GPU's
//! SSBC with Kollig–Keller and the clamped VPL sum of the CPU reference
//! (the same VPLs).
//!
//! `cargo run --release --example hidden_sources -- [SCENE] [--size WxH] [--vpls N] [--bound B] [--spp N]`
//! (default: assets/open-front-box.gltf, 160x120, 256 VPLs, b = 0.5, 64 spp).

use std::sync::atomic::AtomicBool;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use ssbc::cpu::emitters::luminance;
use ssbc::cpu::reference::{Method, Reference, ReferenceSettings};
use ssbc::cpu::sampling::{cosine_hemisphere, Halton};
use ssbc::cpu::vpl::VplSettings;
use ssbc::renderer::{Bound, RenderSettings, Renderer, RendererConfig};

/// Where a residual source lies.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Place {
    Layer0,
    Layer1,
    Deeper,
    GuardLayer0,
    GuardLayer1,
    Outside,
}

const PLACES: [Place; 6] = [
    Place::Layer0,
    Place::Layer1,
    Place::Deeper,
    Place::GuardLayer0,
    Place::GuardLayer1,
    Place::Outside,
];

fn mean_luminance(rgba: &[f32], keep: impl Fn(usize) -> bool) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for (i, p) in rgba.chunks_exact(4).enumerate() {
        if keep(i) {
            sum += luminance(Vec3::new(p[0], p[1], p[2])) as f64;
            n += 1;
        }
    }
    sum / n.max(1) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        args.get(i + 1).cloned()
    };
    let flags = ["--size", "--vpls", "--bound", "--spp"];
    let scene_name = args
        .iter()
        .enumerate()
        .find(|(i, a)| !a.starts_with("--") && (*i == 0 || !flags.contains(&args[i - 1].as_str())))
        .map_or("assets/open-front-box.gltf".to_string(), |(_, a)| a.clone());
    let (w, h) = value("--size")
        .and_then(|s| {
            let (w, h) = s.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .unwrap_or((160u32, 120u32));
    let vpls: usize = value("--vpls").and_then(|v| v.parse().ok()).unwrap_or(256);
    let bound: f32 = value("--bound").and_then(|v| v.parse().ok()).unwrap_or(0.5);
    let spp: u32 = value("--spp").and_then(|v| v.parse().ok()).unwrap_or(64);
    let mut scene = ssbc::scene::load(&scene_name)?;
    scene.ensure_light();
    let centre = |i: usize| {
        let (x, y) = ((i as u32) % w, (i as u32) / w);
        (w / 4..3 * w / 4).contains(&x) && (h / 4..3 * h / 4).contains(&y)
    };
    let everywhere = |_: usize| true;
    let vpl = VplSettings {
        count: vpls,
        bounces: 16,
        seed: 0,
    };
    let reference = |method| -> Result<Vec<f32>, ssbc::Error> {
        Ok(Reference::new(
            &scene,
            ReferenceSettings {
                width: w,
                height: h,
                spp,
                bounces: 16,
                method,
                vpl: vpl.clone(),
                bound,
                ..Default::default()
            },
        )?
        .render(&AtomicBool::new(false), |_| {})
        .0)
    };
    let kk = reference(Method::KolligKeller)?;
    let clamped = reference(Method::Vpl)?;

    // Recovery: what SSBC gives back of what clamping removed.
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    println!("## {scene_name}, {w}x{h}, {vpls} VPLs, b = {bound}\n");
    println!("| G-buffer layers | SSBC steps | recovered (whole image) | recovered (centre) |\n|---|---|---|---|");
    let render = |renderer: &mut Renderer, steps: u32, layers: u32| {
        let mut s = RenderSettings::new(w, h);
        s.vpl = vpl.clone();
        s.bound = Bound::Value(bound);
        s.ssbc.steps = steps;
        s.ssbc.layers = layers;
        renderer.render(&scene, &s).map(|f| f.image.rgba)
    };
    let clamped_gpu = render(&mut renderer, 0, 1)?;
    for layers in [1, 2] {
        for steps in 1..=3 {
            let gpu = render(&mut renderer, steps, layers)?;
            let share = |keep: &dyn Fn(usize) -> bool| {
                (mean_luminance(&gpu, keep) - mean_luminance(&clamped_gpu, keep))
                    / (mean_luminance(&kk, keep) - mean_luminance(&clamped, keep))
            };
            println!(
                "| {layers} | {steps} | {:.1}% | {:.1}% |",
                100.0 * share(&everywhere),
                100.0 * share(&centre)
            );
        }
    }

    // The ceiling: where the true residual's sources lie.
    let tracer = Reference::new(
        &scene,
        ReferenceSettings {
            width: w,
            height: h,
            spp: 1,
            bounces: 16,
            ..Default::default()
        },
    )?;
    let (bvh, camera) = (tracer.bvh(), tracer.camera());
    let right = camera.forward.cross(camera.up).normalize();
    let tan_y = (camera.yfov * 0.5).tan();
    let tan_x = tan_y * w as f32 / h as f32;
    // The nearest visible depth sizes the guard band.
    let mut nearest = f32::MAX;
    for y in 0..h {
        for x in 0..w {
            let dir = camera.pixel_ray(x as f32, y as f32, w, h);
            if let Some(hit) = bvh.intersect_camera(&scene, camera.position, dir) {
                nearest = nearest.min(hit.t * dir.dot(camera.forward));
            }
        }
    }
    let reach = 1.0 / bound.sqrt();
    let (guard_x, guard_y) = (reach / (nearest * tan_x), reach / (nearest * tan_y));
    println!(
        "\nGuard band: 1/sqrt(b) = {reach:.2} m at the nearest visible depth {nearest:.2} m: {:.0} x {:.0} pixels each side\n",
        guard_x * w as f32 * 0.5,
        guard_y * h as f32 * 0.5
    );
    let diagonal = 2.0 * scene.bounds().radius();
    println!("| separation | region | layer 0 | layer 1 | deeper | guard band, layer 0 | guard band, layer 1 | outside | 0 + 1 | 0 + 1 + guard |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for separation in [0.02 * diagonal, 0.05 * diagonal, 0.1 * diagonal] {
        let place = |p: Vec3| {
            let v = p - camera.position;
            let depth = v.dot(camera.forward);
            if depth <= 0.0 {
                return Place::Outside;
            }
            let (nx, ny) = (
                v.dot(right) / (depth * tan_x),
                v.dot(camera.up) / (depth * tan_y),
            );
            let inside = nx.abs() <= 1.0 && ny.abs() <= 1.0;
            let guard = nx.abs() <= 1.0 + guard_x && ny.abs() <= 1.0 + guard_y;
            if !guard {
                return Place::Outside;
            }
            let t = v.length();
            let dir = v / t;
            let tolerance = 1e-3 * t + 1e-4;
            let Some(first) = bvh.intersect_camera(&scene, camera.position, dir) else {
                return Place::Deeper;
            };
            let layer = if (first.t - t).abs() <= tolerance {
                0
            } else {
                match bvh.intersect(camera.position, dir, first.t + separation, f32::INFINITY) {
                    Some(second) if (second.t - t).abs() <= tolerance => 1,
                    _ => 2,
                }
            };
            match (inside, layer) {
                (true, 0) => Place::Layer0,
                (true, 1) => Place::Layer1,
                (_, 2) => Place::Deeper,
                (false, 0) => Place::GuardLayer0,
                _ => Place::GuardLayer1,
            }
        };
        // Per pixel: residual by place (whole image, centre).
        let sums: Vec<[f64; 6]> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let mut out = [0.0f64; 6];
                let dir = camera.pixel_ray(x as f32, y as f32, w, h);
                let Some(hit) = bvh.intersect_camera(&scene, camera.position, dir) else {
                    return out;
                };
                let s = bvh.surface(&scene, &hit, -dir);
                let halton = Halton::new(i as u64);
                for k in 0..spp as u64 {
                    let d = cosine_hemisphere(
                        s.normal,
                        Vec2::new(halton.sample(k, 0), halton.sample(k, 1)),
                    );
                    if d.dot(s.geometric_normal) <= 0.0 {
                        continue;
                    }
                    let origin = s.position
                        + s.geometric_normal * 1e-4 * (1.0 + s.position.abs().max_element());
                    let Some(yh) = bvh.intersect(origin, d, 0.0, f32::INFINITY) else {
                        continue;
                    };
                    let ys = bvh.surface(&scene, &yh, -d);
                    let g = s.normal.dot(d) * ys.normal.dot(-d) / (yh.t * yh.t);
                    if g <= bound {
                        continue;
                    }
                    let radiance = ys.emission + tracer.path_radiance(&ys, i as u64, k, 0, 16);
                    let c = luminance(s.albedo * (1.0 - bound / g) * radiance) as f64;
                    let at = PLACES
                        .iter()
                        .position(|&p| p == place(ys.position))
                        .unwrap();
                    out[at] += c / spp as f64;
                }
                out
            })
            .collect();
        for (label, keep) in [
            ("whole", &everywhere as &dyn Fn(usize) -> bool),
            ("centre", &centre),
        ] {
            let mut total = [0.0f64; 6];
            for (i, s) in sums.iter().enumerate() {
                if keep(i) {
                    for k in 0..6 {
                        total[k] += s[k];
                    }
                }
            }
            let all: f64 = total.iter().sum();
            let pct = |k: usize| 100.0 * total[k] / all.max(1e-30);
            println!(
                "| {separation:.2} m | {label} | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% |",
                pct(0),
                pct(1),
                pct(2),
                pct(3),
                pct(4),
                pct(5),
                pct(0) + pct(1),
                pct(0) + pct(1) + pct(3) + pct(4)
            );
        }
    }
    Ok(())
}
