//! The glTF loader: hierarchy transforms, index types, GLB, embedded buffers,
//! textures (checked in a render), lights and cameras.

mod common;

use common::*;
use glam::{Quat, Vec3};
use ssbc::scene::{gltf_loader, LightKind};
use std::f32::consts::PI;

/// The quad's corners after the two-node hierarchy in `quad_gltf`.
fn expected_corners() -> Vec<Vec3> {
    let r = Quat::from_rotation_y(PI / 2.0);
    [
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(1.0, 0.0, -1.0),
        Vec3::new(-1.0, 0.0, -1.0),
    ]
    .iter()
    .map(|&p| (r * p + Vec3::X) * 2.0 + Vec3::Y)
    .collect()
}

fn check_quad(scene: &ssbc::Scene) {
    assert_eq!(scene.triangle_count(), 2);
    let positions: Vec<Vec3> = scene
        .world_triangles()
        .flatten()
        .map(|v| Vec3::from(v.position))
        .collect();
    let expected = expected_corners();
    for (k, &i) in [0usize, 1, 2, 0, 2, 3].iter().enumerate() {
        assert!(
            (positions[k] - expected[i]).length() < 1e-5,
            "corner {k}: {} vs {}",
            positions[k],
            expected[i]
        );
    }
    for v in scene.world_triangles().flatten() {
        assert!(
            (Vec3::from(v.normal) - Vec3::Y).length() < 1e-5,
            "normal stays +Y under rotation about Y"
        );
    }
}

fn load_str(dir: &std::path::Path, name: &str, content: &[u8]) -> ssbc::Result<ssbc::Scene> {
    let path = dir.join(name);
    std::fs::write(&path, content).unwrap();
    gltf_loader::load(&path, None)
}

#[test]
fn hierarchy_with_u16_indices_and_embedded_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let (bin, _) = quad_buffer(2);
    let json = quad_gltf(Some(&data_uri(&bin)), bin.len(), 5123, None, "");
    check_quad(&load_str(dir.path(), "q.gltf", json.as_bytes()).unwrap());
}

#[test]
fn u32_indices_and_external_buffer() {
    let dir = tempfile::tempdir().unwrap();
    let (bin, _) = quad_buffer(4);
    std::fs::write(dir.path().join("quad data.bin"), &bin).unwrap();
    let json = quad_gltf(Some("quad%20data.bin"), bin.len(), 5125, None, "");
    check_quad(&load_str(dir.path(), "q.gltf", json.as_bytes()).unwrap());
}

#[test]
fn no_indices_means_sequential_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let (bin, _) = quad_buffer(0);
    let json = quad_gltf(Some(&data_uri(&bin)), bin.len(), 0, None, "");
    let s = load_str(dir.path(), "q.gltf", json.as_bytes()).unwrap();
    // 4 vertices without indices: one triangle (the 4th vertex is left over).
    assert_eq!(s.triangle_count(), 1);
}

#[test]
fn glb_with_binary_chunk() {
    let dir = tempfile::tempdir().unwrap();
    let (bin, _) = quad_buffer(2);
    let json = quad_gltf(None, bin.len(), 5123, None, "");
    check_quad(&load_str(dir.path(), "q.glb", &glb(&json, &bin)).unwrap());
}

#[test]
fn lights_and_cameras_are_read_radiometrically() {
    let dir = tempfile::tempdir().unwrap();
    let (bin, _) = quad_buffer(2);
    let mut json = quad_gltf(
        Some(&data_uri(&bin)),
        bin.len(),
        5123,
        None,
        r#","cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.1}}],
"extensionsUsed":["KHR_lights_punctual"],
"extensions":{"KHR_lights_punctual":{"lights":[{"type":"spot","intensity":7,"color":[1,0.5,0.25],"spot":{"innerConeAngle":0.2,"outerConeAngle":0.5}},{"type":"directional","intensity":3}]}}"#,
    );
    // Add a camera node and two light nodes as extra roots.
    json = json.replace(
        r#""scenes":[{"nodes":[0]}]"#,
        r#""scenes":[{"nodes":[0,2,3,4]}]"#,
    );
    json = json.replace(
        r#"{"mesh":0,"rotation":[0,0.7071068,0,0.7071068],"translation":[1,0,0]}]"#,
        r#"{"mesh":0,"rotation":[0,0.7071068,0,0.7071068],"translation":[1,0,0]},
{"camera":0,"translation":[0,1,5]},
{"translation":[0,3,0],"rotation":[-0.7071068,0,0,0.7071068],"extensions":{"KHR_lights_punctual":{"light":0}}},
{"extensions":{"KHR_lights_punctual":{"light":1}}}]"#,
    );
    let s = load_str(dir.path(), "q.gltf", json.as_bytes()).unwrap();
    assert_eq!(s.cameras.len(), 1);
    assert!((s.cameras[0].position - Vec3::new(0.0, 1.0, 5.0)).length() < 1e-6);
    assert!((s.cameras[0].forward - -Vec3::Z).length() < 1e-6);
    assert_eq!(s.lights.len(), 2);
    let spot = &s.lights[0];
    assert!(matches!(spot.kind, LightKind::Spot { .. }));
    assert!(
        (spot.intensity - Vec3::new(7.0, 3.5, 1.75)).length() < 1e-6,
        "W/sr = intensity x color, no 683 lm/W"
    );
    assert!(
        (spot.direction - -Vec3::Y).length() < 1e-5,
        "rotated -90 deg about X points down"
    );
    assert!((spot.position - Vec3::new(0.0, 3.0, 0.0)).length() < 1e-6);
    assert!(matches!(s.lights[1].kind, LightKind::Directional));
    assert!((s.lights[1].direction - -Vec3::Z).length() < 1e-6);
}

/// The quad with material 0 given as JSON (its textures all image 0, a
/// 64x64 PNG whose left half is `left` and right half `right`), loaded and
/// seen from straight above under a perpendicular 1 W/m^2 directional
/// light. The quad spans x 0..4, z -2..2 after the hierarchy, with u =
/// (1 - z/2) / 2; image up is -Z, so the top of the image sees u > 1/2 (the
/// texture's right half) and the bottom u < 1/2.
fn textured_quad_from_above(material: &str, left: [u8; 3], right: [u8; 3]) -> ssbc::Scene {
    let dir = tempfile::tempdir().unwrap();
    let tex = image::RgbaImage::from_fn(64, 64, |x, _| {
        let c = if x < 32 { left } else { right };
        image::Rgba([c[0], c[1], c[2], 255])
    });
    tex.save(dir.path().join("tex.png")).unwrap();
    let (bin, _) = quad_buffer(2);
    let json = quad_gltf(
        Some(&data_uri(&bin)),
        bin.len(),
        5123,
        Some(0),
        &format!(
            r#","materials":[{material}],"textures":[{{"source":0}}],"images":[{{"uri":"tex.png"}}]"#
        ),
    );
    let mut scene = load_str(dir.path(), "t.gltf", json.as_bytes()).unwrap();
    let center = Vec3::new(2.0, 1.0, 0.0);
    scene.cameras.push(ssbc::scene::Camera {
        position: center + Vec3::Y * 3.0,
        forward: -Vec3::Y,
        up: -Vec3::Z,
        yfov: 60f32.to_radians(),
        jitter: glam::Vec2::ZERO,
    });
    scene.lights.push(ssbc::scene::Light {
        kind: LightKind::Directional,
        position: Vec3::ZERO,
        direction: -Vec3::Y,
        intensity: Vec3::ONE,
    });
    scene
}

