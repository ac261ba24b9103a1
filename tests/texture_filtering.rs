//! Minified textures show their mean over each pixel, as a path tracer
//! that averages over pixels sees them, instead of one texel per pixel
//! that aliases: colour, metallic-roughness and normal maps from mipmaps
//! (colour averaged in linear light, normals as unit vectors), several
//! taps along a slanted footprint.

mod common;

use std::sync::atomic::AtomicBool;

use glam::Vec3;
use ssbc::compare::block_average;
use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::scene::{Camera, Material, Reflectance, Scene, Texture, TextureRef, TextureSampler};

/// A deterministic hash of a texel to [0, 1).
fn noise(x: u32, y: u32, k: u32) -> f32 {
    let mut h =
        x.wrapping_mul(0x9E37_79B1) ^ y.wrapping_mul(0x85EB_CA77) ^ k.wrapping_mul(0xC2B2_AE3D);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2C1B_3C6D);
    h ^= h >> 12;
    (h & 0xFFFF) as f32 / 65536.0
}

/// A `side` x `side` texture of `texel(x, y)`.
fn texture(side: u32, texel: impl Fn(u32, u32) -> [u8; 4]) -> Texture {
    Texture {
        width: side,
        height: side,
        rgba8: (0..side * side)
            .flat_map(|i| texel(i % side, i / side))
            .collect(),
    }
}

/// A floor seen at a slant under a point light: its left half diffuse with
/// a 512 x 512 texture of random texels (1.6 cm each, a pixel covers 2 to
/// 30 of them), its right half metal (roughness 0.3) with a bumpy normal
/// map (256 x 256 texels of Gaussian slopes, 0.2 per axis, repeated every
/// metre) and the light's highlight on it.
fn textured_floor() -> Scene {
    let mut s = Scene::new("textured floor");
    s.textures.push(texture(512, |x, y| {
        let c = [0, 1, 2].map(|k| (20.0 + 230.0 * noise(x, y, k)) as u8);
        [c[0], c[1], c[2], 255]
    }));
    s.textures.push(texture(256, |x, y| {
        // Gaussian slopes (Box-Muller), 0.2 per axis.
        let radius = (-2.0 * (1.0 - noise(x, y, 3)).ln()).sqrt() * 0.2;
        let turn = std::f32::consts::TAU * noise(x, y, 4);
        let n = Vec3::new(-radius * turn.cos(), -radius * turn.sin(), 1.0).normalize();
        let c = [n.x, n.y, n.z].map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8);
        [c[0], c[1], c[2], 255]
    }));
    let texture = |index| TextureRef::new(index, TextureSampler::default());
    s.materials.push(Material::diffuse(Vec3::ONE, Some(0)));
    let mut metal = Material::diffuse(Vec3::new(0.9, 0.7, 0.5), None);
    metal.reflectance = Reflectance::MetallicRoughness {
        metallic: 1.0,
        roughness: 0.3,
        texture: None,
    };
    metal.normal_texture = Some(texture(1));
    s.materials.push(metal);
    // u along +x, v along -z: tangent +x.
    common::quad(
        &mut s,
        Vec3::new(-4.0, 0.0, 4.0),
        Vec3::X * 4.0,
        -Vec3::Z * 8.0,
        0,
        1.0,
    );
    common::quad(
        &mut s,
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::X * 4.0,
        -Vec3::Z * 8.0,
        1,
        8.0,
    );
    s.lights
        .push(common::point_light(Vec3::new(1.0, 1.5, -2.0), 6.0));
    s.cameras.push(Camera::look_at(
        Vec3::new(0.0, 1.2, 3.5),
        Vec3::new(0.0, 0.0, -1.5),
        50f32.to_radians(),
    ));
    s
}

/// (relMSE, mean ratio) of `a` against `b` over the pixels (or blocks)
/// whose alpha is 1 in both (wholly on the part compared).
fn rel_mse(a: &[f32], b: &[f32]) -> (f64, f64) {
    let (mut err, mut sum_a, mut sum_b, mut n) = (0.0, 0.0, 0.0, 0usize);
    for (p, q) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        if p[3] < 1.0 || q[3] < 1.0 {
            continue;
        }
        for k in 0..3 {
            let (x, y) = (p[k] as f64, q[k] as f64);
            err += (x - y) * (x - y) / (y * y + 1e-4);
            sum_a += x;
            sum_b += y;
        }
        n += 3;
    }
    (err / n.max(1) as f64, sum_a / sum_b)
}

