//! Screen-space bias compensation: exactness of the brute-force step against
//! a CPU twin, hierarchical against brute force, and `--bound inf`.

mod common;

use glam::Vec3;
use ssbc::cpu::ssbc::{brute_force_step, GBufferView, TwinCamera};
use ssbc::renderer::{Bound, RenderSettings};
use ssbc::settings::{Integration, SsbcSettings};
use ssbc::Frame;

fn settings(integration: Integration, steps: u32, bound: Bound) -> RenderSettings {
    let mut s = common::small(256, 192);
    s.vpl.count = 64;
    s.bound = bound;
    s.ssbc = SsbcSettings {
        steps,
        integration,
        ..Default::default()
    };
    s.debug_readback = true;
    s
}

/// sqrt(sum (a - b)^2 / sum b^2) over RGB.
fn relative_rmse(a: &[f32], b: &[f32]) -> f64 {
    let (mut num, mut den) = (0f64, 0f64);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        if i % 4 == 3 {
            continue;
        }
        num += ((x - y) as f64).powi(2);
        den += (*y as f64).powi(2);
    }
    (num / den.max(1e-30)).sqrt()
}

fn layer<'a>(f: &'a Frame, name: &str) -> &'a [f32] {
    &f.layer(name.parse().expect("a layer name"))
        .unwrap_or_else(|| panic!("layer {name}"))
        .rgba
}

#[test]
fn unbounded_transport_leaves_nothing_to_compensate() {
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let f = common::render_validated(
        &scene,
        &settings(Integration::Hierarchical, 2, Bound::Value(f32::INFINITY)),
    );
    for k in 1..=2 {
        assert!(layer(&f, &format!("residual_{k}"))
            .chunks_exact(4)
            .all(|p| p[..3] == [0.0; 3]));
    }
}

#[test]
fn gpu_brute_force_step_equals_cpu_twin() {
    let scene = ssbc::scene::builtin::cornell();
    let f = common::render_validated(&scene, &settings(Integration::Brute, 1, Bound::Auto));
    let camera = scene.camera(None).unwrap();
    let g = GBufferView {
        width: f.width,
        height: f.height,
        position: layer(&f, "gbuffer_position"),
        normal: layer(&f, "gbuffer_normal"),
        albedo: layer(&f, "gbuffer_albedo"),
    };
    // S0 = direct + bounded indirect, as read back.
    let s0: Vec<f32> = layer(&f, "direct")
        .iter()
        .zip(layer(&f, "indirect_bounded"))
        .map(|(a, b)| a + b)
        .collect();
    let pixel_side = 2.0 * (camera.yfov * 0.5).tan() / f.height as f32;
    let twin_camera = TwinCamera {
        position: camera.position,
        forward: camera.forward,
        up: camera.up,
        pixel_side,
        min_cos_view: 0.2,
        principal: glam::Vec2::ZERO,
    };
    let cpu = brute_force_step(&g, &s0, twin_camera, f.bound);
    let gpu = layer(&f, "residual_1");
    let err = relative_rmse(gpu, &cpu);
    let energy: f32 = cpu.iter().step_by(4).sum();
    eprintln!(
        "brute-force step: GPU vs CPU relative RMSE {err:.2e} (CPU residual red sum {energy})"
    );
    assert!(
        energy > 0.0,
        "the default bound should leave something to compensate"
    );
    // 8e-6 with the pyramid's level 0 in floats, 1.2e-5 in its packed
    // words; halves from the neighbour's position gave 2.9e-4, which
    // 1e-3 let through (docs/performance.md, "fourth round").
    assert!(err < 1e-4, "relative RMSE {err}");
}