#[test]
fn base_color_texture_is_sampled_in_the_render() {
    // Left half sRGB (200, 40, 40), right half (30, 60, 220). The light
    // makes the radiance f(n, n): for this rough dielectric (metallic 0,
    // roughness 1: F = 0.04, D = 1/pi, V = 1/4) (0.96 base + 0.01) / pi.
    let (left, right) = ([200u8, 40, 40], [30u8, 60, 220]);
    let scene = textured_quad_from_above(
        r#"{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,1],"baseColorTexture":{"index":0},"metallicFactor":0}}"#,
        left,
        right,
    );
    let frame = render_validated(&scene, &small(64, 64));
    let linear = |c: [u8; 3]| {
        Vec3::from(c.map(|v| {
            let s = v as f32 / 255.0;
            if s <= 0.04045 {
                s / 12.92
            } else {
                ((s + 0.055) / 1.055).powf(2.4)
            }
        }))
    };
    for (x, y, texel) in [
        (32, 12, right),
        (10, 8, right),
        (32, 52, left),
        (50, 56, left),
    ] {
        let got = pixel(&frame, "direct", x, y);
        let want = (0.96 * linear(texel) + Vec3::splat(0.01)) / PI;
        assert!(
            (got - want).abs().max_element() < 0.01 * want.max_element(),
            "pixel ({x},{y}): got {got}, expected {want}"
        );
    }
}

/// glTF's metallicRoughnessTexture is linear, B scales metallic and G
/// roughness, with the texture's own sampler; the same image used as base
/// colour is sRGB. The G-buffer (albedo.w metallic, normal.w roughness) and
/// the CPU's BRDF must both read it so.
#[test]
fn metallic_roughness_texture_is_linear_blue_metal_green_roughness() {
    // Left half: G 64, B 255 (rough 0.8 x 0.251, metal 0.5 x 1); right
    // half: G 200, B 0 (rough 0.8 x 0.784, metal 0). R is the opposite of B.
    let (left, right) = ([0u8, 64, 255], [255u8, 200, 0]);
    let scene = textured_quad_from_above(
        r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0},
"metallicFactor":0.5,"roughnessFactor":0.8,"metallicRoughnessTexture":{"index":0}}}"#,
        left,
        right,
    );
    let mut settings = small(64, 64);
    settings.debug_readback = true;
    let frame = render_validated(&scene, &settings);
    let w = |layer: &str, x: u32, y: u32| {
        let l = frame.layer(layer.parse().unwrap()).unwrap();
        l.rgba[((y * frame.width + x) * 4 + 3) as usize]
    };
    let srgb = |v: u8| {
        let s = v as f32 / 255.0;
        if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        }
    };
    for (x, y, texel, u) in [(32, 12, right, 0.75f32), (32, 52, left, 0.25)] {
        let metallic = 0.5 * texel[2] as f32 / 255.0;
        let roughness = 0.8 * texel[1] as f32 / 255.0;
        let (got_m, got_r) = (w("gbuffer_albedo", x, y), w("gbuffer_normal", x, y));
        assert!(
            (got_m - metallic).abs() < 0.01 && (got_r - roughness).abs() < 0.01,
            "pixel ({x},{y}): G-buffer metallic {got_m}, roughness {got_r}; expected {metallic}, {roughness}"
        );
        let base = pixel(&frame, "gbuffer_albedo", x, y);
        assert!(
            (base.y - srgb(texel[1])).abs() < 0.01,
            "pixel ({x},{y}): base colour {base} is not the sRGB-decoded texel"
        );
        let cpu = ssbc::cpu::shading::brdf(
            &scene,
            &scene.materials[0],
            glam::Vec2::new(u, 0.5),
            glam::Vec4::ONE,
        );
        assert!(
            (cpu.metallic - metallic).abs() < 0.01 && (cpu.roughness - roughness).abs() < 0.01,
            "CPU BRDF at u = {u}: metallic {}, roughness {}",
            cpu.metallic,
            cpu.roughness
        );
    }
}

/// A 2x2 PNG as a data URI.
fn png_uri() -> String {
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([128, 128, 255, 200]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    use base64::Engine as _;
    format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(out.into_inner())
    )
}

/// The quad with material 0 given as JSON, and the usual texture set.
fn quad_with_material(material: &str) -> String {
    let (bin, _) = quad_buffer(2);
    quad_gltf(
        Some(&data_uri(&bin)),
        bin.len(),
        5123,
        Some(0),
        &format!(
            r#","materials":[{material}],
"textures":[{{"source":0}},{{"source":0,"sampler":0}},{{"source":0,"sampler":1}}],
"samplers":[{{"wrapS":33071,"wrapT":33648,"magFilter":9728}},{{}}],
"images":[{{"uri":"{}"}}],
"extensionsUsed":["KHR_materials_emissive_strength"]"#,
            png_uri()
        ),
    )
}

#[test]
fn emission_alpha_normal_maps_and_samplers_are_read() {
    use ssbc::scene::{AlphaMode, Wrap};
    let dir = tempfile::tempdir().unwrap();
    let json = quad_with_material(
        r#"{"pbrMetallicRoughness":{"baseColorFactor":[1,1,1,0.5],"baseColorTexture":{"index":1}},
"emissiveFactor":[1,0.5,0.25],"emissiveTexture":{"index":2},
"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":40}},
"normalTexture":{"index":0,"scale":0.5},"alphaMode":"MASK","alphaCutoff":0.3,"doubleSided":true}"#,
    );
    let scene = load_str(dir.path(), "m.gltf", json.as_bytes()).unwrap();
    let m = &scene.materials[0];
    assert_eq!(m.emission, Vec3::new(40.0, 20.0, 10.0), "factor x strength");
    assert_eq!(m.alpha, AlphaMode::Mask(0.3));
    assert!(m.double_sided);
    assert_eq!(m.normal_scale, 0.5);
    assert_eq!(m.sampler.wrap_s, Wrap::ClampToEdge);
    assert_eq!(m.sampler.wrap_t, Wrap::MirroredRepeat);
    assert!(m.sampler.nearest);
    let emissive = m.emissive_texture.unwrap();
    assert_eq!(emissive.sampler.wrap_s, Wrap::Repeat);
    assert!(!emissive.sampler.nearest);
    // One image decoded once, used three times.
    assert_eq!(scene.textures.len(), 1);
    // Tangents were generated for the normal map, along +u.
    let t = scene.world_triangles().next().unwrap()[0].tangent;
    assert!((Vec3::new(t[0], t[1], t[2]).length() - 1.0).abs() < 1e-5 && t[3].abs() == 1.0);
    // BLEND reads as a mask at 0.5; the glTF default is one-sided.
    let json = quad_with_material(r#"{"alphaMode":"BLEND"}"#);
    let m = &load_str(dir.path(), "b.gltf", json.as_bytes())
        .unwrap()
        .materials[0];
    assert_eq!(m.alpha, AlphaMode::Mask(0.5));
    assert!(!m.double_sided);
}