#[test]
fn minified_textures_show_their_mean_over_each_pixel() {
    let scene = textured_floor();
    let (w, h) = (128, 96);
    let mut settings = common::small(w, h);
    settings.vpl.count = 0;
    settings.ssbc.steps = 0;
    let gpu = common::render_validated(&scene, &settings).image.rgba;
    let truth = Reference::new(
        &scene,
        ReferenceSettings {
            width: w,
            height: h,
            spp: 256,
            bounces: 0,
            antialias: true,
            ..Default::default()
        },
    )
    .unwrap()
    .render(&AtomicBool::new(false), |_| {})
    .0;
    // Each half apart: pixels whose camera ray meets x < 0 or x > 0.
    let camera = &scene.cameras[0];
    let half = |right: bool, rgba: &[f32]| -> Vec<f32> {
        rgba.chunks_exact(4)
            .enumerate()
            .flat_map(|(i, p)| {
                let on = common::hit_plane(camera, i as u32 % w, i as u32 / w, w, h, 4.0, 0.05)
                    .is_some_and(|q| (q.x > 0.05) == right && q.x.abs() > 0.05);
                if on {
                    [p[0], p[1], p[2], 1.0]
                } else {
                    [0.0; 4]
                }
            })
            .collect()
    };
    let mut report = Vec::new();
    for (name, right) in [("diffuse texture", false), ("metal normal map", true)] {
        let (a, b) = (half(right, &gpu), half(right, &truth));
        let (pixel_mse, mean) = rel_mse(&a, &b);
        let (a, b) = (block_average(&a, w, h, 4), block_average(&b, w, h, 4));
        let (block_mse, _) = rel_mse(&a, &b);
        eprintln!(
            "{name}: GPU / pixel-averaged path tracer: mean {mean:.4}, relMSE per pixel {pixel_mse:.5}, on 4x4 blocks {block_mse:.5}"
        );
        report.push((name, mean, pixel_mse, block_mse));
    }
    // Measured (2026-11-25, again 2026-11-27 on Mesa 25): diffuse mean
    // 1.0009, relMSE 0.0118 per pixel and 0.00036 on blocks (one texel per
    // pixel before: 0.182 and 0.012); metal 1.2227, 0.453 and 0.411
    // (before 0.77, 4.40 and 1.51). The metal's mean normal keeps the lobe
    // as narrow as one bump's, so its highlight is too bright and narrow
    // (docs/accuracy.md): a known imperfection, pinned to a band around
    // what was measured so that neither a regression nor an empty image
    // (mean 0, relMSE about 0.99) passes.
    let [(_, diffuse_mean, diffuse_pixels, diffuse_blocks), (_, metal_mean, metal_pixels, metal_blocks)] =
        report[..]
    else {
        unreachable!()
    };
    assert!(
        (diffuse_mean - 1.0).abs() < 0.01,
        "diffuse mean {diffuse_mean}"
    );
    assert!(
        diffuse_pixels < 0.03 && diffuse_blocks < 0.002,
        "diffuse relMSE {diffuse_pixels} / {diffuse_blocks}"
    );
    assert!(
        (1.15..1.30).contains(&metal_mean),
        "metal mean {metal_mean} outside its measured band 1.15-1.30"
    );
    assert!(
        (0.38..0.53).contains(&metal_pixels) && (0.34..0.49).contains(&metal_blocks),
        "metal relMSE {metal_pixels} / {metal_blocks} outside its measured bands 0.38-0.53 / 0.34-0.49"
    );
}

/// Footprint sampling and the mip chain's uploads under GPU-assisted
/// validation: every texel read in bounds, in both G-buffer layers (the
/// second at half resolution, its own derivatives).
#[test]
fn footprint_sampling_stays_in_bounds_under_gpu_assisted_validation() {
    let scene = textured_floor();
    let mut renderer = common::gpu_assisted_renderer();
    // Small in every way, at an odd size.
    let mut s = common::tiny_settings();
    (s.width, s.height) = (130, 98);
    s.ssbc.layers = 2;
    s.ssbc.layer1_resolution = ssbc::settings::LayerResolution::Half;
    renderer.render(&scene, &s).expect("render");
    common::finish_clean(renderer);
}