/// A residual sum that a device's loop budget cuts short is an error, not a
/// silently partial image: a small plane in a wide image with a tiny bound,
/// so that every window is the whole image (600 rows x 128 segments of 16
/// pixels). The same at 256x192 fits. Mesa 22.3's lavapipe stops a loop
/// after 65535 iterations per invocation; Mesa 25's has no such budget and
/// sums the whole window, so the refusal is checked on the previous driver
/// (this test run again in a child process).
#[test]
fn a_residual_cut_short_by_the_loop_limit_is_an_error() {
    const CHILD: &str = "SSBC_CHILD_ON_PREVIOUS_DRIVER";
    let on_previous = std::env::var_os(CHILD).is_some();
    let mut scene = common::plane_scene(0.5, 0.2);
    scene.ensure_light();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut s = settings(Integration::Brute, 1, Bound::Value(1e-4));
    s.debug_readback = false;
    s.vpl.count = 16;
    let small = renderer
        .render(&scene, &s)
        .expect("256x192 fits the budget");
    assert!(layer(&small, "residual_1").iter().all(|v| v.is_finite()));
    (s.width, s.height) = (2048, 600);
    let device = format!(
        "{} ({})",
        renderer.device().name(),
        renderer.device().driver()
    );
    match renderer.render(&scene, &s) {
        Err(e) => assert!(e.to_string().contains("cut short"), "{e}"),
        Ok(wide) => {
            assert!(
                !on_previous,
                "{device}: a 2048x600 brute-force window was not reported"
            );
            assert!(layer(&wide, "residual_1").iter().all(|v| v.is_finite()));
            eprintln!("{device} has no loop budget: the 2048x600 window was summed");
        }
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
    if on_previous {
        return;
    }
    let Some(previous) = common::previous_driver() else {
        return;
    };
    let child = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "a_residual_cut_short_by_the_loop_limit_is_an_error",
        ])
        .args(["--nocapture", "--test-threads", "1"])
        .env(CHILD, "1")
        .env("VK_ICD_FILENAMES", &previous)
        .env_remove("VK_DRIVER_FILES")
        .output()
        .expect("run this test on the previous driver");
    let output = String::from_utf8_lossy(&child.stdout).into_owned()
        + &String::from_utf8_lossy(&child.stderr);
    assert!(
        child.status.success() && output.contains("1 passed"),
        "on the previous driver ({previous}):\n{output}"
    );
}

/// Texels read per pixel: hierarchical (with evaluation points) and brute force.
fn sample_ratio(scene: ssbc::Scene) -> f64 {
    let mut scene = scene;
    scene.ensure_light();
    let brute = common::render_validated(&scene, &settings(Integration::Brute, 1, Bound::Auto));
    let hier =
        common::render_validated(&scene, &settings(Integration::Hierarchical, 1, Bound::Auto));
    let (h, b) = (
        hier.timings.ssbc_steps[0].samples_per_pixel_avg,
        brute.timings.ssbc_steps[0].samples_per_pixel_avg,
    );
    eprintln!(
        "{}: texels read per pixel, hierarchical {h:.1} vs brute force {b:.1} ({:.1}x fewer)",
        scene.name,
        b / h
    );
    b / h
}

#[test]
fn hierarchical_reads_far_fewer_texels_than_brute_force() {
    for scene in [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
    ] {
        let ratio = sample_ratio(scene);
        assert!(ratio >= 8.0, "only {ratio}x fewer texels");
    }
}

/// The hierarchical residual (evaluation points, interpolation, fallback)
/// against the brute-force twin: relative RMSE at most 2% and mean within 1%
/// on the three built-in scenes and an open-front box, at three sizes and
/// two bounds (one validated renderer for all 24 frames).
#[test]
fn hierarchical_matches_brute_force() {
    let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig {
        validation: true,
        ..Default::default()
    })
    .expect("renderer");
    let log = renderer.validation_log();
    let scenes = [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
        common::ssbc_accuracy::open_box(),
        ssbc::scene::builtin::spheres(),
        // glTF materials: rough dielectrics, nearly Lambertian receivers.
        ssbc::scene::load("assets/open-front-box.gltf").expect("the open-front box"),
    ];
    let mut failures = Vec::new();
    for scene in &scenes {
        for size in [(256, 192), (320, 240), (640, 480)] {
            for bound in [Bound::Auto, Bound::Value(10.0)] {
                let settings = common::ssbc_accuracy::one_step(size, bound);
                // About 4000 pixels spread over the image (2000 missed the
                // one pixel beside a glossy sphere's contact that held 79%
                // of the squared error at 640x480 before glossy receivers
                // refined by their lobe).
                let stride = ((size.0 * size.1) as usize / 4000).max(1) | 1;
                let (c, f) = common::ssbc_accuracy::residual_vs_twin(
                    &mut renderer,
                    scene,
                    &settings,
                    stride,
                );
                let step = &f.timings.ssbc_steps[0];
                let line = format!(
                    "{} {}x{} b = {:.2}: relative RMSE {:.2}%, mean ratio {:.4} ({} pixels), texels/pixel {:.1} (max {:.0}), {:.1}% evaluated alone, eval level {}",
                    scene.name,
                    size.0,
                    size.1,
                    f.bound,
                    c.relative_rmse * 100.0,
                    c.mean_ratio,
                    c.pixels,
                    step.samples_per_pixel_avg,
                    step.samples_per_pixel_max,
                    step.fallback_fraction * 100.0,
                    step.eval_level
                );
                eprintln!("{line}");
                // 2.1%: spheres at 256x192 measured 2.00% once ISM points
                // splatted as discs changed its residual (2026-11-28).
                if !(c.relative_rmse <= 0.021 && (c.mean_ratio - 1.0).abs() <= 0.01) {
                    failures.push(line.clone());
                }
                // Glossy pixels interpolate the glossy rest of evaluation
                // points of their material whose lobes point their way or
                // whose glossy rests agree: 8.5% / 8.2% alone (lobes
                // alone: 11.6%; before, every glossy pixel that was not
                // nearly Lambertian: 34%).
                if scene.name == "spheres" && size == (640, 480) && step.fallback_fraction > 0.1 {
                    failures.push(format!("{line}: glossy pixels alone"));
                }
            }
        }
    }
    drop(renderer);
    assert_eq!(
        log.total(),
        0,
        "validation reported {} message(s)",
        log.total()
    );
    assert!(
        failures.is_empty(),
        "beyond 2.1% / 1%:\n{}",
        failures.join("\n")
    );
}

