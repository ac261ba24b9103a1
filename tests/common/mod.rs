//! Shared test helpers: a validated renderer that fails the test on any
//! validation message (including leaks reported at device destruction), and
//! small scenes with known analytic answers.
#![allow(dead_code)]

pub mod host_frame;
pub mod ssbc_accuracy;

use glam::{Mat4, Vec3};
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};
use ssbc::scene::{Camera, Light, LightKind, Scene};

/// Whether the suite runs under the README's test command
/// (`scripts/test.sh`), which has set up everything a check needs.
pub fn under_test_command() -> bool {
    std::env::var_os("SSBC_TEST_COMMAND").is_some()
}

/// A test that cannot run its check here: under the test command that is
/// a setup error and fails the test; elsewhere it says so on stderr (the
/// caller then returns).
pub fn cannot_check(why: &str) {
    assert!(
        !under_test_command(),
        "this test cannot run its check under the test command: {why}"
    );
    eprintln!("SKIPPED (not under scripts/test.sh): {why}");
}

/// Whether `renderer`'s device has ray queries (exact visibility, traced
/// ISM texels); where it has none, says the test cannot check
/// ([`cannot_check`]: a failure under the test command, whose driver has
/// them).
pub fn has_ray_queries(renderer: &Renderer) -> bool {
    let has = renderer.device().ray_queries().is_some();
    if !has {
        cannot_check("the device has no ray queries");
    }
    has
}

/// A tuning variable a test reads (`SSBC_SCENES`, `SSBC_REFINE_RATIO`, ...):
/// when set it changes what the test checks, so the test names it in its
/// output; the test command refuses them (scripts/test.sh).
pub fn tuning_var(name: &str) -> Option<String> {
    let value = std::env::var(name).ok()?;
    assert!(
        !under_test_command(),
        "{name}={value} would change what the tests check; the test command refuses it"
    );
    eprintln!("NOTE: {name}={value} changes what this test checks");
    Some(value)
}

/// Renders `scene` with validation + synchronization validation on, drops the
/// renderer, and panics if the layer reported anything.
pub fn render_validated(scene: &Scene, settings: &RenderSettings) -> Frame {
    let mut renderer = Renderer::new(&RendererConfig {
        validation: true,
        ..Default::default()
    })
    .expect("renderer (is lavapipe + the validation layer installed? run scripts/setup.sh)");
    let log = renderer.validation_log();
    let frame = renderer.render(scene, settings).expect("render");
    drop(renderer);
    assert_eq!(
        log.total(),
        0,
        "validation reported {} warning(s)/error(s)",
        log.total()
    );
    frame
}

/// A renderer with validation and synchronization validation.
pub fn validated_renderer() -> Renderer {
    Renderer::new(&RendererConfig {
        validation: true,
        ..Default::default()
    })
    .expect("renderer (is lavapipe + the validation layer installed? run scripts/setup.sh)")
}

/// A renderer with GPU-assisted validation (every shader's buffer and
/// image accesses checked for bounds).
pub fn gpu_assisted_renderer() -> Renderer {
    Renderer::new(&RendererConfig {
        gpu_assisted_validation: true,
        ..Default::default()
    })
    .expect("renderer with GPU-assisted validation")
}

/// Drops `renderer` (leaks are reported at device destruction) and fails
/// the test if its validation layer reported anything.
pub fn finish_clean(renderer: Renderer) {
    let log = renderer.validation_log();
    drop(renderer);
    assert_eq!(
        log.total(),
        0,
        "validation reported {} message(s): {:?}",
        log.total(),
        log.messages()
    );
}

/// A frame small in every way (64x48, 32 VPLs of 128 points, 16-texel ISM
/// tiles, 128-texel shadow maps) with two SSBC steps.
pub fn tiny_settings() -> RenderSettings {
    let mut s = small(64, 48);
    s.vpl.count = 32;
    s.points_per_vpl = 128;
    s.ism_tile = 16;
    s.shadow_map_size = 128;
    s.ssbc.steps = 2;
    s
}

