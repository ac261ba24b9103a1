//! Direct light is physically right: analytic Lambertian answers for point,
//! spot and directional lights, and a box's shadow against a CPU ray cast.

mod common;

use common::*;
use glam::{Mat4, Vec3};
use ssbc::scene::{Light, LightKind};
use std::f32::consts::PI;

const W: u32 = 128;
const H: u32 = 96;

/// Compares GPU direct light with `expected(p)` on every plane pixel; returns
/// the number of pixels compared and the worst relative error.
fn compare(
    frame: &ssbc::Frame,
    scene: &ssbc::Scene,
    expected: impl Fn(Vec3) -> Option<f32>,
) -> (usize, f32) {
    let camera = scene.camera(None).unwrap();
    let (mut n, mut worst) = (0, 0f32);
    for y in 0..H {
        for x in 0..W {
            let Some(p) = hit_plane(&camera, x, y, W, H, 2.0, 0.05) else {
                continue;
            };
            let Some(e) = expected(p) else { continue };
            if e < 1e-4 {
                continue;
            }
            let got = pixel(frame, "direct", x, y);
            let rel = (got.x - e).abs() / e;
            worst = worst.max(rel);
            n += 1;
            assert!(
                rel < 0.01,
                "pixel ({x},{y}) at {p}: got {} expected {e} ({:.2}% off)",
                got.x,
                rel * 100.0
            );
            assert!(
                (got.y - got.x).abs() < 1e-6 && (got.z - got.x).abs() < 1e-6,
                "grey in, grey out"
            );
        }
    }
    (n, worst)
}

#[test]
fn point_light_matches_inverse_square_cosine_law() {
    let (albedo, intensity, d) = (0.5, 3.0, 1.5);
    let light_pos = Vec3::new(0.2, d, -0.1);
    let mut scene = plane_scene(albedo, 4.0);
    scene.lights.push(point_light(light_pos, intensity));
    let frame = render_validated(&scene, &small(W, H));
    let (n, worst) = compare(&frame, &scene, |p| {
        let l = light_pos - p;
        let cos = l.normalize().y;
        Some(albedo / PI * intensity * cos / l.length_squared())
    });
    assert!(n > W as usize * H as usize / 3, "only {n} pixels compared");
    eprintln!(
        "point light: {n} pixels, worst relative error {:.4}%",
        worst * 100.0
    );
}

/// A camera's sub-pixel jitter moves every pixel's sample: the analytic
/// answer at the jittered pixel centres holds, at the plain centres it
/// does not (a light close to the plane, so the pixels differ).
#[test]
fn a_jittered_camera_samples_its_jittered_pixel_centres() {
    let (albedo, intensity, d) = (0.5, 0.5, 0.25);
    let light_pos = Vec3::new(0.1, d, 0.2);
    let mut scene = plane_scene(albedo, 4.0);
    scene.lights.push(point_light(light_pos, intensity));
    let mut camera = scene.camera(None).unwrap();
    camera.jitter = glam::Vec2::new(0.45, -0.4);
    scene.cameras = vec![camera.clone()];
    let frame = render_validated(&scene, &small(W, H));
    let expected = |p: Vec3| {
        let l = light_pos - p;
        albedo / PI * intensity * l.normalize().y / l.length_squared()
    };
    let plain = ssbc::scene::Camera {
        jitter: glam::Vec2::ZERO,
        ..camera.clone()
    };
    let (mut worst, mut worst_plain, mut n) = (0f32, 0f32, 0);
    for y in 0..H {
        for x in 0..W {
            let (Some(p), Some(q)) = (
                hit_plane(&camera, x, y, W, H, 2.0, 0.05),
                hit_plane(&plain, x, y, W, H, 2.0, 0.05),
            ) else {
                continue;
            };
            let got = pixel(&frame, "direct", x, y).x;
            worst = worst.max((got - expected(p)).abs() / expected(p));
            worst_plain = worst_plain.max((got - expected(q)).abs() / expected(q));
            n += 1;
        }
    }
    eprintln!(
        "jittered camera: {n} pixels, worst relative error {:.3}% at the jittered centres, {:.3}% at the plain ones",
        worst * 100.0,
        worst_plain * 100.0
    );
    assert!(n > W as usize * H as usize / 3, "only {n} pixels compared");
    assert!(worst < 0.01, "{worst}");
    assert!(worst_plain > 3.0 * worst, "{worst_plain} vs {worst}");
}

#[test]
fn spot_light_matches_inside_inner_cone() {
    let (albedo, intensity) = (0.7, 5.0);
    let light_pos = Vec3::new(0.0, 2.0, 0.0);
    let dir = Vec3::new(0.2, -1.0, 0.1).normalize();
    let (inner, outer) = (30f32.to_radians(), 40f32.to_radians());
    let mut scene = plane_scene(albedo, 4.0);
    scene.lights.push(Light {
        kind: LightKind::Spot {
            inner_cone: inner,
            outer_cone: outer,
        },
        position: light_pos,
        direction: dir,
        intensity: Vec3::splat(intensity),
    });
    let frame = render_validated(&scene, &small(W, H));
    let (n, worst) = compare(&frame, &scene, |p| {
        let l = light_pos - p;
        let angle = (-l.normalize()).dot(dir).acos();
        // Inside the inner cone (with a margin for pixel footprint) the full intensity applies.
        (angle < inner - 0.02)
            .then(|| albedo / PI * intensity * l.normalize().y / l.length_squared())
    });
    assert!(n > 500, "only {n} pixels inside the inner cone");
    // Outside the outer cone there is no light.
    let camera = scene.camera(None).unwrap();
    for y in 0..H {
        for x in 0..W {
            if let Some(p) = hit_plane(&camera, x, y, W, H, 2.0, 0.05) {
                if (p - light_pos).normalize().dot(dir).acos() > outer + 0.02 {
                    assert_eq!(
                        pixel(&frame, "direct", x, y).x,
                        0.0,
                        "light outside the outer cone"
                    );
                }
            }
        }
    }
    eprintln!(
        "spot light: {n} pixels, worst relative error {:.4}%",
        worst * 100.0
    );
}