#[test]
fn bad_material_values_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (material, expected) in [
        (
            r#"{"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":-2}}}"#,
            "emissive_strength",
        ),
        (
            r#"{"emissiveFactor":[1,1,1],"extensions":{"KHR_materials_emissive_strength":{"emissiveStrength":1e39}}}"#,
            "emissive",
        ),
        (r#"{"emissiveFactor":[1,-1,1]}"#, "emissiveFactor"),
        (
            r#"{"emissiveFactor":[1,1,1],"emissiveTexture":{"index":7}}"#,
            "texture index 7",
        ),
        (
            r#"{"alphaMode":"MASK","alphaCutoff":1.5}"#,
            "alphaCutoff 1.5",
        ),
        (r#"{"normalTexture":{"index":9}}"#, "texture index 9"),
    ] {
        let json = quad_with_material(material);
        let e = load_str(dir.path(), "bad.gltf", json.as_bytes())
            .expect_err(material)
            .to_string();
        assert!(e.contains(expected) && !e.contains('\n'), "{material}: {e}");
    }
}

/// `quad_with_material` with a second texture coordinate set, TEXCOORD_1:
/// the first eight floats of the positions, (-1, 0), (1, 1), (0, 1), (1, 0).
fn quad_with_two_uv_sets(material: &str) -> String {
    quad_with_material(material)
        .replace(r#""TEXCOORD_0":2}"#, r#""TEXCOORD_0":2,"TEXCOORD_1":4}"#)
        .replace(
            r#""type":"SCALAR"}]"#,
            r#""type":"SCALAR"},{"bufferView":0,"componentType":5126,"count":4,"type":"VEC2"}]"#,
        )
}

/// The texture coordinates of the loaded quad's six corners (two triangles).
fn corner_uvs(scene: &ssbc::Scene) -> Vec<glam::Vec2> {
    scene
        .world_triangles()
        .flatten()
        .map(|v| glam::Vec2::from(v.uv))
        .collect()
}

/// A material's `texCoord` picks the TEXCOORD set, and KHR_texture_transform
/// maps it, T * R * S with the rotation turning uv counter-clockwise in
/// glTF's v-down uv space (u' = cos u + sin v, v' = -sin u + cos v; the
/// direction implementations and the sample `TextureTransformTest` use).
/// Both are applied to the mesh's uvs, which the GPU and the CPU read.
#[test]
fn texture_coordinate_sets_and_texture_transforms_map_uvs() {
    use glam::Vec2;
    let dir = tempfile::tempdir().unwrap();
    let set0 = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]].map(Vec2::from);
    let set1 = [[-1.0f32, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]].map(Vec2::from);
    let (offset, rotation, scale) = (Vec2::new(0.5, 0.25), 0.3f32, Vec2::new(2.0, 3.0));
    let mapped = |uv: Vec2| {
        let s = uv * scale;
        let (sin, cos) = rotation.sin_cos();
        offset + Vec2::new(cos * s.x + sin * s.y, -sin * s.x + cos * s.y)
    };
    let transform = format!(
        r#""extensions":{{"KHR_texture_transform":{{"offset":[{},{}],"rotation":{rotation},"scale":[{},{}]TEXCOORD}}}}"#,
        offset.x, offset.y, scale.x, scale.y
    );
    let in_transform = transform.replace("TEXCOORD", r#","texCoord":1"#);
    let transform = transform.replace("TEXCOORD", "");
    // The quad's corners, in triangle order.
    let corners = |set: [Vec2; 4]| [0, 1, 2, 0, 2, 3].map(|i| set[i]);
    for (material, expected) in [
        (
            r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0,"texCoord":1}}}"#.to_string(),
            corners(set1),
        ),
        (
            format!(
                r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,{transform}}}}}}}"#
            ),
            corners(set0).map(mapped),
        ),
        // The extension's texCoord overrides the textureInfo's; every
        // texture the same, the normal texture's extension included.
        (
            format!(
                r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,{in_transform}}},
"metallicRoughnessTexture":{{"index":1,"texCoord":1,{transform}}}}},
"normalTexture":{{"index":0,{in_transform}}},"emissiveTexture":{{"index":2,"texCoord":1,{transform}}}}}"#
            ),
            corners(set1).map(mapped),
        ),
        // Textures that disagree are read with the base colour's map (and a
        // warning says so).
        (
            format!(
                r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"texCoord":1}}}},
"normalTexture":{{"index":0,{transform}}}}}"#
            ),
            corners(set1),
        ),
        // No texture: set 0 as it is.
        (r#"{"emissiveFactor":[1,1,1]}"#.to_string(), corners(set0)),
    ] {
        let json = quad_with_two_uv_sets(&material);
        let scene = load_str(dir.path(), "uv.gltf", json.as_bytes()).expect(&material);
        let got = corner_uvs(&scene);
        for (g, e) in got.iter().zip(expected) {
            assert!(
                (*g - e).length() < 1e-5,
                "{material}: uvs {got:?}, expected {expected:?}"
            );
        }
    }
    // A transform past the largest float is a clear error, as is a missing
    // set (a warning, then set 0's absence: uv 0).
    for transform in [
        r#"{"offset":[3e38,0],"scale":[3e38,1]}"#,
        r#"{"offset":[1e39,0]}"#,
    ] {
        let json = quad_with_two_uv_sets(&format!(
            r#"{{"pbrMetallicRoughness":{{"baseColorTexture":{{"index":0,"extensions":{{"KHR_texture_transform":{transform}}}}}}}}}"#
        ));
        let e = load_str(dir.path(), "big.gltf", json.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("KHR_texture_transform") && !e.contains('\n'),
            "{transform}: {e}"
        );
    }
    let json = quad_with_two_uv_sets(
        r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0,"texCoord":5}}}"#,
    );
    let scene = load_str(dir.path(), "missing.gltf", json.as_bytes()).unwrap();
    assert!(corner_uvs(&scene).iter().all(|uv| *uv == Vec2::ZERO));
}

/// The render reads the transformed uvs: mirrored in u (scale [-1, 1],
/// offset [1, 0]) the texture's halves swap sides.
#[test]
fn a_texture_transform_shows_in_the_render() {
    let (left, right) = ([200u8, 40, 40], [30u8, 60, 220]);
    let plain = r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0},"metallicFactor":0}}"#;
    let mirrored = r#"{"pbrMetallicRoughness":{"baseColorTexture":{"index":0,