/// Settings at `width` x `height`, the defaults for that size otherwise,
/// but reading back every output layer (the tests look at them).
pub fn small(width: u32, height: u32) -> RenderSettings {
    RenderSettings {
        output_layers: true,
        ..RenderSettings::new(width, height)
    }
}

/// RGB of pixel (x, y) of a layer.
pub fn pixel(frame: &Frame, layer: &str, x: u32, y: u32) -> Vec3 {
    let l = frame
        .layer(layer.parse().expect("a layer name"))
        .unwrap_or_else(|| panic!("no layer {layer}"));
    let i = ((y * frame.width + x) * 4) as usize;
    Vec3::new(l.rgba[i], l.rgba[i + 1], l.rgba[i + 2])
}

/// A quad from `corner` spanned by `u` and `v` (normal u x v), with uvs from
/// (0, 0) to (uv_scale, uv_scale) along them (tangent along u).
pub fn quad(s: &mut Scene, corner: Vec3, u: Vec3, v: Vec3, material: u32, uv_scale: f32) {
    let n = u.cross(v).normalize();
    let p = [corner, corner + u, corner + u + v, corner + v];
    let uv = [
        [0.0, 0.0],
        [uv_scale, 0.0],
        [uv_scale, uv_scale],
        [0.0, uv_scale],
    ];
    s.add_mesh(
        &p,
        &[n; 4],
        &uv,
        &[0, 1, 2, 0, 2, 3],
        Mat4::IDENTITY,
        material,
    )
    .unwrap();
}

/// A horizontal square plane of side `size` at y = 0 with albedo `albedo`.
pub fn plane_scene(albedo: f32, size: f32) -> Scene {
    let mut s = Scene::new("plane");
    let m = s.add_material(Vec3::splat(albedo), None);
    let h = size * 0.5;
    let p = [
        Vec3::new(-h, 0.0, h),
        Vec3::new(h, 0.0, h),
        Vec3::new(h, 0.0, -h),
        Vec3::new(-h, 0.0, -h),
    ];
    s.add_mesh(
        &p,
        &[Vec3::Y; 4],
        &[],
        &[0, 1, 2, 0, 2, 3],
        Mat4::IDENTITY,
        m,
    )
    .unwrap();
    s.cameras.push(Camera::look_at(
        Vec3::new(0.0, 2.5, 2.0),
        Vec3::ZERO,
        50f32.to_radians(),
    ));
    s
}

/// A point light.
pub fn point_light(position: Vec3, intensity: f32) -> Light {
    Light {
        kind: LightKind::Point,
        position,
        direction: -Vec3::Y,
        intensity: Vec3::splat(intensity),
    }
}

/// Where the camera ray of pixel (x, y) hits the plane y = 0, if it does
/// within `half` of the origin (and not within `margin` of its edge).
pub fn hit_plane(
    camera: &Camera,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
    half: f32,
    margin: f32,
) -> Option<Vec3> {
    let d = camera.pixel_ray(x as f32, y as f32, w, h);
    if d.y >= -1e-4 {
        return None;
    }
    let t = -camera.position.y / d.y;
    let p = camera.position + d * t;
    (p.x.abs() < half - margin && p.z.abs() < half - margin).then_some(p)
}

