//! Hierarchical SSBC against the brute-force CPU twin, and the open-front
//! box the accuracy checks use besides the built-in scenes. Shared by
//! `tests/ssbc.rs` and `examples/ssbc_accuracy.rs` (included by path).

#![allow(dead_code)]

use glam::{Mat4, Vec3};
use ssbc::cpu::ssbc::{compare_with_twin, BruteForceTwin, GBufferView, TwinCamera, TwinComparison};
use ssbc::renderer::{Bound, Frame, RenderSettings, Renderer};
use ssbc::scene::{Camera, Light, LightKind, Scene};

fn quad(s: &mut Scene, corner: Vec3, u: Vec3, v: Vec3, material: u32) {
    let n = u.cross(v).normalize();
    let p = [corner, corner + u, corner + u + v, corner + v];
    s.add_mesh(
        &p,
        &[n; 4],
        &[],
        &[0, 1, 2, 0, 2, 3],
        Mat4::IDENTITY,
        material,
    )
    .expect("quad");
}

/// An axis-aligned box on the floor (five visible faces and a bottom).
fn block(s: &mut Scene, min: Vec3, max: Vec3, material: u32) {
    let d = max - min;
    let (x, y, z) = (Vec3::X * d.x, Vec3::Y * d.y, Vec3::Z * d.z);
    quad(s, min + z, x, y, material); // +z
    quad(s, min + x, -x, y, material); // -z
    quad(s, min + x + z, -z, y, material); // +x
    quad(s, min, z, y, material); // -x
    quad(s, min + y + z, x, -z, material); // +y
    quad(s, min, x, z, material); // -y
}

/// A plain white room open towards the camera: five quads (floor, ceiling,
/// back and side walls; 3 m wide, 2.4 m high, 2.5 m deep), two boxes, and a
/// 15 W/sr point light 10 cm under the ceiling. Not a built-in scene: its
/// proportions, albedo and framing differ from `cornell`.
pub fn open_box() -> Scene {
    let mut s = Scene::new("open-box");
    let white = s.add_material(Vec3::splat(0.8), None);
    let (w, h, d) = (3.0f32, 2.4f32, 2.5f32);
    let (x0, z0, z1) = (-w / 2.0, -d / 2.0, d / 2.0);
    quad(
        &mut s,
        Vec3::new(x0, 0.0, z1),
        Vec3::X * w,
        -Vec3::Z * d,
        white,
    ); // floor
    quad(
        &mut s,
        Vec3::new(x0, h, z0),
        Vec3::X * w,
        Vec3::Z * d,
        white,
    ); // ceiling
    quad(
        &mut s,
        Vec3::new(x0, 0.0, z0),
        Vec3::X * w,
        Vec3::Y * h,
        white,
    ); // back
    quad(
        &mut s,
        Vec3::new(x0, 0.0, z1),
        -Vec3::Z * d,
        Vec3::Y * h,
        white,
    ); // left
    quad(
        &mut s,
        Vec3::new(-x0, 0.0, z0),
        Vec3::Z * d,
        Vec3::Y * h,
        white,
    ); // right
    block(
        &mut s,
        Vec3::new(-1.1, 0.0, -0.9),
        Vec3::new(-0.4, 1.3, -0.3),
        white,
    );
    block(
        &mut s,
        Vec3::new(0.3, 0.0, -0.1),
        Vec3::new(1.0, 0.5, 0.6),
        white,
    );
    s.lights.push(Light {
        kind: LightKind::Point,
        position: Vec3::new(0.2, h - 0.1, -0.2),
        direction: -Vec3::Y,
        intensity: Vec3::splat(15.0),
    });
    s.cameras.push(Camera::look_at(
        Vec3::new(0.6, 1.3, 4.2),
        Vec3::new(-0.1, 0.9, -0.5),
        50f32.to_radians(),
    ));
    s
}

/// Render settings for one hierarchical step at `size` with `bound`.
pub fn one_step(size: (u32, u32), bound: Bound) -> RenderSettings {
    let mut s = RenderSettings {
        width: size.0,
        height: size.1,
        bound,
        debug_readback: true,
        ..Default::default()
    };
    s.vpl.count = 64;
    s.ssbc.steps = 1;
    // Tuning overrides (examples/ssbc_accuracy.rs): SSBC_<FIELD>=value,
    // named in the output; the test command refuses them.
    let var = |name: &str| {
        let value = std::env::var(name).ok()?;
        assert!(
            std::env::var_os("SSBC_TEST_COMMAND").is_none(),
            "{name}={value} would change what the tests check"
        );
        eprintln!("NOTE: {name}={value} overrides the default setting");
        Some(
            value
                .parse::<f32>()
                .unwrap_or_else(|_| panic!("{name}={value}: not a number")),
        )
    };
    if let Some(v) = var("SSBC_REFINE_RATIO") {
        s.ssbc.refine_ratio = v;
    }
    if let Some(v) = var("SSBC_REFINE_EXCESS") {
        s.ssbc.refine_excess = v;
    }
    if let Some(v) = var("SSBC_MAX_NORMAL_SPREAD") {
        s.ssbc.max_normal_spread = v;
    }
    if let Some(v) = var("SSBC_MAX_THICKNESS") {
        s.ssbc.max_thickness = v;
    }
    if let Some(v) = var("SSBC_TEXELS_PER_RADIUS") {
        s.ssbc.texels_per_radius = v;
    }
    if let Some(v) = var("SSBC_SCALE_FRACTION") {
        s.ssbc.scale_fraction = v;
    }
    if let Some(v) = var("SSBC_MAX_EVAL_LEVEL") {
        s.ssbc.max_eval_level = v as u32;
    }
    s
}

/// Renders one step and compares `residual_1` with the brute-force twin on
/// every `stride`-th pixel.
pub fn residual_vs_twin(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    stride: usize,
) -> (TwinComparison, Frame) {
    let frame = renderer.render(scene, settings).expect("render");
    let layer = |name: &str| {
        &frame
            .layer(name.parse().expect("a layer name"))
            .unwrap_or_else(|| panic!("layer {name}"))
            .rgba
    };
    let camera = scene.camera(settings.camera).expect("camera");
    let g = GBufferView {
        width: frame.width,
        height: frame.height,
        position: layer("gbuffer_position"),
        normal: layer("gbuffer_normal"),
        albedo: layer("gbuffer_albedo"),
    };
    // What the pixels send (S0 on Lambertian surfaces).
    let s0 = layer("sources");
    let twin_camera = TwinCamera {
        position: camera.position,
        forward: camera.forward,
        up: camera.up,
        pixel_side: 2.0 * (camera.yfov * 0.5).tan() / frame.height as f32,
        min_cos_view: settings.ssbc.min_cos_view,
        principal: glam::Vec2::ZERO,
    };
    let twin = BruteForceTwin::new(&g, s0, twin_camera, frame.bound)
        .with_glossy_receivers(camera.position);
    let comparison = compare_with_twin(&twin, layer("residual_1"), stride);
    (comparison, frame)
}