"extensions":{"KHR_texture_transform":{"offset":[1,0],"scale":[-1,1]}}},"metallicFactor":0}}"#;
    let settings = small(32, 32);
    let a = render_validated(&textured_quad_from_above(plain, left, right), &settings);
    let b = render_validated(&textured_quad_from_above(mirrored, left, right), &settings);
    for (x, y) in [(16, 6), (16, 26), (5, 4), (27, 28)] {
        let (pa, pb) = (pixel(&a, "direct", x, y), pixel(&b, "direct", x, y));
        let (qa, qb) = (
            pixel(&a, "direct", x, 31 - y),
            pixel(&b, "direct", x, 31 - y),
        );
        assert!(
            (pa - qb).abs().max_element() < 0.01 * pa.max_element()
                && (pb - qa).abs().max_element() < 0.01 * pb.max_element()
                && (pa - pb).abs().max_element() > 0.2 * pa.max_element(),
            "pixel ({x},{y}): plain {pa} / {qa}, mirrored {pb} / {qb}"
        );
    }
}

/// Each texture of a material is read at its own `KHR_texture_transform`
/// of the shared TEXCOORD set: an emissive texture mirrored in u beside an
/// untransformed base colour texture shows mirrored, on the GPU and in the
/// CPU's shading, as it does alone. Before, the base colour's map was used
/// for both (and a warning said so). Black metal: only the emission shows.
#[test]
fn each_texture_is_read_at_its_own_texture_transform() {
    use ssbc::cpu::shading::{emission, srgb_to_linear};
    let (left, right) = ([200u8, 40, 40], [30u8, 60, 220]);
    let linear = |c: [u8; 3]| Vec3::from(c.map(srgb_to_linear));
    let mirror = r#","extensions":{"KHR_texture_transform":{"offset":[1,0],"scale":[-1,1]}}"#;
    let material = |base: &str, emissive: &str| {
        format!(
            r#"{{"pbrMetallicRoughness":{{"baseColorFactor":[0,0,0,1],"metallicFactor":1{base}}},
"emissiveFactor":[1,1,1],"emissiveTexture":{{"index":0{emissive}}}}}"#
        )
    };
    let with_base = r#","baseColorTexture":{"index":0}"#;
    let both = textured_quad_from_above(&material(with_base, mirror), left, right);
    let alone = textured_quad_from_above(&material("", mirror), left, right);
    let plain = textured_quad_from_above(&material(with_base, ""), left, right);
    // The CPU: u < 1/2 reads the mirrored texture's right half.
    let m = &both.materials[0];
    for (u, expected) in [(0.25, linear(right)), (0.75, linear(left))] {
        let e = emission(&both, m, glam::Vec2::new(u, 0.5));
        assert!(
            (e - expected).abs().max_element() < 1e-5,
            "u {u}: {e}, expected {expected}"
        );
    }
    // The GPU: the top of the image sees u > 1/2.
    let settings = small(32, 32);
    let [both, alone, plain] = [both, alone, plain].map(|s| render_validated(&s, &settings));
    for (x, y, expected) in [
        (16, 6, linear(left)),
        (16, 26, linear(right)),
        (5, 4, linear(left)),
    ] {
        let (b, a, p) = (
            pixel(&both, "direct", x, y),
            pixel(&alone, "direct", x, y),
            pixel(&plain, "direct", x, y),
        );
        assert!(
            (b - expected).abs().max_element() < 0.01 * expected.max_element()
                && (b - a).abs().max_element() < 0.01 * a.max_element()
                && (b - p).abs().max_element() > 0.2 * p.max_element(),
            "pixel ({x},{y}): {b} beside the base colour, {a} alone, {p} untransformed; expected {expected}"
        );
    }
}