/// A quad in the XZ plane (size 2 around the origin, normal +Y) as glTF
/// buffer bytes: positions (4 x vec3), normals, uvs, then indices of the
/// given width (2 or 4 bytes; 0 for none). Returns (bytes, index_offset).
pub fn quad_buffer(index_width: usize) -> (Vec<u8>, usize) {
    let mut b = Vec::new();
    let positions = [
        [-1.0f32, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, -1.0],
        [-1.0, 0.0, -1.0],
    ];
    for p in positions {
        for c in p {
            b.extend(c.to_le_bytes());
        }
    }
    for _ in 0..4 {
        for c in [0.0f32, 1.0, 0.0] {
            b.extend(c.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        for c in uv {
            b.extend(c.to_le_bytes());
        }
    }
    let index_offset = b.len();
    for i in [0u32, 1, 2, 0, 2, 3] {
        match index_width {
            2 => b.extend((i as u16).to_le_bytes()),
            4 => b.extend(i.to_le_bytes()),
            _ => {}
        }
    }
    while b.len() % 4 != 0 {
        b.push(0);
    }
    (b, index_offset)
}

/// glTF JSON for one quad mesh in a two-level node hierarchy, with the given
/// buffer URI (None: GLB blob), index component type (5123 u16, 5125 u32, 0
/// none), and extra top-level JSON members (materials, textures, ...).
pub fn quad_gltf(
    uri: Option<&str>,
    byte_length: usize,
    index_type: u32,
    material: Option<u32>,
    extra: &str,
) -> String {
    let index_count = 6;
    let index_width = match index_type {
        5123 => 2,
        5125 => 4,
        _ => 0,
    };
    let indices_view = if index_width > 0 {
        format!(
            r#",{{"buffer":0,"byteOffset":128,"byteLength":{}}}"#,
            index_count * index_width
        )
    } else {
        String::new()
    };
    let indices_acc = if index_width > 0 {
        format!(
            r#",{{"bufferView":3,"componentType":{index_type},"count":{index_count},"type":"SCALAR"}}"#
        )
    } else {
        String::new()
    };
    let prim_indices = if index_width > 0 {
        r#","indices":3"#
    } else {
        ""
    };
    let prim_material = material
        .map(|m| format!(r#","material":{m}"#))
        .unwrap_or_default();
    let uri = uri.map(|u| format!(r#","uri":"{u}""#)).unwrap_or_default();
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"translation":[0,1,0],"scale":[2,2,2],"children":[1]}},{{"mesh":0,"rotation":[0,0.7071068,0,0.7071068],"translation":[1,0,0]}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2}}{prim_indices}{prim_material}}}]}}],
"buffers":[{{"byteLength":{byte_length}{uri}}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":48}},{{"buffer":0,"byteOffset":96,"byteLength":32}}{indices_view}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]}},{{"bufferView":1,"componentType":5126,"count":4,"type":"VEC3"}},{{"bufferView":2,"componentType":5126,"count":4,"type":"VEC2"}}{indices_acc}]{extra}}}"#
    )
}

/// A GLB container around `json` and `bin`.
pub fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while j.len() % 4 != 0 {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while b.len() % 4 != 0 {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend(b"glTF");
    out.extend(2u32.to_le_bytes());
    out.extend((total as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(b);
    out
}

/// Base64 data URI of `bytes`.
pub fn data_uri(bytes: &[u8]) -> String {
    use base64::Engine as _;
    format!(
        "data:application/octet-stream;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(bytes)
    )
}

/// A quad (node 0) moved by animation 0's `channel`: translation keyframes
/// at `times` (0, 1, 2 s), `interpolation` (cubic splines get zero in and
/// out tangents).
pub fn animated_quad_at(interpolation: &str, channel: &str, times: [f32; 3]) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let floats = |bin: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|f| bin.extend(f.to_le_bytes()));
    floats(
        &mut bin,
        &[-1., 0., -1., 1., 0., -1., 1., 0., 1., -1., 0., 1.],
    ); // 0..48
    for i in [0u16, 2, 1, 0, 3, 2] {
        bin.extend(i.to_le_bytes()); // 48..60
    }
    bin.extend([0u8; 4]);
    floats(&mut bin, &times); // 64..76
    floats(&mut bin, &[0., 0., 0., 2., 0., 0., 2., 4., 0.]); // 76..112 linear/step values
                                                             // 112..220: cubic: (in-tangent, value, out-tangent) per key.
    floats(&mut bin, &[0., 0., 0., 0., 0., 0., 0., 0., 0.]);
    floats(&mut bin, &[0., 0., 0., 2., 0., 0., 0., 0., 0.]);
    floats(&mut bin, &[0., 0., 0., 2., 4., 0., 0., 0., 0.]);
    let cubic = interpolation == "CUBICSPLINE";
    let (output_offset, output_count) = if cubic { (112, 9) } else { (76, 3) };
    let uri = data_uri(&bin);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1}}]}}],
