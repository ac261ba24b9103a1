//! Instant radiosity: the GPU's bounded VPL lighting against a CPU evaluation
//! of the same sum, ISM visibility against exact ray casts, the energy a
//! finite bound removes, and bad parameters.

mod common;

use glam::Vec3;
use ssbc::cpu::brdf::Brdf;
use ssbc::cpu::bvh::SceneBvh;
use ssbc::cpu::vpl::bounded_radiance;
use ssbc::passes::indirect_bounded::{ism_bias, ism_test_for};
use ssbc::renderer::{Bound, RenderSettings};
use ssbc::settings::{SsbcSettings, Visibility};
use ssbc::Frame;

/// The full gather: the GPU's sum is compared with the CPU's pixel by pixel
/// (the interleaved gather is checked against the full one in
/// `tests/interleaved.rs`).
fn settings(bound: Bound) -> RenderSettings {
    let mut s = common::small(128, 96);
    s.vpl.count = 64;
    s.gather = ssbc::settings::Gather::Full;
    s.bound = bound;
    s.ssbc = SsbcSettings {
        steps: 0,
        ..Default::default()
    };
    s.debug_readback = true;
    s
}

fn rgb(layer: &[f32], i: usize) -> Vec3 {
    Vec3::new(layer[i * 4], layer[i * 4 + 1], layer[i * 4 + 2])
}

fn layer<'a>(f: &'a Frame, name: &str) -> &'a [f32] {
    &f.layer(name.parse().expect("a layer name")).unwrap().rgba
}

/// A G-buffer pixel with a surface, as the gathers see it.
struct Receiver {
    /// Pixel index.
    i: usize,
    /// Position and shading normal.
    x: Vec3,
    n: Vec3,
    brdf: Brdf,
    /// Towards the eye.
    wo: Vec3,
}

/// Every pixel of `f`'s read-back G-buffer that holds a surface, seen from
/// `eye`.
fn receivers(f: &Frame, eye: Vec3) -> Vec<Receiver> {
    let (pos, nrm, alb) = (
        layer(f, "gbuffer_position"),
        layer(f, "gbuffer_normal"),
        layer(f, "gbuffer_albedo"),
    );
    (0..(f.width * f.height) as usize)
        .filter(|&i| pos[i * 4 + 3] != 0.0)
        .map(|i| {
            let x = rgb(pos, i);
            let albedo = glam::Vec4::from_slice(&alb[i * 4..i * 4 + 4]);
            Receiver {
                i,
                x,
                n: rgb(nrm, i),
                brdf: Brdf::from_gbuffer(albedo, nrm[i * 4 + 3]),
                wo: (eye - x).normalize(),
            }
        })
        .collect()
}

/// sqrt(sum |a - b|^2 / sum |b|^2).
fn relative_rmse(a: &[Vec3], b: &[Vec3]) -> f64 {
    let num: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length_squared() as f64)
        .sum();
    let den: f64 = b.iter().map(|y| y.length_squared() as f64).sum();
    (num / den).sqrt()
}

/// On the Lambertian Cornell box, and on glossy spheres (glossy VPLs and
/// receivers, each with its BRDF). ISM visibility is coarser on the small
/// spheres (measured: 88.2% agreement, 17.7% error against exact
/// visibility with 64 VPLs, against 92.8% and 6.7% on the box).
#[test]
fn gpu_bounded_indirect_equals_cpu_vpl_sum() {
    for (scene, min_agreement, max_ism_error) in [
        (ssbc::scene::builtin::cornell(), 0.90, 0.15),
        (ssbc::scene::builtin::spheres(), 0.86, 0.20),
    ] {
        bounded_indirect_equals_cpu_vpl_sum(&scene, Visibility::Ism, min_agreement, max_ism_error);
    }
}