/// The quad with material 0 given as JSON and a COLOR_0 attribute:
/// `color_bytes` appended to the buffer, read by an accessor with the given
/// members (componentType, type, ...; its bufferView is filled in).
fn quad_with_colors(material: &str, color_bytes: &[u8], accessor: &str) -> String {
    let (mut bin, _) = quad_buffer(2);
    let offset = bin.len();
    bin.extend(color_bytes);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    quad_gltf(
        Some(&data_uri(&bin)),
        bin.len(),
        5123,
        Some(0),
        &format!(r#","materials":[{material}]"#),
    )
    .replace(r#""TEXCOORD_0":2}"#, r#""TEXCOORD_0":2,"COLOR_0":4}"#)
    .replace(
        "],\n\"accessors\":[",
        &format!(
            ",{{\"buffer\":0,\"byteOffset\":{offset},\"byteLength\":{}}}],\n\"accessors\":[",
            color_bytes.len()
        ),
    )
    .replace(
        r#""type":"SCALAR"}]"#,
        &format!(r#""type":"SCALAR"}},{{"bufferView":4,"count":4,{accessor}}}]"#),
    )
}

fn le_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// COLOR_0 as glTF allows it (RGB or RGBA; float, unsigned byte or short
/// normalized) becomes each vertex's RGBA; floats past [0, 1] are clamped;
/// other types are clear errors.
#[test]
fn vertex_colors_are_read_in_every_allowed_encoding() {
    use glam::Vec4;
    let dir = tempfile::tempdir().unwrap();
    let floats = [
        0.2f32, 0.4, 0.6, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5,
    ];
    let bytes: Vec<u8> = (0..16).map(|i| (i * 17) as u8).collect();
    let shorts: Vec<u8> = (0..16u32)
        .flat_map(|i| ((i * 4369) as u16).to_le_bytes())
        .collect();
    let rgb = |c: &[f32]| {
        c.chunks(3)
            .map(|c| Vec4::new(c[0], c[1], c[2], 1.0))
            .collect::<Vec<_>>()
    };
    let rgba = |n: f32| {
        (0..4)
            .map(|k| Vec4::from_slice(&[0, 1, 2, 3].map(|i| (4 * k + i) as f32 / n)))
            .collect::<Vec<_>>()
    };
    for (bytes, accessor, expected) in [
        (
            le_bytes(&floats),
            r#""componentType":5126,"type":"VEC3""#,
            rgb(&floats),
        ),
        (
            bytes,
            r#""componentType":5121,"normalized":true,"type":"VEC4""#,
            rgba(15.0),
        ),
        (
            shorts,
            r#""componentType":5123,"normalized":true,"type":"VEC4""#,
            rgba(15.0),
        ),
        (
            le_bytes(&[1.5, -0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            r#""componentType":5126,"type":"VEC3""#,
            rgb(&[1.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ),
    ] {
        let json = quad_with_colors("{}", &bytes, accessor);
        let scene = load_str(dir.path(), "c.gltf", json.as_bytes()).expect(accessor);
        let got: Vec<Vec4> = scene
            .world_triangles()
            .flatten()
            .map(|v| v.color())
            .collect();
        for (k, &i) in [0usize, 1, 2, 0, 2, 3].iter().enumerate() {
            assert!(
                (got[k] - expected[i]).abs().max_element() < 1e-4,
                "{accessor}: corner {k}: {} against {}",
                got[k],
                expected[i]
            );
        }
    }
    for (bytes, accessor, expected) in [
        (
            le_bytes(&[0.5; 4]),
            r#""componentType":5126,"type":"SCALAR""#,
            "COLOR_0 must be VEC3 or VEC4",
        ),
        (
            le_bytes(&[0.5; 16]),
            r#""componentType":5125,"type":"VEC4""#,
            "not supported",
        ),
    ] {
        let json = quad_with_colors("{}", &bytes, accessor);
        let e = load_str(dir.path(), "c.gltf", json.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected) && !e.contains('\n'), "{accessor}: {e}");
    }
    // Without COLOR_0, white.
    let json = quad_with_material("{}");
    let scene = load_str(dir.path(), "w.gltf", json.as_bytes()).unwrap();
    assert!(scene
        .world_triangles()
        .flatten()
        .all(|v| v.color() == Vec4::ONE));
}

/// The quad lit from above as `textured_quad_from_above` (it fills the
/// view), its material white and its COLOR_0 the given RGBA floats.
fn colored_quad_from_above(material: &str, colors: &[f32; 16]) -> ssbc::Scene {
    let dir = tempfile::tempdir().unwrap();
    let json = quad_with_colors(
        material,
        &le_bytes(colors),
        r#""componentType":5126,"type":"VEC4""#,
    );
    let mut scene = load_str(dir.path(), "c.gltf", json.as_bytes()).unwrap();
    let reference = textured_quad_from_above("{}", [0; 3], [0; 3]);
    scene.cameras = reference.cameras.clone();
    scene.lights = reference.lights.clone();
    scene
}

/// Vertex colours multiply the base colour in the G-buffer and on the CPU,
/// and their alpha the mask: a quad whose alpha falls from 1 to 0 across it
/// is cut at the middle alike in the GPU's image and the path tracer's.
#[test]
fn vertex_colors_tint_and_mask_on_the_gpu_and_the_cpu() {
    use ssbc::cpu::reference::{Reference, ReferenceSettings};
    use std::sync::atomic::AtomicBool;
    let c = [0.2f32, 0.5, 0.9];
    let tint: [f32; 16] = std::array::from_fn(|i| if i % 4 == 3 { 1.0 } else { c[i % 4] });
    // Corners 0 and 1 opaque, 2 and 3 transparent: the cut runs across.
    let fade: [f32; 16] = std::array::from_fn(|i| match i % 4 {
        3 => (i < 8) as u32 as f32,
        k => c[k],
    });
    let settings = small(32, 32);
    let white = r#"{"pbrMetallicRoughness":{"metallicFactor":0}}"#;
    let tinted = render_validated(&colored_quad_from_above(white, &tint), &settings);
    // As in base_color_texture_is_sampled_in_the_render: (0.96 base + 0.01) / pi.
    let want = (0.96 * Vec3::from(c) + Vec3::splat(0.01)) / PI;
    for (x, y) in [(16, 16), (3, 5), (28, 27)] {
        let got = pixel(&tinted, "direct", x, y);
        assert!(
            (got - want).abs().max_element() < 0.01 * want.max_element(),
            "({x},{y}): {got} against {want}"
        );
    }
    let masked = colored_quad_from_above(
        r#"{"pbrMetallicRoughness":{"metallicFactor":0},"alphaMode":"MASK","alphaCutoff":0.5}"#,
        &fade,
    );
    let gpu = render_validated(&masked, &settings);
    let reference = Reference::new(
        &masked,
        ReferenceSettings {
            width: 32,
            height: 32,
            spp: 4,
            ..Default::default()
        },
    )
    .unwrap()
    .render(&AtomicBool::new(false), |_| {})
    .0;
    let (mut lit, mut differ) = (0, 0);
    for i in 0..32 * 32 {
        let g = Vec3::from_slice(&gpu.image.rgba[4 * i..4 * i + 3]);
        let r = Vec3::from_slice(&reference[4 * i..4 * i + 3]);
        lit += (g.max_element() > 0.5 * want.max_element()) as usize;
        differ += ((g - r).abs().max_element() > 0.02 * want.max_element()) as usize;
    }
    assert!(
        (400..=624).contains(&lit),
        "{lit} of 1024 pixels lit: the cut is not at the middle"
    );
    assert!(
        differ <= 32,
        "{differ} pixels differ between the GPU and the path tracer"
    );
}

/// KHR_mesh_quantization's integer attributes: positions as plain signed
/// shorts, normals as normalized signed bytes, uvs as normalized unsigned
/// shorts read as the float quad does.
#[test]
fn quantized_attributes_are_read() {
    let (mut bin, _) = quad_buffer(2);
    let positions: [[i16; 3]; 4] = [[-1, 0, 1], [1, 0, 1], [1, 0, -1], [-1, 0, -1]];
    let quantized: Vec<u8> = positions
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    bin[..24].copy_from_slice(&quantized);
    let normals: Vec<u8> = [[0i8, 127, 0]; 4]
        .iter()
        .flatten()
        .map(|&c| c as u8)
        .collect();
    bin[48..60].copy_from_slice(&normals);
    let uvs: Vec<u8> = [[0u16, 65535], [65535, 65535], [65535, 0], [0, 0]]
        .iter()
        .flatten()
        .flat_map(|c| c.to_le_bytes())
        .collect();
    bin[96..112].copy_from_slice(&uvs);
    let json = quad_gltf(
        Some(&data_uri(&bin)),
        bin.len(),
        5123,
        None,
        r#","extensionsUsed":["KHR_mesh_quantization"],"extensionsRequired":["KHR_mesh_quantization"]"#,
    )
    .replace(r#"{"bufferView":0,"componentType":5126"#, r#"{"bufferView":0,"componentType":5122"#)
    .replace(
        r#"{"bufferView":1,"componentType":5126"#,
        r#"{"bufferView":1,"componentType":5120,"normalized":true"#,
    )
    .replace(
        r#"{"bufferView":2,"componentType":5126"#,
        r#"{"bufferView":2,"componentType":5123,"normalized":true"#,
    );
    let dir = tempfile::tempdir().unwrap();
    let scene = load_str(dir.path(), "q.gltf", json.as_bytes()).unwrap();
    check_quad(&scene);
    let expected = [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let got = corner_uvs(&scene);
    for (k, &i) in [0usize, 1, 2, 0, 2, 3].iter().enumerate() {
        assert_eq!(got[k], glam::Vec2::from(expected[i]), "corner {k}");
    }
}

/// A file that requires an extension ssbc cannot read is refused, naming
/// it; required material extensions render approximately, as used ones do.
#[test]
fn required_extensions_ssbc_cannot_read_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let with = |required: &str| {
        quad_with_material("{}").replace(
            r#""extensionsUsed":["KHR_materials_emissive_strength"]"#,
            &format!(r#""extensionsUsed":[{required}],"extensionsRequired":[{required}]"#),
        )
    };
    let e = load_str(
        dir.path(),
        "r.gltf",
        with(r#""EXT_meshopt_compression","KHR_texture_transform""#).as_bytes(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("requires EXT_meshopt_compression,") && !e.contains("KHR_texture_transform"),
        "{e}"
    );
    load_str(
        dir.path(),
        "r.gltf",
        with(r#""KHR_materials_clearcoat""#).as_bytes(),
    )
    .unwrap();
}

/// The quad's positions as a sparse accessor: `sparse` is its JSON, over
/// bufferView 4 (u8 indices `index_bytes`, then `value_floats`), and
/// `base` says whether it starts from bufferView 0 or from zeros.
fn sparse_quad(base: bool, sparse: &str, index_bytes: &[u8], value_floats: &[f32]) -> String {
    let (mut bin, _) = quad_buffer(2);
    let offset = bin.len();
    bin.extend(index_bytes);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let values_at = bin.len() - offset;
    bin.extend(le_bytes(value_floats));
    let view = if base { r#""bufferView":0,"# } else { "" };
    quad_gltf(Some(&data_uri(&bin)), bin.len(), 5123, None, "")
        .replace(
            "],\n\"accessors\":[",
            &format!(
                ",{{\"buffer\":0,\"byteOffset\":{offset},\"byteLength\":{}}}],\n\"accessors\":[",
                bin.len() - offset
            ),
        )
        .replace(
            r#"{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","#,
            &format!(
                r#"{{{view}"componentType":5126,"count":4,"type":"VEC3","sparse":{},"#,
                sparse.replace("VALUES_AT", &values_at.to_string())
            ),
        )
}

/// Sparse accessors: substituted elements over a bufferView's or over
/// zeros (an accessor without a bufferView); bad sparse parts are clear
/// errors.
#[test]
fn sparse_accessors_substitute_their_elements() {
    let dir = tempfile::tempdir().unwrap();
    let corners = [
        -1.0f32, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, -1.0,
    ];
    let all = r#"{"count":4,"indices":{"bufferView":4,"componentType":5121},"values":{"bufferView":4,"byteOffset":VALUES_AT}}"#;
    let json = sparse_quad(false, all, &[0, 1, 2, 3], &corners);
    check_quad(&load_str(dir.path(), "s.gltf", json.as_bytes()).unwrap());
    // One corner moved over the bufferView's positions.
    let one = r#"{"count":1,"indices":{"bufferView":4,"componentType":5121},"values":{"bufferView":4,"byteOffset":VALUES_AT}}"#;
    let json = sparse_quad(true, one, &[2], &[1.0, 0.5, -1.0]);
    let scene = load_str(dir.path(), "s1.gltf", json.as_bytes()).unwrap();
    let moved: Vec<Vec3> = scene
        .world_triangles()
        .flatten()
        .map(|v| Vec3::from(v.position))
        .collect();
    let expected = expected_corners();
    assert!((moved[0] - expected[0]).length() < 1e-5, "{moved:?}");
    // Corner 2 is 1 m higher in object space: 2 m in the world (scale 2).
    assert!(
        (moved[2] - (expected[2] + Vec3::Y)).length() < 1e-5,
        "{moved:?}"
    );
    for (sparse, indices, expected) in [
        (
            one.replace(r#""count":1"#, r#""count":5"#),
            vec![0u8],
            "sparse count 5",
        ),
        (one.to_string(), vec![9u8], "sparse index 9 out of range"),
        (
            one.replace(r#","byteOffset":VALUES_AT"#, r#","byteOffset":4000"#),
            vec![0u8],
            "past the end",
        ),
    ] {
        let json = sparse_quad(true, &sparse, &indices, &[0.0; 3]);
        let e = load_str(dir.path(), "bad.gltf", json.as_bytes())
            .unwrap_err()
            .to_string();
        assert!(e.contains(expected) && !e.contains('\n'), "{sparse}: {e}");
    }
    // Zeros for an accessor the input does not bound are the budget's.
    let (bin, _) = quad_buffer(2);
    let json = quad_gltf(Some(&data_uri(&bin)), bin.len(), 5123, None, "").replace(
        r#"{"bufferView":2,"componentType":5126,"count":4"#,
        r#"{"componentType":5126,"count":40000000"#,
    );
    let e = load_str(dir.path(), "zeros.gltf", json.as_bytes())
        .unwrap_err()
        .to_string();
    assert!(e.contains("exceed the scene's budget"), "{e}");
}

fn centre(scene: &ssbc::Scene) -> Vec3 {
    let corners: Vec<Vec3> = scene
        .world_triangles()
        .flatten()
        .map(|v| Vec3::from(v.position))
        .collect();
    corners.iter().sum::<Vec3>() / corners.len() as f32
}

#[test]
fn node_animations_play_at_a_time() {
    let dir = std::env::temp_dir();
    let at = |interp: &str, t: f32| {
        let bytes = animated_quad(interp, CHANNEL);
        ssbc::scene::load_gltf_bytes_at("anim.gltf", &bytes, &dir, t).unwrap()
    };
    let rest =
        ssbc::scene::load_gltf_bytes("anim.gltf", &animated_quad("LINEAR", CHANNEL), &dir).unwrap();
    assert!(centre(&rest).abs_diff_eq(Vec3::ZERO, 1e-6), "rest pose");
    let cases = [
        ("LINEAR", 0.5, Vec3::new(1.0, 0.0, 0.0)),
        ("LINEAR", 1.5, Vec3::new(2.0, 2.0, 0.0)),
        ("LINEAR", 9.0, Vec3::new(2.0, 4.0, 0.0)),
        ("LINEAR", -1.0, Vec3::ZERO),
        ("STEP", 0.99, Vec3::ZERO),
        ("STEP", 1.0, Vec3::new(2.0, 0.0, 0.0)),
        // Zero tangents: smoothstep, 0.15625 of the way at a quarter.
        ("CUBICSPLINE", 0.25, Vec3::new(2.0 * 0.15625, 0.0, 0.0)),
    ];
    for (interp, t, expected) in cases {
        let c = centre(&at(interp, t));
        assert!(
            c.abs_diff_eq(expected, 1e-5),
            "{interp} at {t}: {c} (want {expected})"
        );
    }
}

#[test]
fn bad_animations_are_clear_errors() {
    let dir = std::env::temp_dir();
    let cases = [
        (
            r#"{"sampler":0,"target":{"node":7,"path":"translation"}}"#,
            "LINEAR",
            "node 7",
        ),
        (
            r#"{"sampler":3,"target":{"node":0,"path":"translation"}}"#,
            "LINEAR",
            "sampler 3",
        ),
        (
            r#"{"sampler":0,"target":{"node":0,"path":"rotation"}}"#,
            "LINEAR",
            "accessor 3",
        ),
        (CHANNEL, "QUADRATIC", "interpolation"),
        (
            r#"{"sampler":0,"target":{"node":0,"path":"scale"}}"#,
            "CUBICSPLINE_",
            "interpolation",
        ),
    ];
    for (channel, interp, needle) in cases {
        let bytes = animated_quad(interp, channel);
        let err = ssbc::scene::load_gltf_bytes_at("bad.gltf", &bytes, &dir, 0.5)
            .expect_err(needle)
            .to_string();
        assert!(err.contains(needle), "{needle}: {err}");
    }
    // Times that do not increase.
    let bytes = animated_quad_at("LINEAR", CHANNEL, [0.0, 2.0, 1.0]);
    let err = ssbc::scene::load_gltf_bytes_at("t.gltf", &bytes, &dir, 0.5)
        .unwrap_err()
        .to_string();
    assert!(err.contains("increasing"), "{err}");
    // A non-finite time.
    let bytes = animated_quad("LINEAR", CHANNEL);
    let err = ssbc::scene::load_gltf_bytes_at("t.gltf", &bytes, &dir, f32::INFINITY)
        .unwrap_err()
        .to_string();
    assert!(err.contains("finite"), "{err}");
    // Without a time the animation is not read (a rest pose is always there).
    assert!(ssbc::scene::load_gltf_bytes(
        "t.gltf",
        &animated_quad_at("LINEAR", CHANNEL, [0.0, 2.0, 1.0]),
        &dir
    )
    .is_ok());
}

#[test]
fn the_animation_end_comes_from_the_keyframes_declared_maximum() {
    let dir = std::env::temp_dir();
    let scene =
        ssbc::scene::load_gltf_bytes("a.gltf", &animated_quad("STEP", CHANNEL), &dir).unwrap();
    assert_eq!(scene.animation_end, Some(2.0));
    let still = load_str(
        &dir,
        "still.gltf",
        quad_gltf(None, 0, 0, None, "").as_bytes(),
    );
    assert!(still.is_err() || still.unwrap().animation_end.is_none());
}

/// A quad (4 vertices, +Y normals) as mesh 0 with one morph target (every
/// vertex +1 in y, normals +1 in x; default weight 0.5) drawn by node 0 at
/// its default weight and node 1 (moved 10 in x) at weight 1; and as mesh
/// 1, skinned (vertices 0 and 1 on joint node 3 at the origin, 2 and 3 on
/// joint node 4, bound at z = -1 and resting 3 higher, its translation
/// animated to 5 higher at 1 s), drawn by node 2 whose own translation (100
/// in x) glTF says to ignore. `edit` changes the JSON before it is parsed.
fn deformed_quads(joints: [u8; 16], edit: impl Fn(String) -> String) -> Vec<u8> {
    let mut bin = le_bytes(&[
        -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, -1.0, // positions
        0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, // normals
        0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, // target positions
        1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, // target normals
    ]);
    bin.extend(joints);
    bin.extend(le_bytes(&[1.0, 0.0, 0.0, 0.0].repeat(4)));
    let identity = glam::Mat4::IDENTITY.to_cols_array();
    let unbind = glam::Mat4::from_translation(Vec3::Z).to_cols_array();
    bin.extend(le_bytes(&identity));
    bin.extend(le_bytes(&unbind));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend(le_bytes(&[0.0, 1.0, 0.0, 3.0, -1.0, 0.0, 5.0, -1.0]));
    assert_eq!(bin.len(), 444);
    let acc = |offset: usize, ty: &str, component: u32, count: usize, extra: &str| {
        format!(
            r#"{{"bufferView":0,"byteOffset":{offset},"componentType":{component},"count":{count},"type":"{ty}"{extra}}}"#
        )
    };
    let accessors = [
        acc(0, "VEC3", 5126, 4, r#","min":[-1,0,-1],"max":[1,0,1]"#),
        acc(48, "VEC3", 5126, 4, ""),
        acc(96, "VEC3", 5126, 4, ""),
        acc(144, "VEC3", 5126, 4, ""),
        acc(192, "VEC4", 5121, 4, ""),
        acc(208, "VEC4", 5126, 4, ""),
        acc(272, "MAT4", 5126, 2, ""),
        acc(400, "SCALAR", 5123, 6, ""),
        acc(412, "SCALAR", 5126, 2, r#","min":[0],"max":[1]"#),
        acc(420, "VEC3", 5126, 2, ""),
    ]
    .join(",");
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1,2,3]}}],
        "nodes":[{{"mesh":0}},{{"mesh":0,"weights":[1.0],"translation":[10,0,0]}},
          {{"mesh":1,"skin":0,"translation":[100,0,0]}},{{"children":[4]}},{{"translation":[0,3,-1]}}],
        "skins":[{{"joints":[3,4],"inverseBindMatrices":6,"skeleton":3}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1}},"indices":7,"targets":[{{"POSITION":2,"NORMAL":3}}]}}],"weights":[0.5]}},
          {{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"JOINTS_0":4,"WEIGHTS_0":5}},"indices":7}}]}}],
        "animations":[{{"channels":[{{"sampler":0,"target":{{"node":4,"path":"translation"}}}}],
          "samplers":[{{"input":8,"output":9,"interpolation":"LINEAR"}}]}}],
        "accessors":[{accessors}],
        "bufferViews":[{{"buffer":0,"byteLength":444}}],
        "buffers":[{{"byteLength":444,"uri":"{}"}}]}}"#,
        data_uri(&bin)
    );
    edit(json).into_bytes()
}