/// Mean RGB sum per corner region of the Cornell box: pixels within 20 cm of
/// two walls, grouped by the pair of walls (floor-left, back-ceiling, ...).
fn corner_means(f: &Frame, name: &str) -> Vec<(String, f64)> {
    let pos = layer(f, "gbuffer_position");
    let img = layer(f, name);
    let walls = ["left", "right", "floor", "ceiling", "back"];
    let mut sums = std::collections::BTreeMap::<String, (f64, usize)>::new();
    for i in 0..(f.width * f.height) as usize {
        if pos[i * 4 + 3] == 0.0 {
            continue;
        }
        let p = Vec3::new(pos[i * 4], pos[i * 4 + 1], pos[i * 4 + 2]);
        let d = [p.x + 1.0, 1.0 - p.x, p.y, 2.0 - p.y, p.z + 1.0];
        let near: Vec<&str> = walls
            .iter()
            .zip(d)
            .filter(|(_, d)| d.abs() < 0.2)
            .map(|(w, _)| *w)
            .collect();
        if near.len() == 2 {
            let e = sums.entry(near.join("-")).or_default();
            e.0 += (img[i * 4] + img[i * 4 + 1] + img[i * 4 + 2]) as f64;
            e.1 += 1;
        }
    }
    sums.into_iter()
        .filter(|(_, (_, n))| *n >= 20)
        .map(|(k, (s, n))| (k, s / n as f64))
        .collect()
}