/// ISMs whose texels are traced (`Visibility::Traced`, devices with ray
/// queries): the GPU's sum is the CPU's with the same atlas, and nearer
/// the exact-visibility sum than splatted texels (measured 2026-11-29,
/// 64 VPLs, against exact visibility: cornell 3.20% and 97.3% of the pairs
/// agreeing, spheres 3.99% and 95.1%; splatted 3.25% / 96.4% and 7.01% /
/// 91.8%).
#[test]
fn traced_isms_are_the_cpu_sum_and_nearer_exact_visibility() {
    let renderer = common::validated_renderer();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    drop(renderer);
    for (scene, min_agreement, max_ism_error) in [
        (ssbc::scene::builtin::cornell(), 0.96, 0.045),
        (ssbc::scene::builtin::spheres(), 0.94, 0.05),
    ] {
        bounded_indirect_equals_cpu_vpl_sum(
            &scene,
            Visibility::Traced,
            min_agreement,
            max_ism_error,
        );
    }
}

fn bounded_indirect_equals_cpu_vpl_sum(
    scene: &ssbc::Scene,
    visibility: Visibility,
    min_agreement: f64,
    max_ism_error: f64,
) {
    let mut settings = settings(Bound::Auto);
    settings.visibility = visibility;
    let relative_bias = ism_bias(visibility);
    let f = common::render_validated(scene, &settings);
    let eye = scene.camera(None).unwrap().position;
    let bvh = SceneBvh::new(scene);
    let ism = f.ism.as_ref().unwrap();
    let gpu_layer = layer(&f, "indirect_bounded");
    let (mut gpu, mut cpu_ism, mut cpu_exact) = (Vec::new(), Vec::new(), Vec::new());
    let (mut agree, mut pairs) = (0usize, 0usize);
    for Receiver {
        i,
        x,
        n,
        brdf: a,
        wo,
    } in receivers(&f, eye)
    {
        gpu.push(rgb(gpu_layer, i));
        cpu_ism.push(bounded_radiance(x, n, &a, wo, &f.vpls, f.bound, |k, v| {
            ism.visible(k, v, x, n, ism_test_for(&a, relative_bias))
        }));
        cpu_exact.push(bounded_radiance(x, n, &a, wo, &f.vpls, f.bound, |_, v| {
            // Exact visibility, with the receiver nudged off its surface.
            !bvh.occluded(v.position + v.normal * 1e-4, x + n * 1e-4)
        }));
        // Sample (pixel, VPL) pairs where the VPL faces the pixel.
        if i % 7 == 0 {
            for (k, v) in f.vpls.iter().enumerate() {
                let d = x - v.position;
                // Pairs that exchange light, not at grazing angles (cos < 0.1, where
                // G is negligible and any depth test is ill-conditioned).
                let w = d.normalize();
                if v.normal.dot(w) < 0.1 || -n.dot(w) < 0.1 {
                    continue;
                }
                pairs += 1;
                let exact = !bvh.occluded(v.position + v.normal * 1e-4, x + n * 1e-4);
                agree +=
                    (exact == ism.visible(k, v, x, n, ism_test_for(&a, relative_bias))) as usize;
            }
        }
    }
    let sum_err = relative_rmse(&gpu, &cpu_ism);
    let exact_err = relative_rmse(&gpu, &cpu_exact);
    let agreement = agree as f64 / pairs as f64;
    eprintln!(
        "{}: bounded indirect, {visibility} ISMs: GPU vs CPU sum with the same ISM visibility: relative RMSE {sum_err:.2e}; \
         vs exact visibility: {:.2}%; ISM agrees with ray casts on {:.2}% of {pairs} pairs",
        scene.name,
        exact_err * 100.0,
        agreement * 100.0
    );
    assert!(sum_err < 1e-3, "the GPU sum itself is off: {sum_err}");
    assert!(
        agreement >= min_agreement,
        "ISM visibility agreement {agreement}"
    );
    assert!(
        exact_err < max_ism_error,
        "ISM approximation error {exact_err}"
    );
}