const SKIN_JOINTS: [u8; 16] = [0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0];

/// Each drawn quad's four corners (position, normal) in the order of the
/// quad's vertices, from its two triangles (0 1 2, 0 2 3).
fn quad_corners(scene: &ssbc::Scene) -> Vec<[(Vec3, Vec3); 4]> {
    let v: Vec<(Vec3, Vec3)> = scene
        .world_triangles()
        .flatten()
        .map(|v| (Vec3::from(v.position), Vec3::from(v.normal)))
        .collect();
    v.chunks_exact(6)
        .map(|t| [t[0], t[1], t[2], t[5]])
        .collect()
}

/// Morph targets at the node's weights (else the mesh's), and skins posed
/// by their joints, at rest and at an animation time, the skinned node's
/// own transform ignored (glTF 2.0, 3.7.2.2 and 3.7.3).
#[test]
fn morph_targets_and_skins_are_posed_at_load() {
    let dir = tempfile::tempdir().unwrap();
    let rest =
        ssbc::scene::load_gltf_bytes("d.gltf", &deformed_quads(SKIN_JOINTS, |j| j), dir.path())
            .unwrap();
    let quads = quad_corners(&rest);
    assert_eq!(quads.len(), 3);
    let flat = [(-1.0, 1.0), (1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)];
    let want = |x: f32, y: [f32; 4], n: Vec3| -> [(Vec3, Vec3); 4] {
        std::array::from_fn(|k| (Vec3::new(flat[k].0 + x, y[k], flat[k].1), n.normalize()))
    };
    let cases = [
        (
            "default weight",
            want(0.0, [0.5; 4], Vec3::new(0.5, 1.0, 0.0)),
        ),
        (
            "node's weight",
            want(10.0, [1.0; 4], Vec3::new(1.0, 1.0, 0.0)),
        ),
        ("skinned at rest", want(0.0, [0.0, 0.0, 3.0, 3.0], Vec3::Y)),
    ];
    for ((what, want), got) in cases.iter().zip(&quads) {
        for k in 0..4 {
            assert!(
                got[k].0.abs_diff_eq(want[k].0, 1e-5) && got[k].1.abs_diff_eq(want[k].1, 1e-5),
                "{what}, corner {k}: {:?}, want {:?}",
                got[k],
                want[k]
            );
        }
    }
    // The animation moves joint 4 from 3 to 5 higher over a second.
    let posed = ssbc::scene::load_gltf_bytes_at(
        "d.gltf",
        &deformed_quads(SKIN_JOINTS, |j| j),
        dir.path(),
        0.5,
    )
    .unwrap();
    let skinned = quad_corners(&posed)[2];
    let heights = skinned.map(|(p, _)| p.y);
    assert!(
        (heights[0]).abs() < 1e-5
            && (heights[2] - 4.0).abs() < 1e-5
            && (heights[3] - 4.0).abs() < 1e-5,
        "skinned at 0.5 s: {heights:?}"
    );
}

