//! The CPU reference is right: analytic direct light, the furnace-style
//! bounce ratio of a closed box, 1/spp convergence, Kollig–Keller's
//! unbiasedness, and agreement with the GPU renderer.

mod common;

use std::sync::atomic::AtomicBool;

use glam::{Mat4, Vec3};
use ssbc::compare::compare;
use ssbc::cpu::bvh::Surface;
use ssbc::cpu::sampling::Halton;
use ssbc::reference::{Method, Reference, ReferenceSettings};
use ssbc::renderer::Bound;
use ssbc::settings::VplSettings;

fn render(scene: &ssbc::Scene, settings: ReferenceSettings) -> Vec<f32> {
    Reference::new(scene, settings)
        .unwrap()
        .render(&AtomicBool::new(false), |_| {})
        .0
}

/// The path tracer's direct light at `w` x `h`, one ray per pixel centre
/// (what the rasterised G-buffer sees).
fn direct_light(scene: &ssbc::Scene, w: u32, h: u32) -> Vec<f32> {
    let settings = ReferenceSettings {
        width: w,
        height: h,
        spp: 1,
        bounces: 0,
        ..Default::default()
    };
    render(scene, settings)
}

#[test]
fn path_tracer_matches_the_analytic_point_light() {
    let (albedo, intensity) = (0.5, 3.0);
    let light = Vec3::new(0.2, 1.5, -0.1);
    let mut scene = common::plane_scene(albedo, 4.0);
    scene.lights.push(common::point_light(light, intensity));
    let (w, h) = (64, 48);
    let img = render(
        &scene,
        ReferenceSettings {
            width: w,
            height: h,
            spp: 1,
            bounces: 2,
            ..Default::default()
        },
    );
    let camera = scene.camera(None).unwrap();
    let mut n = 0;
    for y in 0..h {
        for x in 0..w {
            let Some(p) = common::hit_plane(&camera, x, y, w, h, 2.0, 0.02) else {
                continue;
            };
            let l = light - p;
            let expected =
                albedo / std::f32::consts::PI * intensity * l.normalize().y / l.length_squared();
            let got = img[((y * w + x) * 4) as usize];
            assert!(
                (got - expected).abs() / expected < 0.01,
                "({x},{y}): {got} vs {expected}"
            );
            n += 1;
        }
    }
    assert!(n > 1000);
}

/// A closed cube of uniform albedo rho lit from inside: all flux leaving the
/// walls lands on the walls, so the area-averaged radiance of bounce order
/// k + 1 is exactly rho times that of order k.
#[test]
fn closed_box_bounce_orders_scale_by_the_albedo() {
    let rho = 0.6;
    let mut scene = ssbc::Scene::new("furnace");
    let m = scene.add_material(Vec3::splat(rho), None);
    // Six inward-facing faces of the cube [-1, 1]^3: (normal, u, v).
    let faces = [
        (Vec3::X, Vec3::Y, Vec3::Z),
        (-Vec3::X, Vec3::Z, Vec3::Y),
        (Vec3::Y, Vec3::Z, Vec3::X),
        (-Vec3::Y, Vec3::X, Vec3::Z),
        (Vec3::Z, Vec3::X, Vec3::Y),
        (-Vec3::Z, Vec3::Y, Vec3::X),
    ];
    for (n, u, v) in faces {
        let c = -n; // the face opposite to its inward normal
        let p = [c - u - v, c + u - v, c + u + v, c - u + v];
        scene
            .add_mesh(&p, &[n; 4], &[], &[0, 1, 2, 0, 2, 3], Mat4::IDENTITY, m)
            .unwrap();
    }
    scene
        .lights
        .push(common::point_light(Vec3::new(0.1, 0.3, -0.2), 1.0));
    scene
        .cameras
        .push(ssbc::scene::Camera::look_at(Vec3::ZERO, -Vec3::Z, 1.0));
    let reference = Reference::new(
        &scene,
        ReferenceSettings {
            width: 1,
            height: 1,
            ..Default::default()
        },
    )
    .unwrap();
    let halton = Halton::new(5);
    let samples = 60_000u64;
    let mut orders = [0f64; 3];
    for i in 0..samples {
        let (n, u, v) = faces[(halton.sample(i, 0) * 6.0) as usize % 6];
        let p = -n + u * (2.0 * halton.sample(i, 1) - 1.0) + v * (2.0 * halton.sample(i, 2) - 1.0);
        let s = Surface {
            position: p,
            normal: n,
            geometric_normal: n,
            albedo: Vec3::splat(rho),
            brdf: ssbc::cpu::brdf::Brdf::lambertian(Vec3::splat(rho)),
            wo: n,
            emission: Vec3::ZERO,
            front: true,
            double_sided: true,
        };
        for (k, o) in orders.iter_mut().enumerate() {
            *o += reference.path_radiance(&s, i, 0, k as u32, k as u32).x as f64;
        }
    }
    for k in 0..2 {
        let ratio = orders[k + 1] / orders[k];
        eprintln!("bounce {} / bounce {k}: {ratio:.4} (albedo {rho})", k + 1);
        assert!(
            (ratio - rho as f64).abs() / (rho as f64) < 0.01,
            "ratio {ratio}"
        );
    }
    // Order 0 is the exact direct light: its average is rho/pi * power / area.
    let expected0 = rho as f64 / std::f64::consts::PI * 4.0 * std::f64::consts::PI / 24.0;
    let got0 = orders[0] / samples as f64;
    assert!(
        (got0 - expected0).abs() / expected0 < 0.01,
        "direct average {got0} vs {expected0}"
    );
}