"buffers":[{{"byteLength":{len},"uri":"{uri}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}},
 {{"buffer":0,"byteOffset":64,"byteLength":12}},{{"buffer":0,"byteOffset":{output_offset},"byteLength":{output_bytes}}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]}},
 {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}},
 {{"bufferView":2,"componentType":5126,"count":3,"type":"SCALAR","min":[{t0}],"max":[{t2}]}},
 {{"bufferView":3,"componentType":5126,"count":{output_count},"type":"VEC3"}}],
"animations":[{{"channels":[{channel}],
 "samplers":[{{"input":2,"output":3,"interpolation":"{interpolation}"}}]}}]}}"#,
        len = bin.len(),
        output_bytes = output_count * 12,
        t0 = times[0],
        t2 = times[2],
    )
    .into_bytes()
}

pub fn animated_quad(interpolation: &str, channel: &str) -> Vec<u8> {
    animated_quad_at(interpolation, channel, [0.0, 1.0, 2.0])
}

pub const CHANNEL: &str = r#"{"sampler":0,"target":{"node":0,"path":"translation"}}"#;

/// Largest difference between two frames' final images, relative to the
/// brightest value of `b`.
#[allow(dead_code)]
pub fn max_relative_difference(a: &Frame, b: &Frame) -> f32 {
    let peak = b.image.rgba.iter().fold(0f32, |m, &v| m.max(v.abs()));
    a.image
        .rgba
        .iter()
        .zip(&b.image.rgba)
        .fold(0f32, |m, (x, y)| m.max((x - y).abs()))
        / peak.max(1e-12)
}

/// The CPU stages a frame ran.
#[allow(dead_code)]
pub fn stages(frame: &Frame) -> Vec<&str> {
    frame
        .timings
        .cpu_spans
        .iter()
        .map(|s| s.name.as_str())
        .collect()
}

/// A `side` x `side` tangent-space normal map: texel (x, y) tilted by the
/// slopes `slope(x, y)` along the tangent and the bitangent.
#[allow(dead_code)]
pub fn normal_map(side: u32, slope: impl Fn(u32, u32) -> (f32, f32)) -> ssbc::scene::Texture {
    ssbc::scene::Texture {
        width: side,
        height: side,
        rgba8: (0..side * side)
            .flat_map(|i| {
                let (sx, sy) = slope(i % side, i / side);
                let n = Vec3::new(sx, sy, 1.0).normalize();
                let [x, y, z] = [n.x, n.y, n.z].map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8);
                [x, y, z, 255]
            })
            .collect(),
    }
}

/// Every channel of every layer of an EXR, by name (`layer/channel`),
/// sorted by name.
pub fn exr_channels(path: &std::path::Path) -> Vec<(String, Vec<f32>)> {
    ssbc::output::read_exr_channels(path).expect("read EXR")
}

/// The previous lavapipe (Debian 12's own Mesa 22.3, unpacked by
/// scripts/setup.sh): its ICD manifest, or None (and [`cannot_check`])
/// where there is none.
pub fn previous_driver() -> Option<String> {
    let manifest = std::env::var("SSBC_PREVIOUS_ICD")
        .unwrap_or_else(|_| "/usr/local/lib/ssbc-mesa-stock/lvp_icd.json".into());
    if std::path::Path::new(&manifest).is_file() {
        Some(manifest)
    } else {
        cannot_check(&format!(
            "no previous driver at {manifest} (scripts/setup.sh unpacks it)"
        ));
        None
    }
}