/// Skins and morph targets that cannot be posed are clear errors.
#[test]
fn bad_skins_and_morph_targets_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let mut bad_joint = SKIN_JOINTS;
    bad_joint[8] = 2;
    let cases: [(&str, Vec<u8>, &str); 6] = [
        (
            "joint index past the skin's joints",
            deformed_quads(bad_joint, |j| j),
            "not one of the skin's 2 joints",
        ),
        (
            "too few inverse bind matrices",
            deformed_quads(SKIN_JOINTS, |j| {
                j.replace(r#""count":2,"type":"MAT4""#, r#""count":1,"type":"MAT4""#)
            }),
            "1 inverse bind matrices for 2 joints",
        ),
        (
            "a joint outside the scene",
            deformed_quads(SKIN_JOINTS, |j| {
                j.replace(r#""nodes":[0,1,2,3]"#, r#""nodes":[0,1,2]"#)
            }),
            "joint node 3 is not in the scene",
        ),
        (
            "a morph target shorter than its mesh",
            deformed_quads(SKIN_JOINTS, |j| {
                j.replace(
                    r#""byteOffset":96,"componentType":5126,"count":4"#,
                    r#""byteOffset":96,"componentType":5126,"count":3"#,
                )
            }),
            "morph target 0 has 3 vertices, not 4",
        ),
        // Finite, but 10^20 m made the BVH builder's costs infinite and it
        // panicked (an index out of bounds in obvhs).
        (
            "a morph weight moving the mesh 10^20 m",
            deformed_quads(SKIN_JOINTS, |j| {
                j.replace(r#""weights":[1.0]"#, r#""weights":[1e20]"#)
            }),
            "its geometry reaches 1e20 m from the origin, beyond the 1e9 m ssbc takes",
        ),
        (
            "a node 10^10 m away",
            deformed_quads(SKIN_JOINTS, |j| {
                j.replace(r#""translation":[10,0,0]"#, r#""translation":[1e10,0,0]"#)
            }),
            "object 1: its geometry reaches 1e10 m",
        ),
    ];
    for (what, bytes, message) in cases {
        let e = ssbc::scene::load_gltf_bytes("d.gltf", &bytes, dir.path())
            .expect_err(what)
            .to_string();
        assert!(e.contains(message), "{what}: {e}");
    }
}

/// A quad (+Y normals, u along +x, v along +z) with a normal map and
/// `KHR_texture_transform` `transform` on its textures, with or without
/// the TANGENT attribute (1, 0, 0, 1: right for the untransformed uvs).
fn transformed_quad(transform: &str, with_tangents: bool) -> Vec<u8> {
    transformed_normal_map_quad(transform, transform, with_tangents)
}

/// [`transformed_quad`] with the base colour texture's transform `base`
/// and the normal map's `normal`.
fn transformed_normal_map_quad(base: &str, normal: &str, with_tangents: bool) -> Vec<u8> {
    let mut bin = le_bytes(&[
        -1.0, 0.0, 1.0, 1.0, 0.0, 1.0, 1.0, 0.0, -1.0, -1.0, 0.0, -1.0, // positions
        0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, // normals
        0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, // uvs
    ]);
    bin.extend(le_bytes(&[1.0, 0.0, 0.0, 1.0].repeat(4)));
    bin.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
    bin.extend([0u8; 4]);
    let tangent = if with_tangents { r#","TANGENT":3"# } else { "" };
    let texture =
        |t: &str| format!(r#"{{"index":0,"extensions":{{"KHR_texture_transform":{t}}}}}"#);
    let (base, normal) = (texture(base), texture(normal));
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
        "extensionsUsed":["KHR_texture_transform"],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorTexture":{base}}},"normalTexture":{normal}}}],
        "textures":[{{"source":0}}],"images":[{{"uri":"{}"}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"NORMAL":1,"TEXCOORD_0":2{tangent}}},"indices":4,"material":0}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[-1,0,-1],"max":[1,0,1]}},
          {{"bufferView":0,"byteOffset":48,"componentType":5126,"count":4,"type":"VEC3"}},
          {{"bufferView":0,"byteOffset":96,"componentType":5126,"count":4,"type":"VEC2"}},
          {{"bufferView":0,"byteOffset":128,"componentType":5126,"count":4,"type":"VEC4"}},
          {{"bufferView":0,"byteOffset":192,"componentType":5123,"count":6,"type":"SCALAR"}}],
        "bufferViews":[{{"buffer":0,"byteLength":{len}}}],
        "buffers":[{{"byteLength":{len},"uri":"{}"}}]}}"#,
        png_uri(),
        data_uri(&bin),
        len = bin.len()
    )
    .into_bytes()
}

