//! Scenes modelled the way third-party files model them
//! (scripts/make-test-scenes.py writes tests/scenes/): emissive fixtures
//! pressed against a ceiling, a closed room, an object whose only emission
//! is a mostly black emissive texture, scenes without a camera. Each renders
//! at the defaults for its size, validation on, against the CPU path tracer.

mod common;

use std::sync::atomic::AtomicBool;

use glam::Vec3;
use ssbc::cpu::bvh::SceneBvh;
use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::Scene;

const SIZE: (u32, u32) = (64, 48);

fn load(name: &str) -> Scene {
    let path = format!("{}/tests/scenes/{name}.gltf", env!("CARGO_MANIFEST_DIR"));
    let mut scene = ssbc::scene::load(&path).expect("test scene");
    scene.ensure_light();
    scene
}

/// Mean of the RGB channels over all pixels of an RGBA image.
fn mean(rgba: &[f32]) -> f64 {
    let sum: f64 = rgba
        .chunks_exact(4)
        .map(|p| (p[0] + p[1] + p[2]) as f64)
        .sum();
    sum / (rgba.len() / 4 * 3) as f64
}

/// Relative MSE on 4x4 blocks (the error that remains once pixel noise is
/// blurred away): mean over blocks of (a - b)² / (b² + 1e-2 mean²).
fn block_rel_mse(a: &[f32], b: &[f32], (w, h): (u32, u32)) -> f64 {
    let block = |img: &[f32], bx: u32, by: u32| {
        let mut s = 0.0f64;
        for y in by * 4..by * 4 + 4 {
            for x in bx * 4..bx * 4 + 4 {
                let i = ((y * w + x) * 4) as usize;
                s += (img[i] + img[i + 1] + img[i + 2]) as f64;
            }
        }
        s / 48.0
    };
    let m = mean(b);
    let mut sum = 0.0;
    for by in 0..h / 4 {
        for bx in 0..w / 4 {
            let (x, y) = (block(a, bx, by), block(b, bx, by));
            sum += (x - y).powi(2) / (y * y + 1e-2 * m * m);
        }
    }
    sum / ((w / 4) * (h / 4)) as f64
}

/// GPU against path tracer: the ratio of the means and the relative MSE on
/// 4x4 blocks (which holds the path tracer's own noise too).
struct Agreement {
    ratio: f64,
    blocks: f64,
}

impl Agreement {
    /// Failures against the mean's tolerance and the block limit `blocks`
    /// (about 1.5 times what was measured: an image wrong by a constant
    /// factor of 0.7, or black, exceeds every limit).
    fn failures(&self, name: &str, blocks: f64) -> Vec<String> {
        let mut failures = Vec::new();
        if (self.ratio - 1.0).abs() >= TOLERANCE {
            failures.push(format!("{name}: GPU / path tracer {}", self.ratio));
        }
        if self.blocks > blocks {
            failures.push(format!(
                "{name}: relMSE on 4x4 blocks {} above {blocks}",
                self.blocks
            ));
        }
        failures
    }

    fn assert(&self, name: &str, blocks: f64) {
        let failures = self.failures(name, blocks);
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }
}

/// Renders `name` at the defaults for [`SIZE`] and with the path tracer
/// (256 spp: the mean's noise is about 0.2%); prints and returns how they
/// agree, with the VPLs per light path.
fn gpu_over_path_tracer(name: &str) -> (Agreement, ssbc::renderer::Frame) {
    gpu_over_path_tracer_at(name, SIZE, 256)
}

/// [`gpu_over_path_tracer`] at `size` with `spp` path-traced samples.
fn gpu_over_path_tracer_at(
    name: &str,
    size: (u32, u32),
    spp: u32,
) -> (Agreement, ssbc::renderer::Frame) {
    let scene = load(name);
    let settings = common::small(size.0, size.1);
    let frame = common::render_validated(&scene, &settings);
    let reference = Reference::new(
        &scene,
        ReferenceSettings {
            width: size.0,
            height: size.1,
            spp,
            ..Default::default()
        },
    )
    .unwrap()
    .render(&AtomicBool::new(false), |_| {})
    .0;
    let ratio = mean(&frame.image.rgba) / mean(&reference);
    let blocks = block_rel_mse(&frame.image.rgba, &reference, size);
    let t = &frame.timings;
    eprintln!(
        "{name}: GPU / path tracer {ratio:.4}, relMSE on 4x4 blocks {blocks:.4}; {} VPLs from {} light paths (at most {} from one), {:.3} W of {:.3} W of emission into solids left out",
        t.vpl_count,
        t.light_paths,
        t.max_vpls_per_light_path,
        t.enclosed_emission_w,
        t.emission_w,
    );
    (Agreement { ratio, blocks }, frame)
}