#[test]
fn relative_mse_falls_as_one_over_spp() {
    // Tori: no surface right next to the light, so no heavy-tailed fireflies.
    let scene = ssbc::scene::builtin::tori();
    let base = ReferenceSettings {
        width: 48,
        height: 36,
        ..Default::default()
    };
    let truth = render(
        &scene,
        ReferenceSettings {
            spp: 2048,
            seed: 99,
            ..base.clone()
        },
    );
    let err = |spp| {
        compare(
            &render(
                &scene,
                ReferenceSettings {
                    spp,
                    seed: 1,
                    ..base.clone()
                },
            ),
            &truth,
        )
        .unwrap()
        .rel_mse
    };
    let (e8, e32) = (err(8), err(32));
    eprintln!(
        "relMSE: 8 spp {e8:.5}, 32 spp {e32:.5}, ratio {:.2} (expected about 4)",
        e8 / e32
    );
    assert!((3.0..5.5).contains(&(e8 / e32)), "ratio {}", e8 / e32);
}

#[test]
fn kollig_keller_equals_the_unclamped_vpl_sum_in_expectation() {
    let scene = ssbc::scene::builtin::cornell();
    // Over four VPL sets: for one set of 128 VPLs the two differ by that
    // set's near-field noise (1.8-2.0% for seed 3, which alone decided this
    // test until a path tracer that finds hits nearer than 0.1 mm moved it
    // from 1.8% to 2.0%).
    let (mut clamped_sum, mut kk_sum) = (0.0, 0.0);
    let seeds = [3, 4, 5, 6];
    for seed in seeds {
        let base = ReferenceSettings {
            width: 48,
            height: 36,
            vpl: VplSettings {
                count: 128,
                bounces: 4,
                seed,
                first_path: 0,
            },
            ..Default::default()
        };
        let unclamped = render(
            &scene,
            ReferenceSettings {
                method: Method::Vpl,
                bound: f32::INFINITY,
                ..base.clone()
            },
        );
        let clamped = render(
            &scene,
            ReferenceSettings {
                method: Method::Vpl,
                bound: 0.5,
                ..base.clone()
            },
        );
        let kk = render(
            &scene,
            ReferenceSettings {
                method: Method::KolligKeller,
                bound: 0.5,
                spp: 128,
                ..base.clone()
            },
        );
        let (c_kk, c_clamped) = (
            compare(&kk, &unclamped).unwrap(),
            compare(&clamped, &unclamped).unwrap(),
        );
        eprintln!(
            "VPL seed {seed}: mean radiance vs the unclamped VPL sum: clamped {:.4}, Kollig-Keller {:.4}",
            c_clamped.mean_ratio, c_kk.mean_ratio
        );
        clamped_sum += c_clamped.mean_ratio;
        kk_sum += c_kk.mean_ratio;
    }
    let n = seeds.len() as f64;
    let (clamped, kk) = (clamped_sum / n, kk_sum / n);
    assert!(clamped < 0.97, "the bound should remove energy ({clamped})");
    // Kollig-Keller replaces the VPLs' near field T_r L^ by the path-traced
    // T_r (L - Le): equal in expectation over VPL sets (measured: 1.2% over
    // these four, 0.5-2.0% for each).
    assert!((kk - 1.0).abs() < 0.02, "Kollig-Keller mean {kk}");
}

