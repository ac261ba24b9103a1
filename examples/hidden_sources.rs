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
//! `--twin` adds the CPU twin: SSBC's brute force on exact G-buffers (ray
//! cast at pixel centres, layer-0 pixels split at creases as the GPU splits
//! them: `ssbc::cpu::ssbc::footprint`) with exact S0, and the ceiling over all steps
//! (Kollig–Keller's residual paths whose every source lies on layer 0, or on
//! layers 0 and 1). `--camera-shift DX,DY` moves the camera sideways (metres)
//! to change the pixel grid's phase against the scene's edges.
//!
//! `--separation F` sets layer 1's minimum separation (a fraction of the
//! scene's diagonal; default: the renderer's).
//!
//! `cargo run --release --example hidden_sources -- [SCENE] [--size WxH] [--vpls N] [--bound B] [--spp N] [--twin] [--camera-shift DX,DY] [--separation F]`
//! (default: assets/open-front-box.gltf, 160x120, 256 VPLs, b = 0.5, 64 spp).

use std::sync::atomic::AtomicBool;

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use ssbc::cpu::bvh::Surface;
use ssbc::cpu::emitters::luminance;
use ssbc::cpu::sampling::{cosine_hemisphere, Halton};
use ssbc::cpu::ssbc::{footprint, pixel_area, residual_weight, GBufferView, TwinCamera};
use ssbc::reference::{Method, Reference, ReferenceSettings};
use ssbc::renderer::{Bound, RenderSettings, Renderer, RendererConfig};
use ssbc::scene::Scene;
use ssbc::settings::LayerResolution;
use ssbc::settings::VplSettings;

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
    let flags = [
        "--size",
        "--vpls",
        "--bound",
        "--spp",
        "--camera-shift",
        "--separation",
    ];
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
    let separation: f32 = value("--separation")
        .and_then(|v| v.parse().ok())
        .unwrap_or(ssbc::settings::SsbcSettings::default().layer_separation);
    let mut scene = ssbc::scene::load(&scene_name)?;
    scene.ensure_light();
    if let Some((dx, dy)) = value("--camera-shift").and_then(|v| {
        let (x, y) = v.split_once(',')?;
        Some((x.parse::<f32>().ok()?, y.parse::<f32>().ok()?))
    }) {
        // Moves the camera sideways (metres, in its own right/up axes): the
        // pixel grid's phase against the scene's edges changes.
        let mut camera = scene.camera(None)?;
        let right = camera.forward.cross(camera.up).normalize();
        camera.position += right * dx + camera.up * dy;
        scene.cameras = vec![camera];
    }
    let centre = |i: usize| {
        let (x, y) = ((i as u32) % w, (i as u32) / w);
        (w / 4..3 * w / 4).contains(&x) && (h / 4..3 * h / 4).contains(&y)
    };
    let everywhere = |_: usize| true;
    let vpl = VplSettings {
        count: vpls,
        bounces: 16,
        seed: 0,
        first_path: 0,
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
    let render =
        |renderer: &mut Renderer, steps: u32, layer1: Option<LayerResolution>, guard_band: bool| {
            let mut s = RenderSettings::new(w, h);
            s.ssbc.guard_band = guard_band;
            s.vpl = vpl.clone();
            s.bound = Bound::Value(bound);
            s.ssbc.steps = steps;
            s.ssbc.layer_separation = separation;
            s.ssbc.layers = 1 + layer1.is_some() as u32;
            s.ssbc.layer1_resolution = layer1.unwrap_or_default();
            renderer.render(&scene, &s).map(|f| f.image.rgba)
        };
    let clamped_gpu = render(&mut renderer, 0, None, false)?;
    let configs = [
        ("1", None, false),
        ("1, guard band", None, true),
        ("2 (layer 1 half)", Some(LayerResolution::Half), false),
        ("2 (layer 1 full)", Some(LayerResolution::Full), false),
        (
            "2 (layer 1 full), guard band",
            Some(LayerResolution::Full),
            true,
        ),
    ];
    for (layers, layer1, guard_band) in configs {
        for steps in 1..=3 {
            let gpu = render(&mut renderer, steps, layer1, guard_band)?;
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

    if args.iter().any(|a| a == "--twin") {
        let truth = Truth {
            kk: &kk,
            clamped: &clamped,
            width: w,
            height: h,
        };
        twin_report(&scene, &truth, bound, spp, &vpl, separation)?;
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
    for separation in [0.002, 0.02, 0.1].map(|f| f * diagonal) {
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

/// The true residual per pixel (Kollig–Keller minus the clamped VPL sum).
struct Truth<'a> {
    kk: &'a [f32],
    clamped: &'a [f32],
    width: u32,
    height: u32,
}

impl Truth<'_> {
    fn in_centre(&self, i: usize) -> bool {
        let (w, h) = (self.width, self.height);
        let (x, y) = ((i as u32) % w, (i as u32) / w);
        (w / 4..3 * w / 4).contains(&x) && (h / 4..3 * h / 4).contains(&y)
    }

    /// Mean true residual (luminance) over the whole image and its centre.
    fn means(&self) -> (f64, f64) {
        let at = |i: usize| {
            let (a, b) = (&self.kk[i * 4..i * 4 + 3], &self.clamped[i * 4..i * 4 + 3]);
            luminance(Vec3::from_slice(a) - Vec3::from_slice(b)) as f64
        };
        let n = (self.width * self.height) as usize;
        let whole = (0..n).map(at).sum::<f64>() / n as f64;
        let centre: Vec<usize> = (0..n).filter(|&i| self.in_centre(i)).collect();
        let c = centre.iter().map(|&i| at(i)).sum::<f64>() / centre.len() as f64;
        (whole, c)
    }
}

/// A screen-space source and receiver of the CPU twin: a layer-0 pixel or
/// a layer-1 pixel, on exact geometry.
struct TwinPoint {
    surface: Surface,
    area: f32,
    /// S0: direct light plus the clamped VPL sum with exact visibility.
    s0: Vec3,
    /// The layer-0 pixel, or None on layer 1.
    pixel: Option<usize>,
    /// A layer-0 pixel's part beyond a crease, as the GPU reconstructs it
    /// (`ssbc::cpu::ssbc::footprint`): centroid, normal, area, and the
    /// point whose S it carries.
    other: Option<(Vec3, Vec3, f32, usize)>,
}

/// Ray-cast G-buffers at pixel centres: layer 0, then (with `layer1`)
/// layer 1 as the GPU peels it: per layer-1 pixel (at half resolution 2 x 2
/// image pixels), the nearest surface at least `separation` beyond the
/// farthest of the layer-0 depths under it, back faces included, with
/// outward normals. Full-resolution layers are split at creases as the GPU
/// splits them.
fn twin_points(
    tracer: &Reference,
    scene: &Scene,
    truth: &Truth,
    layer1: Option<LayerResolution>,
    separation: f32,
) -> Vec<TwinPoint> {
    let (bvh, camera) = (tracer.bvh(), tracer.camera());
    let (w, h) = (truth.width, truth.height);
    let pixel_side = 2.0 * (camera.yfov * 0.5).tan() / h as f32;
    let min_cos_view = ssbc::settings::SsbcSettings::default().min_cos_view;
    let point = |surface: Surface, side: f32, pixel: Option<usize>| TwinPoint {
        other: None,
        area: pixel_area(
            surface.position,
            surface.normal,
            camera.position,
            camera.forward,
            side,
            min_cos_view,
        ),
        s0: tracer.clamped_radiance(&surface),
        surface,
        pixel,
    };
    let twin_camera = TwinCamera {
        position: camera.position,
        forward: camera.forward,
        up: camera.up,
        pixel_side,
        min_cos_view,
        principal: glam::Vec2::ZERO,
    };
    let mut depth = vec![f32::INFINITY; (w * h) as usize];
    let mut points = Vec::new();
    let mut at = Vec::new();
    for (i, d) in depth.iter_mut().enumerate() {
        let dir = camera.pixel_ray((i as u32 % w) as f32, (i as u32 / w) as f32, w, h);
        if let Some(hit) = bvh.intersect_camera(scene, camera.position, dir) {
            *d = hit.t * dir.dot(camera.forward);
            points.push(point(bvh.surface(scene, &hit, -dir), pixel_side, Some(i)));
            at.push(i);
        }
    }
    split_at_creases(&mut points, &at, w, h, &twin_camera);
    let Some(layer1) = layer1 else {
        return points;
    };
    let side = 1u32 << layer1.shift();
    let (w1, h1) = layer1.extent((w, h));
    let (mut hidden, mut at) = (Vec::new(), Vec::new());
    for y in 0..h1 {
        for x in 0..w1 {
            let under = (0..side * side).filter_map(|k| {
                let (px, py) = (x * side + k % side, y * side + k / side);
                (px < w && py < h).then(|| depth[(py * w + px) as usize])
            });
            let far = under.fold(0.0f32, f32::max);
            if !far.is_finite() {
                continue;
            }
            let centre = (Vec2::new(x as f32, y as f32) + 0.5) * side as f32 - 0.5;
            let dir = camera.pixel_ray(centre.x, centre.y, w, h);
            let tmin = (far + separation) / dir.dot(camera.forward);
            if let Some(hit) = bvh.intersect(camera.position, dir, tmin, f32::INFINITY) {
                let mut s = bvh.surface(scene, &hit, -dir);
                if !s.front {
                    s.normal = -s.normal;
                    s.geometric_normal = -s.geometric_normal;
                }
                hidden.push(point(s, side as f32 * pixel_side, None));
                at.push((y * w1 + x) as usize);
            }
        }
    }
    if layer1 == LayerResolution::Full {
        split_at_creases(&mut hidden, &at, w, h, &twin_camera);
        // Crease parts point into this layer's points, which follow layer 0's.
        let offset = points.len();
        for p in &mut hidden {
            if let Some(o) = &mut p.other {
                o.3 += offset;
            }
        }
    }
    points.extend(hidden);
    points
}

/// The footprints of one full-resolution layer's points (`points[k]` at
/// pixel `at[k]`), split at creases as the GPU splits them; a part beyond a
/// crease carries the index (in `points`) of the point whose S it takes.
fn split_at_creases(points: &mut [TwinPoint], at: &[usize], w: u32, h: u32, camera: &TwinCamera) {
    let (mut position, mut normal) = (
        vec![0.0; (w * h * 4) as usize],
        vec![0.0; (w * h * 4) as usize],
    );
    let mut point_at = vec![usize::MAX; (w * h) as usize];
    for (k, (p, &i)) in points.iter().zip(at).enumerate() {
        position[i * 4..i * 4 + 4].copy_from_slice(&p.surface.position.extend(1.0).to_array());
        normal[i * 4..i * 4 + 3].copy_from_slice(&p.surface.normal.to_array());
        point_at[i] = k;
    }
    let view = GBufferView {
        width: w,
        height: h,
        position: &position,
        normal: &normal,
        albedo: &normal,
    };
    for (p, &i) in points.iter_mut().zip(at) {
        let f = footprint(&view, camera, i as u32 % w, i as u32 / w);
        p.area = f.own_area;
        p.other = f.other.map(|(c, n, a, j)| (c, n, a, point_at[j]));
    }
}

/// K brute-force SSBC steps over every point pair (no visibility, as on the
/// GPU): per step, the recovered share of the true residual (whole, centre).
fn twin_steps(points: &[TwinPoint], truth: &Truth, bound: f32, steps: u32) -> Vec<(f64, f64)> {
    let (truth_whole, truth_centre) = truth.means();
    let n = (truth.width * truth.height) as usize;
    let n_centre = (0..n).filter(|&i| truth.in_centre(i)).count() as f64;
    let mut source: Vec<Vec3> = points.iter().map(|p| p.s0).collect();
    let mut total = vec![Vec3::ZERO; points.len()];
    let mut shares = Vec::new();
    for _ in 0..steps {
        source = points
            .par_iter()
            .map(|x| {
                let (px, nx) = (x.surface.position, x.surface.normal);
                let own = points
                    .iter()
                    .zip(&source)
                    .map(|(y, s)| (y.surface.position, y.surface.normal, y.area, *s));
                let across = points
                    .iter()
                    .filter_map(|y| y.other)
                    .map(|(c, n, a, j)| (c, n, a, source[j]));
                let sum: Vec3 = own
                    .chain(across)
                    .map(|(y, ny, area, s)| residual_weight(px, nx, y, ny, bound) * area * s)
                    .sum();
                x.surface.albedo / std::f32::consts::PI * sum
            })
            .collect();
        let (mut whole, mut centre) = (0.0, 0.0);
        for ((p, t), s) in points.iter().zip(&mut total).zip(&source) {
            *t += *s;
            if let Some(i) = p.pixel {
                let v = luminance(*t) as f64;
                whole += v;
                if truth.in_centre(i) {
                    centre += v;
                }
            }
        }
        shares.push((
            whole / n as f64 / truth_whole,
            centre / n_centre / truth_centre,
        ));
    }
    shares
}

/// Kollig–Keller's residual paths from every layer-0 pixel (8 hops), the
/// whole and the part whose every residual source is on layer 0 (or on
/// layers 0 and 1): what a perfect screen-space integration over those
/// layers could give back, over all steps. Shares of the true residual
/// (whole, centre) in that order: [layer 0, layers 0 + 1, all].
fn screen_space_ceiling(
    tracer: &Reference,
    scene: &Scene,
    points: &[TwinPoint],
    truth: &Truth,
    bound: f32,
    spp: u32,
    separation: f32,
) -> [(f64, f64); 3] {
    let (bvh, camera) = (tracer.bvh(), tracer.camera());
    let layer_of = |q: Vec3| -> u8 {
        let v = q - camera.position;
        let t = v.length();
        let dir = v / t;
        let tolerance = 1e-3 * t + 1e-4;
        match bvh.intersect_camera(scene, camera.position, dir) {
            Some(first) if (first.t - t).abs() <= tolerance => 0,
            Some(first) => {
                match bvh.intersect(camera.position, dir, first.t + separation, f32::INFINITY) {
                    Some(second) if (second.t - t).abs() <= tolerance => 1,
                    _ => 2,
                }
            }
            None => 2,
        }
    };
    let per_pixel: Vec<(usize, [f64; 3])> = points
        .par_iter()
        .filter_map(|p| Some((p.pixel?, p)))
        .map(|(i, p)| {
            let halton = Halton::new(i as u64 ^ 0x5EED);
            let mut out = [0.0; 3];
            for k in 0..spp as u64 {
                let (mut s, mut weight, mut deepest) = (p.surface, Vec3::ONE, 0u8);
                for bounce in 0..8usize {
                    let u = Vec2::new(
                        halton.sample(k, 2 * bounce),
                        halton.sample(k, 2 * bounce + 1),
                    );
                    let Some((y, w)) = residual_hop(tracer, scene, &s, u, bound) else {
                        break;
                    };
                    weight *= w;
                    deepest = deepest.max(layer_of(y.position));
                    let c = luminance(weight * tracer.clamped_radiance(&y)) as f64 / spp as f64;
                    for (layer, o) in out.iter_mut().enumerate() {
                        if usize::from(deepest) <= layer {
                            *o += c;
                        }
                    }
                    s = y;
                }
            }
            (i, out)
        })
        .collect();
    let (truth_whole, truth_centre) = truth.means();
    let n = (truth.width * truth.height) as f64;
    let n_centre = (0..n as usize).filter(|&i| truth.in_centre(i)).count() as f64;
    [0, 1, 2].map(|k| {
        let whole: f64 = per_pixel.iter().map(|(_, o)| o[k]).sum();
        let centre: f64 = per_pixel
            .iter()
            .filter(|(i, _)| truth.in_centre(*i))
            .map(|(_, o)| o[k])
            .sum();
        (whole / n / truth_whole, centre / n_centre / truth_centre)
    })
}

/// One hop of a residual path: a cosine-sampled ray from `s` to y, kept
/// where G > b, with the weight albedo (1 - b/G).
fn residual_hop(
    tracer: &Reference,
    scene: &Scene,
    s: &Surface,
    u: Vec2,
    bound: f32,
) -> Option<(Surface, Vec3)> {
    let d = cosine_hemisphere(s.normal, u);
    if d.dot(s.geometric_normal) <= 0.0 {
        return None;
    }
    let origin = s.position + s.geometric_normal * 1e-4 * (1.0 + s.position.abs().max_element());
    let hit = tracer.bvh().intersect(origin, d, 0.0, f32::INFINITY)?;
    let y = tracer.bvh().surface(scene, &hit, -d);
    let g = s.normal.dot(d) * y.normal.dot(-d) / (hit.t * hit.t);
    (g > bound).then(|| (y, s.albedo * (1.0 - bound / g)))
}

/// The CPU twin: SSBC's brute force on exact G-buffers with exact S0 (no
/// GPU approximation left), against the true residual and against the
/// ceiling of a perfect screen-space integration.
fn twin_report(
    scene: &Scene,
    truth: &Truth,
    bound: f32,
    spp: u32,
    vpl: &VplSettings,
    separation: f32,
) -> Result<(), Box<dyn std::error::Error>> {
    let tracer = Reference::new(
        scene,
        ReferenceSettings {
            width: truth.width,
            height: truth.height,
            spp: 1,
            bounces: 16,
            method: Method::Vpl,
            vpl: vpl.clone(),
            bound,
            ..Default::default()
        },
    )?;
    let separation = separation * 2.0 * scene.bounds().radius();
    println!("\n### CPU twin: exact G-buffers, exact S0, brute force\n");
    println!("| G-buffer layers | 1 step | 2 steps | 3 steps | 3 steps, centre | ceiling, all steps | ceiling, centre |");
    println!("|---|---|---|---|---|---|---|");
    let configs = [
        ("1", None),
        ("2 (layer 1 half)", Some(LayerResolution::Half)),
        ("2 (layer 1 full)", Some(LayerResolution::Full)),
    ];
    let mut ceiling = None;
    for (layers, layer1) in configs {
        let points = twin_points(&tracer, scene, truth, layer1, separation);
        let ceiling = *ceiling.get_or_insert_with(|| {
            screen_space_ceiling(&tracer, scene, &points, truth, bound, spp, separation)
        });
        let shares = twin_steps(&points, truth, bound, 3);
        let c = ceiling[layer1.is_some() as usize];
        println!(
            "| {layers} | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% | {:.1}% |",
            100.0 * shares[0].0,
            100.0 * shares[1].0,
            100.0 * shares[2].0,
            100.0 * shares[2].1,
            100.0 * c.0,
            100.0 * c.1
        );
    }
    if let Some(ceiling) = ceiling {
        println!(
            "\nAll residual paths (8 hops, {spp} per pixel) over Kollig–Keller: {:.1}% (whole), {:.1}% (centre)",
            100.0 * ceiling[2].0,
            100.0 * ceiling[2].1
        );
    }
    Ok(())
}