#[test]
fn directional_light_matches_cosine_law() {
    let (albedo, irradiance) = (0.6, 2.0);
    let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let mut scene = plane_scene(albedo, 4.0);
    scene.lights.push(Light {
        kind: LightKind::Directional,
        position: Vec3::ZERO,
        direction: dir,
        intensity: Vec3::splat(irradiance),
    });
    let frame = render_validated(&scene, &small(W, H));
    let (n, worst) = compare(&frame, &scene, |_| {
        Some(albedo / PI * irradiance * (-dir).y)
    });
    assert!(n > W as usize * H as usize / 3);
    eprintln!(
        "directional light: {n} pixels, worst relative error {:.4}%",
        worst * 100.0
    );
}

/// Ray-box slab test: does the segment from `p` to `q` cross the box?
fn segment_hits_box(p: Vec3, q: Vec3, min: Vec3, max: Vec3) -> bool {
    let d = q - p;
    let (mut t0, mut t1) = (0f32, 1f32);
    for a in 0..3 {
        if d[a].abs() < 1e-9 {
            if p[a] < min[a] || p[a] > max[a] {
                return false;
            }
            continue;
        }
        let (mut ta, mut tb) = ((min[a] - p[a]) / d[a], (max[a] - p[a]) / d[a]);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
        if t0 > t1 {
            return false;
        }
    }
    true
}

#[test]
fn box_casts_the_shadow_a_ray_cast_predicts() {
    let (albedo, intensity) = (0.5, 4.0);
    let light_pos = Vec3::new(0.0, 2.0, 0.0);
    let mut scene = plane_scene(albedo, 4.0);
    let m = scene.materials.len() as u32 - 1;
    // A 0.5 m cube floating 0.6 m above the plane.
    let (bmin, bmax) = (Vec3::new(-0.35, 0.6, -0.15), Vec3::new(0.15, 1.1, 0.35));
    let c = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
    let corners = [
        c(bmin.x, bmin.y, bmin.z),
        c(bmax.x, bmin.y, bmin.z),
        c(bmax.x, bmax.y, bmin.z),
        c(bmin.x, bmax.y, bmin.z),
        c(bmin.x, bmin.y, bmax.z),
        c(bmax.x, bmin.y, bmax.z),
        c(bmax.x, bmax.y, bmax.z),
        c(bmin.x, bmax.y, bmax.z),
    ];
    let faces: [u32; 36] = [
        0, 1, 2, 0, 2, 3, 4, 6, 5, 4, 7, 6, 0, 4, 5, 0, 5, 1, 3, 2, 6, 3, 6, 7, 0, 3, 7, 0, 7, 4,
        1, 5, 6, 1, 6, 2,
    ];
    scene
        .add_mesh(&corners, &[], &[], &faces, Mat4::IDENTITY, m)
        .unwrap();
    scene.lights.push(point_light(light_pos, intensity));
    let frame = render_validated(&scene, &small(W, H));
    let camera = scene.camera(None).unwrap();
    let (mut agree, mut total, mut shadowed) = (0, 0, 0);
    for y in 0..H {
        for x in 0..W {
            let Some(p) = hit_plane(&camera, x, y, W, H, 2.0, 0.05) else {
                continue;
            };
            // Skip the penumbra band: points 3 cm around p must all agree.
            let offsets = [
                Vec3::ZERO,
                Vec3::X * 0.03,
                -Vec3::X * 0.03,
                Vec3::Z * 0.03,
                -Vec3::Z * 0.03,
            ];
            let hits: Vec<bool> = offsets
                .iter()
                .map(|o| segment_hits_box(p + *o, light_pos, bmin, bmax))
                .collect();
            if hits.iter().any(|&h| h != hits[0]) {
                continue;
            }
            // The camera must see p itself (not the box in front of it).
            if segment_hits_box(camera.position, p, bmin, bmax) {
                continue;
            }
            let l = light_pos - p;
            let unshadowed =
                albedo / std::f32::consts::PI * intensity * l.normalize().y / l.length_squared();
            let got = pixel(&frame, "direct", x, y).x;
            let gpu_shadowed = got < 0.5 * unshadowed;
            total += 1;
            shadowed += hits[0] as usize;
            agree += (gpu_shadowed == hits[0]) as usize;
            if !hits[0] {
                assert!(
                    (got - unshadowed).abs() / unshadowed < 0.01,
                    "lit pixel ({x},{y}) off: {got} vs {unshadowed}"
                );
            }
        }
    }
    assert!(
        shadowed > 100,
        "the box should shadow part of the visible plane ({shadowed} pixels)"
    );
    assert_eq!(
        agree,
        total,
        "shadow disagrees with the ray cast on {} of {total} pixels",
        total - agree
    );
    eprintln!("shadow: {total} pixels checked ({shadowed} in umbra), all agree");
}