#[test]
fn gpu_agrees_with_the_cpu_reference_on_cornell() {
    let scene = ssbc::scene::builtin::cornell();
    let (w, h) = (128, 96);
    // Direct light only.
    let mut s = common::small(w, h);
    s.vpl.count = 0;
    s.ssbc.steps = 0;
    let gpu = common::render_validated(&scene, &s);
    let cpu = direct_light(&scene, w, h);
    let c = compare(&gpu.image.rgba, &cpu).unwrap();
    eprintln!(
        "direct: GPU/CPU mean {:.4}, relMSE {:.5}",
        c.mean_ratio, c.rel_mse
    );
    assert!(
        (c.mean_ratio - 1.0).abs() < 0.01 && c.rel_mse < 0.01,
        "{c:?}"
    );
    // Unclamped VPL lighting: same VPLs, exact visibility on the CPU, ISMs on the GPU.
    let mut s = common::small(w, h);
    s.vpl.count = 64;
    s.bound = Bound::Value(f32::INFINITY);
    s.ssbc.steps = 0;
    let gpu = common::render_validated(&scene, &s);
    let cpu = render(
        &scene,
        ReferenceSettings {
            width: w,
            height: h,
            method: Method::Vpl,
            vpl: s.vpl.clone(),
            ..Default::default()
        },
    );
    let c = compare(&gpu.image.rgba, &cpu).unwrap();
    eprintln!(
        "direct + unclamped VPLs: GPU/CPU mean {:.4}, relMSE {:.5}",
        c.mean_ratio, c.rel_mse
    );
    assert!(
        (c.mean_ratio - 1.0).abs() < 0.05,
        "ISM visibility explains at most 5% of the mean: {c:?}"
    );
}

#[test]
fn unclamped_vpl_lighting_converges_to_the_path_tracer() {
    let scene = ssbc::scene::builtin::cornell();
    let (w, h) = (128, 96);
    let truth = render(
        &scene,
        ReferenceSettings {
            width: w,
            height: h,
            spp: 256,
            ..Default::default()
        },
    );
    let mut errors = Vec::new();
    for vpls in [16, 64, 256] {
        let mut s = common::small(w, h);
        s.vpl.count = vpls;
        s.bound = Bound::Value(f32::INFINITY);
        s.ssbc.steps = 0;
        let gpu = common::render_validated(&scene, &s);
        let c = compare(&gpu.image.rgba, &truth).unwrap();
        eprintln!(
            "{vpls} VPLs, b = inf: relMSE {:.4}, mean ratio {:.4}",
            c.rel_mse, c.mean_ratio
        );
        errors.push(c.rel_mse);
    }
    assert!(
        errors[2] < errors[1] && errors[1] < errors[0],
        "relMSE should fall as VPLs grow: {errors:?}"
    );
}

#[test]
fn clamped_radiance_is_what_the_vpl_method_shows() {
    // A screen-space twin takes S0 at any surface point from
    // `clamped_radiance`; at a pixel centre it must equal the VPL image.
    let scene = ssbc::scene::builtin::cornell();
    let (w, h) = (32, 24);
    let settings = ReferenceSettings {
        width: w,
        height: h,
        method: Method::Vpl,
        vpl: VplSettings {
            count: 64,
            bounces: 8,
            seed: 3,
            first_path: 0,
        },
        bound: 0.5,
        ..Default::default()
    };
    let image = render(&scene, settings.clone());
    let tracer = Reference::new(&scene, settings).unwrap();
    let camera = tracer.camera();
    let mut checked = 0;
    for (i, px) in image.chunks_exact(4).enumerate() {
        let (x, y) = (i as u32 % w, i as u32 / w);
        let dir = camera.pixel_ray(x as f32, y as f32, w, h);
        let Some(hit) = tracer.bvh().intersect_camera(&scene, camera.position, dir) else {
            continue;
        };
        let s: Surface = tracer.bvh().surface(&scene, &hit, -dir);
        let l = s.emission + tracer.clamped_radiance(&s);
        let want = Vec3::new(px[0], px[1], px[2]);
        assert!(
            (l - want).abs().max_element() <= 1e-5 * (1.0 + want.max_element()),
            "pixel ({x}, {y}): {l} vs {want}"
        );
        checked += 1;
    }
    assert!(checked > w * h / 2, "{checked} geometry pixels");
}