fn rmse(a: &[f32], b: &[f32]) -> f64 {
    let n = a.len() as f64 * 0.75;
    (a.iter()
        .zip(b)
        .enumerate()
        .filter(|(i, _)| i % 4 != 3)
        .map(|(_, (x, y))| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / n)
        .sqrt()
}

fn mean(a: &[f32]) -> f64 {
    a.iter()
        .enumerate()
        .filter(|(i, _)| i % 4 != 3)
        .map(|(_, x)| *x as f64)
        .sum::<f64>()
        / (a.len() as f64 * 0.75)
}

#[test]
fn ssbc_restores_the_energy_clamping_removed() {
    let scene = ssbc::scene::builtin::cornell();
    let run = |steps: u32, bound: Bound| {
        let mut s = common::small(256, 192);
        s.bound = bound;
        s.ssbc.steps = steps;
        s.debug_readback = true;
        common::render_validated(&scene, &s)
    };
    // The truth: a path-traced image on the same pixel grid (4 bounces, as the
    // VPLs), in a copy of a GPU frame so the corner regions come from its G-buffer.
    let unclamped = run(0, Bound::Value(f32::INFINITY));
    let mut truth = unclamped.clone();
    let settings = ssbc::reference::ReferenceSettings {
        width: 256,
        height: 192,
        spp: 256,
        ..Default::default()
    };
    let reference = ssbc::reference::Reference::new(&scene, settings).unwrap();
    truth.image.rgba = reference
        .render(&std::sync::atomic::AtomicBool::new(false), |_| {})
        .0;
    let truth_img = &truth.image.rgba;
    let truth_corners = corner_means(&truth, "final");
    assert!(
        truth_corners.len() >= 6,
        "corner regions found: {truth_corners:?}"
    );
    let summary = |label: &str, f: &Frame| {
        let (m, e) = (
            mean(&f.image.rgba) / mean(truth_img),
            rmse(&f.image.rgba, truth_img),
        );
        eprintln!("{label}: mean radiance {m:.4} of the truth, RMSE {e:.4}");
        (m, e, corner_means(f, "final"))
    };
    summary("unclamped (b = inf)", &unclamped);
    // b = 2 /m^2 clamps within 0.7 m: the corners visibly darken.
    let (clamped_mean, clamped_rmse, clamped_corners) =
        summary("clamped (b = 2)", &run(0, Bound::Value(2.0)));
    for steps in [2, 3] {
        let (m, e, corners) = summary(
            &format!("SSBC {steps} steps"),
            &run(steps, Bound::Value(2.0)),
        );
        assert!(
            (m - 1.0).abs() < (clamped_mean - 1.0).abs(),
            "mean radiance not closer: {m} vs {clamped_mean}"
        );
        assert!(e < clamped_rmse, "RMSE not lower: {e} vs {clamped_rmse}");
        for ((region, t), ((_, c), (_, s))) in truth_corners
            .iter()
            .zip(clamped_corners.iter().zip(corners))
        {
            eprintln!(
                "  {region:>14}: clamped {:.3}, SSBC {:.3} of the truth",
                c / t,
                s / t
            );
            assert!(
                s / t < 1.03,
                "{region}: SSBC overshoots the truth by {:.1}%",
                (s / t - 1.0) * 100.0
            );
            assert!(s > *c, "{region}: SSBC adds no energy");
        }
    }
}

/// A flat floor cannot light itself, whatever its normal map: SSBC's
/// senders take their areas, cosines and creases from the surface's
/// geometric normal. The normal map's V-grooves (slopes of 0.6, 8 of its
/// 64 texels, both axes) turn neighbouring pixels' shading normals toward
/// each other; taken for the senders' cosines, they lit each other at a
/// pixel's distance (on a grooved metal sphere, relMSE against the path
/// tracer on 4x4 blocks went 0.060 with no SSBC step to 0.110 with one;
/// now 0.060).
#[test]
fn a_normal_mapped_plane_does_not_light_itself() {
    use ssbc::scene::{Material, TextureRef, TextureSampler};
    let mut scene = ssbc::Scene::new("grooved floor");
    let side = 64u32;
    let slope = |c: u32| match c % side {
        0..4 => 0.6,
        60.. => -0.6,
        _ => 0.0,
    };
    scene
        .textures
        .push(common::normal_map(side, |x, y| (slope(x), slope(y))));
    let mut floor = Material::diffuse(Vec3::splat(0.8), None);
    floor.normal_texture = Some(TextureRef::new(0, TextureSampler::default()));
    scene.materials.push(floor);
    common::quad(
        &mut scene,
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::X * 4.0,
        -Vec3::Z * 4.0,
        0,
        4.0,
    );
    scene
        .lights
        .push(common::point_light(Vec3::new(0.3, 1.5, 0.2), 4.0));
    scene.cameras.push(ssbc::scene::Camera::look_at(
        Vec3::new(0.0, 1.0, 2.2),
        Vec3::ZERO,
        50f32.to_radians(),
    ));
    let mut s = settings(Integration::Hierarchical, 1, Bound::Auto);
    s.width = 128;
    s.height = 96;
    let f = common::render_validated(&scene, &s);
    let sum = |name: &str| -> f64 {
        layer(&f, name)
            .chunks_exact(4)
            .map(|p| p[..3].iter().map(|&c| c as f64).sum::<f64>())
            .sum()
    };
    let (residual, image) = (sum("residual_1"), sum("final"));
    assert!(image > 0.0, "the floor is lit");
    // Measured: 1.5e-5 of the image (the geometric normal is stored to
    // within 8e-4 radians, so the nearest pixels can exceed b by a hair);
    // with the shading normal for senders, 1.65e-2.
    assert!(
        residual <= 1e-4 * image,
        "a plane lit itself: residual {residual} of an image summing to {image}"
    );
}