/// Within 5% of the path tracer (the bar): what is left is the
/// clamped energy SSBC does not give back (hidden surfaces) and the ISMs'
/// false shadows, 2-4% on these scenes at 160x120.
const TOLERANCE: f64 = 0.05;

#[test]
fn a_thin_closed_emissive_box_under_the_ceiling() {
    let (agreement, frame) = gpu_over_path_tracer("fixture-thin-box");
    // Measured 0.0165 (2026-11-27).
    agreement.assert("fixture-thin-box", 0.025);
    // The inner sides' light stays in the box: half the emission is left
    // out, and no path bounces there until the budget is spent.
    assert!(frame.timings.enclosed_emission_w > 1.5);
    assert!(frame.timings.max_vpls_per_light_path <= 64);
    assert!(frame.timings.light_paths * 8 >= frame.timings.vpl_count as u64);
}

/// Rooms whose walls are closed slabs, lit only by a thin closed emissive
/// slab under the ceiling (issue 34's held-out boxes rebuilt, and variants:
/// fixtures 1 mm to 10 cm thick, touching the ceiling or 1 cm under it,
/// slabs butting or overlapping, one- and double-sided walls, 1x and 3x
/// scale). Most of the emission goes into solids (the fixture's inside, the
/// slab it touches): left out, never more than was emitted.
#[test]
fn rooms_of_slabs_lit_by_a_thin_closed_fixture() {
    let dir = format!("{}/tests/scenes", env!("CARGO_MANIFEST_DIR"));
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
        .filter(|n| n.starts_with("slabs-") && n.ends_with(".gltf"))
        .map(|n| n.trim_end_matches(".gltf").to_string())
        .collect();
    names.sort();
    assert!(names.len() >= 6, "{names:?}");
    let mut failures = Vec::new();
    for name in &names {
        // At the size: below it the interleaved gather's filter
        // and the ISMs err by 5-10% in whole regions of these images (the
        // 10 cm fixture: 0.93 at 64x48, 0.95 at 128x96, 0.99 at 160x120);
        // 64 samples make the path tracer's mean good to about 0.3%.
        let (agreement, frame) = gpu_over_path_tracer_at(name, (160, 120), 64);
        let t = &frame.timings;
        failures.extend(agreement.failures(name, slab_block_limit(name)));
        if !(t.enclosed_emission_w <= t.emission_w && t.enclosed_emission_w > 0.25 * t.emission_w) {
            failures.push(format!(
                "{name}: {} W of {} W left out",
                t.enclosed_emission_w, t.emission_w
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The relative MSE on 4x4 blocks a slab room may reach at 160x120 against
/// 64 path-traced samples: about 1.5 times what was measured (2026-11-27:
/// the open box 0.079, where ISM visibility errs most; the closed rooms
/// 0.018-0.026; the rest 0.003-0.005).
fn slab_block_limit(name: &str) -> f64 {
    match name {
        "slabs-open-box" => 0.12,
        n if n.starts_with("slabs-room") => 0.04,
        _ => 0.008,
    }
}

#[test]
fn a_double_sided_quad_1cm_under_the_ceiling() {
    let (agreement, _) = gpu_over_path_tracer("fixture-quad-gap");
    // Measured 0.0306.
    agreement.assert("fixture-quad-gap", 0.045);
}

#[test]
fn a_one_sided_quad_flush_with_the_ceiling() {
    let (agreement, _) = gpu_over_path_tracer("fixture-quad-flush");
    // Measured 0.0108.
    agreement.assert("fixture-quad-flush", 0.016);
}

#[test]
fn a_closed_room_lit_by_a_point_light() {
    let (agreement, _) = gpu_over_path_tracer("closed-room");
    // Measured 0.0035.
    agreement.assert("closed-room", 0.006);
}

#[test]
fn emission_that_cannot_light_the_scene_gets_the_default_light_as_well() {
    // A bottle whose label glows: its light leaves the convex bottle.
    let label = load("glowing-label");
    assert_eq!(label.lights.len(), 1, "the default light is added");
    let (agreement, frame) = gpu_over_path_tracer("glowing-label");
    // Measured 0.0012.
    agreement.assert("glowing-label", 0.003);
    // More than the label shows: the bottle is lit.
    let lit = frame
        .image
        .rgba
        .chunks_exact(4)
        .filter(|p| p[1] > 1e-3)
        .count();
    assert!(lit > 300, "{lit} lit pixels");
    // A lone emissive plane lights nothing but gets a light too; rooms lit by
    // their fixtures keep only their own light.
    assert_eq!(load("emissive-floor").lights.len(), 1);
    for room in ["fixture-thin-box", "fixture-quad-gap", "fixture-quad-flush"] {
        assert!(load(room).lights.is_empty(), "{room} got a default light");
    }
}

/// Share of the pixels of a [`SIZE`] image from the default camera that
/// show geometry.
fn geometry_share(scene: &Scene) -> f64 {
    let camera = scene.camera(None).unwrap();
    let bvh = SceneBvh::new(scene);
    let (w, h) = (160, 120);
    let mut hits = 0;
    for y in 0..h {
        for x in 0..w {
            let dir = camera.pixel_ray(x as f32, y as f32, w, h);
            hits += bvh.intersect_camera(scene, camera.position, dir).is_some() as u32;
        }
    }
    hits as f64 / (w * h) as f64
}

/// A box of `size` standing on y = 0 at (`x`, `z`).
fn add_box(scene: &mut Scene, x: f32, z: f32, size: Vec3, material: u32) {
    let lo = Vec3::new(x - size.x * 0.5, 0.0, z - size.z * 0.5);
    ssbc::scene::builtin::axis_box(scene, lo, lo + size, material).unwrap();
}

#[test]
fn the_default_camera_shows_wide_flat_and_tall_scenes() {
    // A 40 m emissive plane (seen edge-on by a camera at its height).
    let plane = load("emissive-floor");
    // A wide, flat interior: 40 x 30 m of floor, rooms of 3 m walls.
    let mut interior = Scene::new("interior");
    let m = interior.add_material(Vec3::splat(0.6), None);
    add_box(&mut interior, 0.0, 0.0, Vec3::new(40.0, 0.1, 30.0), m);
    for i in 0..5 {
        let x = -16.0 + 8.0 * i as f32;
        add_box(&mut interior, x, 0.0, Vec3::new(0.2, 3.0, 30.0), m);
        add_box(&mut interior, x + 4.0, -5.0, Vec3::new(2.0, 1.0, 1.0), m);
    }
    add_box(&mut interior, 0.0, 0.0, Vec3::new(40.0, 3.0, 0.2), m);
    // A tall, narrow object: a 0.5 x 3 m column.
    let mut column = Scene::new("column");
    let m = column.add_material(Vec3::splat(0.6), None);
    add_box(&mut column, 0.0, 0.0, Vec3::new(0.5, 3.0, 0.5), m);
    // What each can fill: the plane and the interior much of the frame
    // (a square seen from above at an angle is a diamond: half its bounding
    // rectangle); the column at most its width over its height of a 4:3
    // frame (about 15% seen from the side). The default camera measured 41%,
    // 34% and 17%; the old one (level with the centre, looking along -Z at
    // the bounding sphere) 0%, 3.5% and 12%.
    for (scene, least) in [(&plane, 0.3), (&interior, 0.25), (&column, 0.1)] {
        let share = geometry_share(scene);
        eprintln!(
            "{}: {:.1}% of the pixels show geometry",
            scene.name,
            share * 100.0
        );
        assert!(share >= least, "{}: {share}", scene.name);
    }
    // A glTF camera is still used.
    let room = load("closed-room");
    assert_eq!(room.camera(None).unwrap(), room.cameras[0]);
}