/// Exact visibility (ray queries, where the device has them: Mesa 25's
/// lavapipe does): the GPU's bounded VPL lighting is the CPU's sum with
/// ray-cast visibility, pixel by pixel, on the Lambertian box and the
/// glossy spheres.
#[test]
fn exact_visibility_is_the_cpu_sum_with_ray_casts() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    for scene in [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::spheres(),
    ] {
        let mut s = settings(Bound::Auto);
        s.visibility = ssbc::settings::Visibility::Exact;
        let f = renderer.render(&scene, &s).expect("render");
        let eye = scene.camera(None).unwrap().position;
        let bvh = SceneBvh::new(&scene);
        let gpu_layer = layer(&f, "indirect_bounded");
        let (mut gpu, mut cpu) = (Vec::new(), Vec::new());
        for Receiver {
            i,
            x,
            n,
            brdf: a,
            wo,
        } in receivers(&f, eye)
        {
            gpu.push(rgb(gpu_layer, i));
            // exact_visible() in shaders/include/vpl_gather.glsl: both
            // ends lifted by 1e-4 of their coordinates' size, the receiver
            // towards the VPL.
            let lift = |p: Vec3| 1e-4 * (1.0 + p.abs().max_element());
            cpu.push(bounded_radiance(x, n, &a, wo, &f.vpls, f.bound, |_, v| {
                let origin = v.position + v.normal * lift(v.position);
                let toward = if n.dot(origin - x) >= 0.0 { n } else { -n };
                !bvh.occluded(origin, x + toward * lift(x))
            }));
        }
        // Pixels exactly on an edge between two surfaces (the floor's row
        // along a wall) are ill-posed: a ray to them grazes the wall, and
        // the two ray casters' tolerances decide. Every other pixel must
        // agree to rounding.
        let sum = |v: &[Vec3]| v.iter().map(|c| c.element_sum() as f64).sum::<f64>();
        let mean = sum(&cpu) / cpu.len() as f64 / 3.0;
        let off = gpu
            .iter()
            .zip(&cpu)
            .filter(|(g, c)| {
                (**g - **c).abs().max_element() as f64 > 1e-3 * (c.max_element() as f64 + mean)
            })
            .count();
        let share = off as f64 / cpu.len() as f64;
        let ratio = sum(&gpu) / sum(&cpu);
        eprintln!(
            "{}: exact visibility: GPU vs CPU sum with ray casts: {:.2}% of pixels differ (by 1e-3), means {ratio:.5}, relative RMSE {:.2e}",
            scene.name,
            share * 100.0,
            relative_rmse(&gpu, &cpu)
        );
        assert!(
            share < 0.01,
            "{}: {:.2}% of pixels differ",
            scene.name,
            share * 100.0
        );
        assert!((ratio - 1.0).abs() < 0.005, "{}: means {ratio}", scene.name);
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// A 4 m square floor at y = 0 (material 0) and a 4 x 2 m wall at z = -2
/// (material 1) behind it.
fn floor_and_wall(scene: &mut ssbc::Scene) {
    common::quad(
        scene,
        Vec3::new(-2.0, 0.0, 2.0),
        Vec3::X * 4.0,
        -Vec3::Z * 4.0,
        0,
        1.0,
    );
    common::quad(
        scene,
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::X * 4.0,
        Vec3::Y * 2.0,
        1,
        1.0,
    );
}

/// The floor's (y = 0) VPL light in frame `f`, GPU against the CPU sum over
/// the same VPLs with exact visibility, summed per band (`band` of a floor
/// point; None leaves it out): (GPU, exact) per band, and the pixels counted.
fn floor_against_exact(
    scene: &ssbc::Scene,
    f: &Frame,
    band: impl Fn(Vec3) -> Option<usize>,
) -> (Vec<(f64, f64)>, usize) {
    let eye = scene.camera(None).unwrap().position;
    let bvh = SceneBvh::new(scene);
    let gpu_layer = layer(f, "indirect_bounded");
    let (mut bands, mut pixels) = (Vec::new(), 0);
    for Receiver {
        i,
        x,
        n,
        brdf: a,
        wo,
    } in receivers(f, eye)
    {
        if x.y > 1e-3 {
            continue;
        }
        let Some(k) = band(x) else { continue };
        let exact = bounded_radiance(x, n, &a, wo, &f.vpls, f.bound, |_, v| {
            !bvh.occluded(v.position + v.normal * 1e-4, x + Vec3::Y * 1e-4)
        });
        if bands.len() <= k {
            bands.resize(k + 1, (0.0, 0.0));
        }
        bands[k].0 += rgb(gpu_layer, i).element_sum() as f64;
        bands[k].1 += exact.element_sum() as f64;
        pixels += 1;
    }
    (bands, pixels)
}

/// A floor whose normal map turns every normal `tilt` towards a wall a point
/// light lights (none: no normal map), seen from above the floor.
fn floor_turned_to_a_wall(tilt: Option<f32>) -> ssbc::Scene {
    use ssbc::scene::{Camera, Light, LightKind, Material, Scene, TextureRef, TextureSampler};
    let mut scene = Scene::new("normal-map-towards-vpls");
    let mut floor = Material::diffuse(Vec3::splat(0.7), None);
    if let Some(tilt) = tilt {
        // Every normal turned by `tilt` towards image-down (-green).
        scene
            .textures
            .push(common::normal_map(1, |_, _| (0.0, -tilt.tan())));
        floor.normal_texture = Some(TextureRef::new(0, TextureSampler::default()));
    }
    scene.materials.push(floor);
    scene
        .materials
        .push(Material::diffuse(Vec3::new(0.8, 0.6, 0.4), None));
    // u along +x, v along -z: image-up (green) is +z, so the normals turn
    // towards -z, the wall.
    floor_and_wall(&mut scene);
    scene.lights.push(Light {
        kind: LightKind::Point,
        position: Vec3::new(0.0, 1.0, -1.6),
        direction: Vec3::ZERO,
        intensity: Vec3::splat(6.0),
    });
    scene.cameras.push(Camera::look_at(
        Vec3::new(0.0, 3.2, 3.0),
        Vec3::new(0.0, 0.0, -0.2),
        45f32.to_radians(),
    ));
    scene
}

/// A floor whose normal map turns every normal 35 degrees towards a wall
/// lit by a point light: the wall's VPLs light the floor at grazing angles
/// (its geometric surface) while its shading normals face them. The ISM
/// test's tolerance took the receiver's slope from the shading normal,
/// which left too little for the floor's own points in a VPL's map: the
/// floor shadowed itself, more the more grazing (GPU / exact-visibility sum
/// 0.80-0.94 per band here). Now its geometric normal's (0.999-1.000).
#[test]
fn a_normal_map_turned_to_the_vpls_does_not_shadow_its_own_surface() {
    let scene = floor_turned_to_a_wall(Some(35f32.to_radians()));
    let mut settings = settings(Bound::Auto);
    settings.vpl.count = 256;
    let f = common::render_validated(&scene, &settings);
    // Floor pixels in bands by distance from the wall.
    let (bands, _) = floor_against_exact(&scene, &f, |x| Some(((x.z + 2.0) as usize).min(3)));
    let ratios: Vec<f64> = bands.iter().map(|(g, c)| g / c).collect();
    eprintln!("floor's VPL light, GPU / exact visibility, by distance from the wall: {ratios:.4?}");
    for r in ratios {
        assert!(
            (r - 1.0).abs() < 0.015,
            "a band of the floor at {r} of its VPL light"
        );
    }
}

/// A mirror-like metal floor (roughness 0.12, then 0.3) before a plinth
/// that hides the lit wall behind it from the floor just in front. A
/// diffuse receiver spreads a leak over its hemisphere, a narrow lobe
/// reflects it where the plinth should be dark. Receivers with GGX alpha
/// under 0.25 take less of the relative bias and the lifted test
/// (`indirect_bounded::ism_test_for`): the texels at the plinth's foot
/// store the floor behind it, which the slope term let through as the
/// receiver's own plane; now the slope counts only where the receiver
/// lifted (now 0.75 of) a footprint off the floor passes too, and that
/// point's ray meets the plinth. GPU / exact-visibility VPL sum, 256 VPLs, full
/// gather, by quarter metre from the plinth (2026-11-29): 1.25, 0.78, 1.02
/// and 0.61, the nearest half metre 0.92, 0.69 over the metre; roughness
/// 0.3: 1.35, 0.56, 0.99, 0.75; 0.80, 0.80 (before the lifted test 5.8,
/// 3.0, 2.9, 0.88; 3.8, 1.40, and at 0.3 6.9, 3.6, 3.1, 1.33; 4.6, 2.04;
/// before ISM discs, 5.5, 2.5, 1.3, 0.16 and 8.0, 3.6, 2.6, 0.59; with the
/// receiver's slope 32, 7.2, 1.8, 0.20; before the bias for narrow lobes
/// 43, 24, 19, 3.1). Since the test follows the stored plane where it
/// turns across the receiver's (`ism_visible`), with discs of at most
/// 15/13 point radii: 1.23, 0.76, 0.73, 0.54; 0.90; 0.59, and at 0.3 1.35,
/// 0.51, 0.76, 0.68; 0.76; 0.70; with one-texel holes filled: 1.10,
/// 0.76, 0.73, 0.51; 0.86; 0.57, and at 0.3 1.13, 0.51, 0.76, 0.64; 0.69;
/// 0.67. With tiles by projected solid angle (fewer false shadows, more
/// holes between the plinth's discs): at 0.3 1.89, 1.17, 1.11, 0.88; so
/// narrow lobes take the lifted test also where they pass within the
/// relative tolerance alone (a hole), lifted by 0.75 footprints: 0.97,
/// 0.59, 1.11, 0.88; 0.70; 0.90, and at 0.3 1.32, 0.73, 1.18, 1.02; 0.91;
/// 1.04 (by half a footprint 1.50 in the nearest band; by one, 1.41 in the
/// third); with the relative tolerance 0.05 (was 0.08): 0.87, 0.59, 1.10,
/// 0.87; 0.67; 0.89, and at 0.3 1.24, 0.72, 1.12, 0.91; 0.88; 0.94; since
/// neither the stored plane's test nor the slope term leaves room for a
/// curve (2026-11-30): 0.83, 0.57, 1.10, 0.87; 0.65; 0.88, and at 0.3 1.16,
/// 0.69, 1.12, 0.91; 0.83; 0.94. Issue 61's limit: 1.5x in every band. What is left errs dark
/// here and there: the lifted test's false shadows (the lifted point's
/// texel is not the receiver's). docs/accuracy.md.
#[test]
fn a_mirror_like_floor_does_not_reflect_light_an_occluder_hides() {
    floor_before_a_plinth_stays_dark(false);
}

/// The floor before the plinth with ISMs (with back-face maps if
/// `back_faces`): within issue 61's 1.5x of its exact VPL light in every
/// quarter metre, and 0.5-1.5x of it over the metre.
fn floor_before_a_plinth_stays_dark(back_faces: bool) {
    for roughness in [0.12, 0.3] {
        let (near, ratio, by_band) = floor_before_a_plinth(roughness, Visibility::Ism, back_faces);
        eprintln!(
            "ISMs{}, metal floor of roughness {roughness} before a plinth: GPU / exact visibility {ratio:.3}, \
             the nearest half metre {near:.2} (by distance from the plinth: {by_band:.2?})",
            if back_faces { " with back-face maps" } else { "" }
        );
        for (i, &r) in by_band.iter().enumerate() {
            assert!(
                r < 1.5,
                "roughness {roughness}: quarter metre {i} from the plinth reflects {r:.2}x its VPL light (the plinth leaks)"
            );
        }
        assert!(
            (0.5..1.5).contains(&ratio),
            "roughness {roughness}: the floor reflects {ratio:.2}x its VPL light"
        );
    }
}

/// ISMs with back-face maps (`RenderSettings::ism_back_faces`): the floor
/// before the plinth, as above. Measured 2026-11-29 (roughness 0.12; 0.3),
/// by quarter metre: 0.86, 0.59, 1.10, 0.87; 1.19, 0.72, 1.10, 0.88
/// (without them 0.87, 0.59, 1.10, 0.87; 1.24, 0.72, 1.12, 0.91: the
/// plinth is a closed box, whose far side now hides a little more).
/// Issue 61's limit: 1.5x in every band.
#[test]
fn back_face_maps_keep_the_mirror_like_floor_dark_before_the_plinth() {
    floor_before_a_plinth_stays_dark(true);
}

/// Traced ISM texels (ray queries): the floor before the plinth, as
/// above. Measured 2026-11-29 (roughness 0.12; 0.3), by quarter metre:
/// 1.39, 1.13, 1.36, 1.24; 1.68, 1.19, 1.51, 1.22 since the lifted test
/// also checks what passes within the relative tolerance (1.65, 1.37,
/// 1.38, 1.23; 1.99, 1.41, 1.51, 1.21 before; with paraboloid tiles
/// before their projected map: 1.31, 1.12, 2.00, 1.18; 1.57, 1.19, 2.01,
/// 1.37). Not issue 61's 1.5x: the texels at the plinth's edges hold the
/// floor beside and beyond it where their centre rays pass it; splatted
/// discs overhang the edges (and err dark, 0.51-0.76). Pinned at 1.25
/// times the measured.
#[test]
fn with_traced_isms_a_mirror_like_floor_does_not_reflect_light_an_occluder_hides() {
    let renderer = common::validated_renderer();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    drop(renderer);
    for roughness in [0.12, 0.3] {
        let (near, ratio, by_band) = floor_before_a_plinth(roughness, Visibility::Traced, false);
        eprintln!(
            "traced ISMs, metal floor of roughness {roughness} before a plinth: GPU / exact VPL sum {ratio:.3}, \
             the nearest half metre {near:.3} (by distance from the plinth: {by_band:.3?})"
        );
        for (i, &r) in by_band.iter().enumerate() {
            assert!(
                r < 2.5,
                "roughness {roughness}: quarter metre {i} from the plinth reflects {r:.2}x its VPL light (the plinth leaks)"
            );
        }
    }
}

/// With exact visibility (ray queries) the contact leak is gone: the floor
/// beside the plinth gets its exact VPL light (issue 61's limit: 1.5x).
#[test]
fn with_exact_visibility_a_mirror_like_floor_has_no_contact_leak() {
    let renderer = common::validated_renderer();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    drop(renderer);
    for roughness in [0.12, 0.3] {
        let (near, ratio, by_band) = floor_before_a_plinth(roughness, Visibility::Exact, false);
        eprintln!(
            "exact visibility, metal floor of roughness {roughness} before a plinth: GPU / exact VPL sum {ratio:.3}, \
             the nearest half metre {near:.3} (by distance from the plinth: {by_band:.3?})"
        );
        for (what, r) in [("nearest half metre", near), ("metre", ratio)]
            .into_iter()
            .chain(by_band.iter().map(|&r| ("quarter metre", r)))
        {
            assert!(
                (0.98..1.02).contains(&r),
                "roughness {roughness}: the floor's {what} gets {r:.3}x its exact VPL light"
            );
        }
    }
}

/// The metre of a metal floor (`roughness`) in front of a plinth lit from
/// behind, GPU over the exact-visibility VPL sum: over its nearest half
/// metre, over all of it, and by quarter metre; the GPU with `visibility`.
fn floor_before_a_plinth(
    roughness: f32,
    visibility: Visibility,
    back_faces: bool,
) -> (f64, f64, Vec<f64>) {
    use ssbc::scene::{Camera, Material, Scene};
    let mut scene = Scene::new("mirror-floor-before-a-plinth");
    scene.materials.push(Material::metallic_roughness(
        Vec3::splat(0.9),
        1.0,
        roughness,
    ));
    scene
        .materials
        .push(Material::diffuse(Vec3::new(0.8, 0.6, 0.4), None));
    scene
        .materials
        .push(Material::diffuse(Vec3::splat(0.5), None));
    floor_and_wall(&mut scene);
    let (lo, hi) = (Vec3::new(-0.6, 0.0, -0.3), Vec3::new(0.6, 0.5, 0.3));
    ssbc::scene::builtin::axis_box(&mut scene, lo, hi, 2).unwrap();
    scene
        .lights
        .push(common::point_light(Vec3::new(0.0, 1.5, -1.4), 6.0));
    scene.cameras.push(Camera::look_at(
        Vec3::new(0.0, 1.0, 3.0),
        Vec3::new(0.0, 0.2, 0.0),
        45f32.to_radians(),
    ));
    let mut settings = settings(Bound::Auto);
    settings.vpl.count = 256;
    settings.visibility = visibility;
    settings.ism_back_faces = back_faces;
    let f = common::render_validated(&scene, &settings);
    // The metre of floor in front of the plinth, as wide as it is, in
    // quarter-metre bands by distance from it.
    let (bands, pixels) = floor_against_exact(&scene, &f, |x| {
        let ahead = x.z - hi.z;
        ((0.0..1.0).contains(&ahead) && x.x.abs() <= hi.x).then(|| ((ahead * 4.0) as usize).min(3))
    });
    assert!(pixels > 300, "the floor before the plinth is in view");
    let (gpu, exact) = bands
        .iter()
        .fold((0.0, 0.0), |(g, e), b| (g + b.0, e + b.1));
    let near = (bands[0].0 + bands[1].0) / (bands[0].1 + bands[1].1);
    (
        near,
        gpu / exact,
        bands.iter().map(|(g, e)| g / e).collect(),
    )
}

/// The interleaved gather's filter keeps neighbours on the pixel's surface:
/// within a slope of its tangent plane, the geometric normal's. With the
/// shading normal's, every pixel of a floor whose normal map turns 35
/// degrees saw its neighbours off its plane and evaluated every VPL itself
/// (here 154,880 gather invocations against 27,136 without the map; at
/// 640x480 the crease kernel took 5.6 s against 27 ms).
#[test]
fn a_normal_mapped_plane_is_one_surface_to_the_gathers_filter() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !renderer.device().profiling().pipeline_statistics {
        common::cannot_check("no pipeline statistics on this device: nothing to count");
        return;
    }
    let mut s = settings(Bound::Auto);
    s.gather = ssbc::settings::Gather::Interleaved;
    s.vpl.count = 256;
    let invocations = |scene: &ssbc::Scene, renderer: &mut ssbc::Renderer| {
        let f = renderer.render(scene, &s).expect("render");
        f.timings
            .timed_passes()
            .iter()
            .find(|p| p.name == "indirect_bounded")
            .and_then(|p| p.compute_invocations)
            .expect("counted")
    };
    let turned = invocations(
        &floor_turned_to_a_wall(Some(35f32.to_radians())),
        &mut renderer,
    );
    let plain = invocations(&floor_turned_to_a_wall(None), &mut renderer);
    eprintln!("gather invocations: normal-mapped floor {turned}, plain floor {plain}");
    assert!(
        (turned as f64) < 1.25 * plain as f64,
        "the normal map made {turned} gather invocations against {plain}"
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

#[test]
fn a_finite_bound_removes_energy_mostly_in_corners() {
    let scene = ssbc::scene::builtin::cornell();
    let clamped = common::render_validated(&scene, &settings(Bound::Auto));
    let unclamped = common::render_validated(&scene, &settings(Bound::Value(f32::INFINITY)));
    let (c, u) = (
        layer(&clamped, "indirect_bounded"),
        layer(&unclamped, "indirect_bounded"),
    );
    let pos = layer(&clamped, "gbuffer_position");
    // Corner regions: within 15 cm of two walls of the box (x = +-1, y = 0 or 2, z = -1).
    let near_walls = |p: Vec3| {
        [
            (p.x + 1.0).abs(),
            (1.0 - p.x).abs(),
            p.y.abs(),
            (2.0 - p.y).abs(),
            (p.z + 1.0).abs(),
        ]
        .iter()
        .filter(|&&d| d < 0.15)
        .count()
    };
    let (mut all_c, mut all_u, mut corner_c, mut corner_u) = (0f64, 0f64, 0f64, 0f64);
    for i in 0..(clamped.width * clamped.height) as usize {
        if pos[i * 4 + 3] == 0.0 {
            continue;
        }
        let (vc, vu) = (
            rgb(c, i).element_sum() as f64,
            rgb(u, i).element_sum() as f64,
        );
        all_c += vc;
        all_u += vu;
        if near_walls(rgb(pos, i)) >= 2 {
            corner_c += vc;
            corner_u += vu;
        }
    }
    let missing_all = 1.0 - all_c / all_u;
    let missing_corners = 1.0 - corner_c / corner_u;
    eprintln!(
        "clamping at b = {:.2} /m^2 removes {:.1}% of the indirect light overall and {:.1}% in the corners",
        clamped.bound,
        missing_all * 100.0,
        missing_corners * 100.0
    );
    assert!(missing_all > 0.0);
    assert!(
        missing_corners > 1.5 * missing_all,
        "clamping should hit the corners hardest"
    );
}

#[test]
fn unclamped_gpu_equals_clamped_when_bound_is_huge() {
    // b above every G in the scene clamps nothing: identical images.
    let scene = ssbc::scene::builtin::cornell();
    let a = common::render_validated(&scene, &settings(Bound::Value(1e30)));
    let b = common::render_validated(&scene, &settings(Bound::Value(f32::INFINITY)));
    assert_eq!(layer(&a, "indirect_bounded"), layer(&b, "indirect_bounded"));
}
