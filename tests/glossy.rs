//! glTF metallic-roughness materials end to end: the GLSL BRDF against the
//! CPU one, and on the `spheres` built-in (and a mostly metallic variant)
//! the GPU against the path tracer, which honours the same BRDF: direct
//! light, the whole image at the defaults, and what the clamping removes
//! given back by Kollig & Keller's compensation.

mod common;

use std::sync::atomic::AtomicBool;

use ash::vk;
use glam::Vec3;
use gpu_allocator::MemoryLocation;
use ssbc::compare::{block_average, compare};
use ssbc::cpu::brdf::Brdf;
use ssbc::reference::{Method, Reference, ReferenceSettings};
use ssbc::renderer::RenderSettings;
use ssbc::scene::{Material, Reflectance, Scene};
use ssbc::shaders::brdf_probe_comp;
use ssbc::vk::{Access, Buffer, CommandPool, ComputeKernel, DescriptorPool, Device, Work};

/// `ProbeInput` in brdf_probe.comp.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct ProbeInput {
    base_metallic: [f32; 4],
    n_roughness: [f32; 4],
    wo_specular: [f32; 4],
    wi: [f32; 4],
}

/// A deterministic unit vector in the hemisphere around +Z.
fn hemisphere(i: u32, k: u32) -> Vec3 {
    let h = |j: u32| {
        let x =
            (i.wrapping_mul(2_654_435_761) ^ j.wrapping_mul(40_503)).wrapping_mul(2_246_822_519);
        (x >> 8) as f32 / (1u32 << 24) as f32
    };
    let (z, phi) = (
        0.02 + 0.98 * h(2 * k),
        2.0 * std::f32::consts::PI * h(2 * k + 1),
    );
    let r = (1.0 - z * z).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn glsl_brdf_matches_the_cpu_brdf() {
    let mut inputs = Vec::new();
    let mut cpu = Vec::new();
    for i in 0..4096u32 {
        let brdf = if i % 7 == 0 {
            Brdf::lambertian(Vec3::new(0.8, 0.4, 0.1))
        } else {
            Brdf {
                base: Vec3::new(0.9, 0.6, 0.3) * (0.2 + (i % 5) as f32 * 0.2),
                metallic: (i % 3) as f32 * 0.5,
                roughness: [0.0, 0.05, 0.2, 0.45, 0.7, 1.0][i as usize % 6],
                specular: 1.0,
            }
        };
        // A tilted normal: the BRDF in any frame.
        let tilt = glam::Quat::from_rotation_x(0.3 * (i % 4) as f32);
        let (n, wo, wi) = (
            tilt * Vec3::Z,
            tilt * hemisphere(i, 0),
            tilt * hemisphere(i, 1),
        );
        inputs.push(ProbeInput {
            base_metallic: brdf.base.extend(brdf.metallic).into(),
            n_roughness: n.extend(brdf.roughness).into(),
            wo_specular: wo.extend(brdf.specular).into(),
            wi: wi.extend(0.0).into(),
        });
        cpu.push(brdf.eval(n, wo, wi));
    }
    let renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let device: &std::sync::Arc<Device> = renderer.device();
    let gpu: Vec<[f32; 4]> = {
        let kernel = ComputeKernel::<brdf_probe_comp::Interface>::new(device).unwrap();
        let input = Buffer::with_data(
            device,
            "probe.inputs",
            &inputs,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )
        .unwrap();
        let output = Buffer::new(
            device,
            "probe.outputs",
            32 * inputs.len() as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )
        .unwrap();
        let pool = DescriptorPool::new(device, &[kernel.set_layout()]).unwrap();
        let mut commands = CommandPool::new(device).unwrap();
        let mut rec = commands.begin().unwrap();
        let bindings = brdf_probe_comp::Bindings {
            inputs: &input,
            outputs: &output,
        };
        let count = inputs.len() as u32;
        let push = brdf_probe_comp::Push { count };
        let threads = Work::Threads([count, 1, 1]);
        kernel
            .dispatch(&mut rec, &pool, &bindings, &push, threads)
            .unwrap();
        rec.use_buffer(&output, Access::HostRead);
        rec.flush_barriers();
        let done = rec.submit().unwrap();
        device.wait(done).unwrap();
        output.read().unwrap()
    };
    let (gpu, sources): (Vec<[f32; 4]>, Vec<[f32; 4]>) =
        gpu.chunks_exact(2).map(|p| (p[0], p[1])).unzip();
    let mut worst = (0.0f32, 0);
    for (i, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
        let g = Vec3::new(g[0], g[1], g[2]);
        // Relative to the value, absolute below 1 (f reaches 1e4 in narrow peaks).
        let err = ((g - *c).abs() / c.abs().max(Vec3::ONE)).max_element();
        if err > worst.0 {
            worst = (err, i);
        }
    }
    let (worst, at) = worst;
    eprintln!(
        "worst at {:?}: GPU {:?}, CPU {}",
        inputs[at], gpu[at], cpu[at]
    );
    drop(renderer);
    eprintln!(
        "GLSL vs CPU BRDF on {} inputs: worst relative error {worst:.2e}",
        cpu.len()
    );
    assert!(worst <= 1e-4, "GLSL and CPU BRDFs differ by {worst}");
    assert_eq!(log.total(), 0, "{:?}", log.messages());
    // What a surface sends as a source (brdf_source_color, a table over
    // roughness) is its hemispherical albedo: the CPU BRDF's, by sampling,
    // for each of the inputs' distinct BRDFs.
    let mut worst = (0.0f32, 0, Vec3::ZERO, Vec3::ZERO);
    for (i, input) in inputs.iter().enumerate().take(210) {
        let brdf = Brdf {
            base: Vec3::from_slice(&input.base_metallic[..3]),
            metallic: input.base_metallic[3],
            roughness: input.n_roughness[3],
            specular: input.wo_specular[3],
        };
        let albedo = hemispherical_albedo(&brdf);
        let source = Vec3::from_slice(&sources[i][..3]);
        let err = ((source - albedo).abs() / albedo.max(Vec3::splat(0.05))).max_element();
        if err > worst.0 {
            worst = (err, i, source, albedo);
        }
    }
    let (worst, at, source, albedo) = worst;
    eprintln!(
        "source colour vs hemispherical albedo: worst relative error {worst:.4} at {:?}: {source} against {albedo}",
        inputs[at]
    );
    // Measured 0.9%; this check's own sampling error (32 views x 2048
    // samples) is up to about 1%, a wrong table entry or lobe weight 5-100%.
    assert!(worst <= 0.02, "brdf_source_color is off by {worst}");
}

/// The BRDF's albedo averaged over cosine-weighted views around +Z, by
/// sampling its lobes (f cos / pdf).
fn hemispherical_albedo(brdf: &Brdf) -> Vec3 {
    let (views, samples) = (32u32, 2048u32);
    let mut sum = Vec3::ZERO;
    for v in 0..views {
        let wo = hemisphere_cosine((v as f32 + 0.5) / views as f32, 0.0);
        for k in 0..samples {
            let u = Vec3::new(
                halton(k + v * samples, 2),
                halton(k + v * samples, 3),
                halton(k + v * samples, 5),
            );
            if let Some(s) = brdf.sample(Vec3::Z, wo, u) {
                sum += s.weight;
            }
        }
    }
    sum / (views * samples) as f32
}

/// A view direction whose cosine is sqrt(`u`) (cosine-weighted), azimuth
/// `phi`.
fn hemisphere_cosine(u: f32, phi: f32) -> Vec3 {
    let cos = u.sqrt();
    let sin = (1.0 - u).sqrt();
    Vec3::new(sin * phi.cos(), sin * phi.sin(), cos)
}

/// The radical inverse of `i` in `base` (a Halton coordinate).
fn halton(mut i: u32, base: u32) -> f32 {
    let (mut f, mut r) = (1.0f32, 0.0f32);
    while i > 0 {
        f /= base as f32;
        r += f * (i % base) as f32;
        i /= base;
    }
    r
}

/// The path tracer at `size` with `spp` samples and at most `bounces`, at
/// pixel centres.
fn path_traced(scene: &Scene, size: (u32, u32), spp: u32, bounces: u32) -> Vec<f32> {
    path_traced_with(scene, size, spp, bounces, false)
}

/// The path tracer, sampling each pixel's area if `antialias`.
fn path_traced_with(
    scene: &Scene,
    size: (u32, u32),
    spp: u32,
    bounces: u32,
    antialias: bool,
) -> Vec<f32> {
    let settings = ReferenceSettings {
        width: size.0,
        height: size.1,
        spp,
        bounces,
        seed: 7,
        antialias,
        ..Default::default()
    };
    Reference::new(scene, settings)
        .unwrap()
        .render(&AtomicBool::new(false), |_| {})
        .0
}

/// (mean ratio, relMSE on 4x4 blocks) of `a` against `b`.
fn against(a: &[f32], b: &[f32], size: (u32, u32)) -> (f64, f64) {
    let whole = compare(a, b).unwrap();
    let blocks = compare(
        &block_average(a, size.0, size.1, 4),
        &block_average(b, size.0, size.1, 4),
    )
    .unwrap();
    (whole.mean_ratio, blocks.rel_mse)
}

#[test]
fn direct_light_on_glossy_spheres_matches_the_path_tracer() {
    let scene = ssbc::scene::builtin::spheres();
    let size = (128, 96);
    let mut s = RenderSettings::new(size.0, size.1);
    s.vpl.count = 0;
    s.ssbc.steps = 0;
    let gpu = common::render_validated(&scene, &s);
    let truth = path_traced(&scene, size, 256, 0);
    let (mean, rel_mse) = against(&gpu.image.rgba, &truth, size);
    eprintln!("spheres, direct light: GPU / path tracer {mean:.4}, relMSE(4x4) {rel_mse:.5}");
    assert!((mean - 1.0).abs() <= 0.01, "mean ratio {mean}");
    assert!(rel_mse <= 0.005, "relMSE(4x4) {rel_mse}");
}

/// `spheres` with every sphere and the floor metallic, roughness at least
/// 0.3.
fn metallic_spheres() -> Scene {
    let mut scene = ssbc::scene::builtin::spheres();
    scene.name = "metallic spheres".into();
    for m in &mut scene.materials {
        if let Reflectance::MetallicRoughness { roughness, .. } = m.reflectance {
            *m = Material {
                reflectance: Reflectance::MetallicRoughness {
                    metallic: 1.0,
                    roughness: roughness.max(0.3),
                    texture: None,
                },
                ..m.clone()
            };
        }
    }
    scene
}

#[test]
fn glossy_scenes_at_the_defaults_match_the_path_tracer() {
    let size = (128, 96);
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut failures = Vec::new();
    // Measured 0.0075 (spheres) and 0.0095 (metallic) here. Before glossy
    // sources sent their specular reflection (by its hemispherical albedo,
    // brdf_source_color) the metallic variant was at 0.0111: its metal
    // floor sent nothing to the back wall's foot, where clamping cut the
    // most (docs/accuracy.md).
    for (scene, max_rel_mse) in [
        (ssbc::scene::builtin::spheres(), 0.01),
        (metallic_spheres(), 0.01),
    ] {
        let gpu = renderer
            .render(&scene, &RenderSettings::new(size.0, size.1))
            .unwrap();
        let truth = path_traced(&scene, size, 1024, 64);
        let (mean, rel_mse) = against(&gpu.image.rgba, &truth, size);
        let line = format!(
            "{}, defaults: GPU / path tracer {mean:.4}, relMSE(4x4) {rel_mse:.5}",
            scene.name
        );
        eprintln!("{line}");
        if (mean - 1.0).abs() > 0.03 || rel_mse > max_rel_mse {
            failures.push(line);
        }
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
    assert!(failures.is_empty(), "{failures:#?}");
}

/// T = T_b + T_r with glossy surfaces: Kollig & Keller's compensation (the
/// clamped VPL sum plus the clamped-away part by BRDF-sampled path
/// tracing, recursively) gives back what a low bound removes: it lands on
/// the path tracer, which the clamped sum misses. 1024 VPLs: with 256 the
/// one VPL set's own error (its unclamped sum 0.974-0.979 of the path
/// tracer) was as large as what the test measures, and reweighting light
/// paths for shading normals (docs/conventions.md) moved every figure by
/// 0.5% and it failed; the same sums converge on the path tracer at 8192
/// VPLs either way (1.0000 / 0.9995).
#[test]
fn kollig_keller_gives_back_what_clamping_removes_on_glossy_spheres() {
    let scene = ssbc::scene::builtin::spheres();
    let size = (64, 48);
    let run = |method, bound, spp| {
        let settings = ReferenceSettings {
            width: size.0,
            height: size.1,
            spp,
            method,
            bound,
            seed: 3,
            vpl: ssbc::settings::VplSettings {
                count: 1024,
                ..Default::default()
            },
            ..Default::default()
        };
        let rgba = Reference::new(&scene, settings)
            .unwrap()
            .render(&AtomicBool::new(false), |_| {})
            .0;
        rgba.chunks_exact(4)
            .map(|p| (p[0] + p[1] + p[2]) as f64)
            .sum::<f64>()
    };
    // A low bound, so that clamping removes enough to measure its return.
    let bound = 1.0;
    let truth = run(Method::PathTrace, f32::INFINITY, 1024);
    let clamped = run(Method::Vpl, bound, 1) / truth;
    let unclamped = run(Method::Vpl, f32::INFINITY, 1) / truth;
    let compensated = run(Method::KolligKeller, bound, 64) / truth;
    eprintln!(
        "spheres / path tracer: VPLs clamped at b = {bound} {clamped:.4}, unclamped {unclamped:.4}, \
         Kollig-Keller {compensated:.4}"
    );
    assert!(
        1.0 - clamped > 0.02,
        "the bound removes too little to test: {clamped}"
    );
    assert!(
        (compensated - 1.0).abs() < 0.25 * (1.0 - clamped),
        "Kollig-Keller / path tracer {compensated}"
    );
}

/// Highlights smaller than a pixel keep their energy: a 5 x 5 grid of
/// spheres (metallic 0 to 1 down, roughness 0.05 to 1 across; a point
/// light, black background) against the path tracer sampling each pixel's
/// area. Shaded at the pixel's centre, the smooth metal spheres' highlights
/// were all or nothing: the image was 0.949 of the truth (the smoothest
/// metal sphere's cell 0.08), 0.998 with the highlight averaged over the
/// normals the pixel spans (direct_lighting.comp). Its relMSE on 4x4
/// blocks went 0.0103 -> 0.0159 (widened lobes' tails light a highlight's
/// neighbouring blocks; at 160x120 0.0085 -> 0.0070), under the 0.03
/// aimed at for scenes modelled by others.
#[test]
fn highlights_smaller_than_a_pixel_keep_their_energy() {
    let scene = ssbc::scene::load("tests/scenes/sphere-grid.gltf").expect("the sphere grid");
    let size = (128, 96);
    let gpu = common::render_validated(&scene, &RenderSettings::new(size.0, size.1));
    let truth = path_traced_with(
        &scene,
        size,
        512,
        ReferenceSettings::default().bounces,
        true,
    );
    let (mean, rel_mse) = against(&gpu.image.rgba, &truth, size);
    eprintln!("sphere grid: GPU / area-sampled path tracer {mean:.4}, relMSE(4x4) {rel_mse:.5}");
    assert!((mean - 1.0).abs() <= 0.03, "mean ratio {mean}");
    assert!(rel_mse <= 0.025, "relMSE(4x4) {rel_mse}");
}

/// The highlight's anti-aliasing spreads the normal relative to the half
/// vector, which turns across a pixel too (on a convex mirror it adds to
/// the normal's turn), and widens each tap's lobe only near its peak (in
/// GGX's tail a widened lobe is brighter than the narrow one's mean).
/// Direct light alone on the sphere grid, 160x120, against the path tracer
/// sampling each pixel's area (256 samples): relative MSE per pixel 0.0090,
/// mean 0.986 (with the normal's spread alone 0.026 and 0.996; widened
/// everywhere 0.033, docs/accuracy.md).
#[test]
fn a_highlights_anti_aliasing_follows_the_half_vector() {
    let scene = ssbc::scene::load("tests/scenes/sphere-grid.gltf").expect("the sphere grid");
    let size = (160, 120);
    let mut s = RenderSettings::new(size.0, size.1);
    s.vpl.count = 0;
    s.ssbc.steps = 0;
    let gpu = common::render_validated(&scene, &s);
    let truth = path_traced_with(&scene, size, 256, 0, true);
    let per_pixel = compare(&gpu.image.rgba, &truth).unwrap();
    eprintln!(
        "sphere grid, direct light: GPU / area-sampled path tracer {:.4}, relMSE per pixel {:.5}",
        per_pixel.mean_ratio, per_pixel.rel_mse
    );
    assert!(
        (per_pixel.mean_ratio - 1.0).abs() <= 0.02,
        "mean ratio {}",
        per_pixel.mean_ratio
    );
    assert!(
        per_pixel.rel_mse <= 0.015,
        "relMSE per pixel {}",
        per_pixel.rel_mse
    );
}

/// A glossy floor meeting a wall, seen at a grazing angle: the floor's
/// pixels beside the wall take SSBC's residual from wall pixels a few
/// centimetres away, each seen over up to a steradian. Evaluating the
/// floor's narrow lobe at such a pixel's centre (where the mirror
/// direction meets the wall's foot) multiplied the lobe's peak by that
/// whole solid angle: the floor's row along the wall was 5.6x the truth in
/// a third-party-style room (docs/accuracy.md). Such pixels now widen the
/// lobe by their angular radius (a virtual spherical light). GPU defaults
/// against the path tracer at pixel centres, 128x96: no 4x4 block along
/// the seam (or anywhere) above 1.35x the truth. Measured 1.07x, relMSE
/// (4x4) 0.0004; 2.65x and 0.0046 before.
#[test]
fn a_glossy_floor_has_no_bright_seam_along_a_wall() {
    use ssbc::scene::Camera;
    let mut scene = Scene::new("glossy floor and a wall");
    scene.materials.push(Material::metallic_roughness(
        Vec3::new(0.6, 0.5, 0.4),
        0.0,
        0.25,
    ));
    scene
        .materials
        .push(Material::diffuse(Vec3::new(0.75, 0.72, 0.7), None));
    common::quad(
        &mut scene,
        Vec3::new(-3.0, 0.0, 3.0),
        Vec3::X * 6.0,
        -Vec3::Z * 6.0,
        0,
        1.0,
    );
    common::quad(
        &mut scene,
        Vec3::new(-3.0, 0.0, -3.0),
        Vec3::X * 6.0,
        Vec3::Y * 3.0,
        1,
        1.0,
    );
    scene
        .lights
        .push(common::point_light(Vec3::new(0.0, 2.5, 0.0), 12.0));
    scene.cameras.push(Camera::look_at(
        Vec3::new(0.2, 1.5, 2.7),
        Vec3::new(0.0, 0.8, -3.0),
        55f32.to_radians(),
    ));
    let size = (128, 96);
    let gpu = common::render_validated(&scene, &RenderSettings::new(size.0, size.1));
    let truth = path_traced(&scene, size, 512, 64);
    let (a, b) = (
        block_average(&gpu.image.rgba, size.0, size.1, 4),
        block_average(&truth, size.0, size.1, 4),
    );
    let luminance = |p: &[f32]| (p[0] + p[1] + p[2]) as f64;
    let worst = a
        .chunks_exact(4)
        .zip(b.chunks_exact(4))
        .map(|(a, b)| luminance(a) / luminance(b).max(1e-6))
        .fold(0.0, f64::max);
    let (mean, rel_mse) = against(&gpu.image.rgba, &truth, size);
    eprintln!(
        "glossy floor and a wall: GPU / path tracer {mean:.4}, relMSE(4x4) {rel_mse:.5}, \
         brightest block {worst:.3}x"
    );
    assert!(worst <= 1.35, "a block at {worst:.3}x the path tracer");
    assert!((mean - 1.0).abs() <= 0.05, "mean ratio {mean}");
}