/// The path tracer's camera rays find a surface wherever the surfaces
/// around do: no pixel without geometry whose four neighbours all have it.
/// Rays through the seams of the built-in rooms (their corners, the edges
/// where walls meet, a wall's diagonal) slipped between triangles and left
/// such holes, black in every path-traced image (cornell 18 at 320x240).
#[test]
fn the_path_tracers_camera_rays_leave_no_holes_at_seams() {
    let mut holes = Vec::new();
    for name in ssbc::scene::builtin::NAMES {
        let scene = ssbc::scene::builtin::by_name(name).unwrap();
        for (w, h) in [(128, 96), (320, 240), (333, 250)] {
            let rgba = direct_light(&scene, w, h);
            let geometry = |x: u32, y: u32| rgba[((y * w + x) * 4 + 3) as usize] > 0.0;
            for y in 1..h - 1 {
                for x in 1..w - 1 {
                    let around = [(x - 1, y), (x + 1, y), (x, y - 1), (x, y + 1)];
                    if !geometry(x, y) && around.iter().all(|&(u, v)| geometry(u, v)) {
                        holes.push((name, (w, h), (x, y)));
                    }
                }
            }
        }
    }
    assert!(holes.is_empty(), "{} holes: {holes:?}", holes.len());
}

/// Light paths reflect as the path tracer does on normal-mapped surfaces:
/// a surface reflects what arrives from w weighted by the shading cosine
/// |n_s . w|, where a light path's flux counts the geometric |n_g . w|, so
/// each VPL's flux carries their ratio and each bounce leaves with f |n_g .
/// w| / pdf (Veach's adjoint BRDF for shading normals); and a VPL sends
/// nothing where its shading normal faces away. A spot light lights only a
/// floor whose normal map tilts every texel's normal by a slope of 0.6
/// (its direct light is 0.85 of a flat floor's); the camera sees the back
/// wall, lit by the floor alone (0.74 of what a flat floor gives it: the
/// texels tilted away from it reflect nothing its way). The CPU VPL sum
/// (exact visibility, no clamping, 8192 VPLs) against the path tracer:
/// 1.38 with the shading cosines taken as geometric ones, 1.14 with the
/// weights alone, 1.001 now.
#[test]
fn vpls_on_normal_mapped_surfaces_send_what_the_path_tracer_sees() {
    use ssbc::scene::{Camera, Light, LightKind, Material, TextureRef, TextureSampler};
    let mut scene = ssbc::Scene::new("bumpy floor");
    let side = 64u32;
    scene.textures.push(common::normal_map(side, |x, y| {
        let i = x + y * side;
        let turn = (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32
            * std::f32::consts::TAU;
        (0.6 * turn.cos(), 0.6 * turn.sin())
    }));
    let mut floor = Material::diffuse(Vec3::splat(0.8), None);
    // Nearest texels: bilinear filtering would average the random tilts
    // down (the floor's direct light was 0.98 of a flat floor's, not 0.86).
    floor.normal_texture = Some(TextureRef::new(
        0,
        TextureSampler {
            nearest: true,
            ..TextureSampler::default()
        },
    ));
    scene.materials.push(floor);
    scene
        .materials
        .push(Material::diffuse(Vec3::splat(0.8), None));
    common::quad(
        &mut scene,
        Vec3::new(-2.0, 0.0, 1.0),
        Vec3::X * 4.0,
        -Vec3::Z * 3.0,
        0,
        8.0,
    );
    common::quad(
        &mut scene,
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::X * 4.0,
        Vec3::Y * 3.0,
        1,
        1.0,
    );
    scene.lights.push(Light {
        kind: LightKind::Spot {
            inner_cone: 0.3,
            outer_cone: 0.4,
        },
        position: Vec3::new(0.0, 2.0, 0.5),
        direction: -Vec3::Y,
        intensity: Vec3::splat(20.0),
    });
    scene.cameras.push(Camera::look_at(
        Vec3::new(0.0, 1.5, 0.8),
        Vec3::new(0.0, 1.5, -2.0),
        60f32.to_radians(),
    ));
    let (width, height) = (32, 24);
    // Sum of RGB (alpha is coverage).
    let mean = |image: &[f32]| -> f64 {
        image
            .chunks_exact(4)
            .map(|p| p[..3].iter().map(|&v| v as f64).sum::<f64>())
            .sum()
    };
    let truth = mean(&render(
        &scene,
        ReferenceSettings {
            width,
            height,
            spp: 1024,
            ..Default::default()
        },
    ));
    let vpl = mean(&render(
        &scene,
        ReferenceSettings {
            width,
            height,
            method: Method::Vpl,
            bound: f32::INFINITY,
            vpl: VplSettings {
                count: 8192,
                ..Default::default()
            },
            ..Default::default()
        },
    ));
    let ratio = vpl / truth;
    eprintln!("VPL sum / path tracer on the wall lit by a bumpy floor: {ratio:.4}");
    assert!(
        truth > 0.0 && (ratio - 1.0).abs() < 0.03,
        "VPL sum / path tracer {ratio}"
    );
}