/// A TANGENT frame follows a texture transform that turns, scales or
/// mirrors the uvs: the loaded tangents (direction and handedness) equal
/// those generated from the mapped uvs. Before, the frame kept the
/// untransformed u while the normal map was read along the mapped one.
#[test]
fn tangents_follow_texture_transforms() {
    let dir = tempfile::tempdir().unwrap();
    let tangents_of = |gltf: &[u8]| -> Vec<glam::Vec4> {
        let scene = ssbc::scene::load_gltf_bytes("t.gltf", gltf, dir.path()).unwrap();
        scene
            .world_triangles()
            .flatten()
            .map(|v| glam::Vec4::from(v.tangent))
            .collect()
    };
    let tangents = |transform: &str, with: bool| tangents_of(&transformed_quad(transform, with));
    for transform in [
        r#"{"rotation":0.7}"#,
        r#"{"rotation":2.5,"scale":[2,2],"offset":[0.3,0.1]}"#,
        r#"{"scale":[-1,1]}"#,
        r#"{"rotation":1.5707963}"#,
        r#"{}"#,
    ] {
        let (given, generated) = (tangents(transform, true), tangents(transform, false));
        // The normal map's frame follows its own transform, whatever the
        // base colour's (here another one, which becomes the mesh's uvs).
        let base = r#"{"rotation":-1.1,"scale":[3,0.5],"offset":[0.2,0.7]}"#;
        let normal_only = [true, false]
            .map(|with| tangents_of(&transformed_normal_map_quad(base, transform, with)));
        for (k, (a, b)) in given.iter().zip(&generated).enumerate() {
            assert!(
                a.abs_diff_eq(*b, 1e-4),
                "{transform}, corner {k}: TANGENT gives {a}, generated {b}"
            );
            for (t, how) in normal_only.iter().zip(["TANGENT", "generated"]) {
                assert!(
                    t[k].abs_diff_eq(*a, 1e-4),
                    "{transform} on the normal map alone, corner {k}: {how} gives {}, expected {a}",
                    t[k]
                );
            }
        }
    }
}
