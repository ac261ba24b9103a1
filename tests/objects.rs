//! Objects: meshes stored once and drawn by objects with transforms. Moving
//! an object redoes only what depends on it, and every frame equals the
//! frame of the same scene built static at that pose; glTF nodes that share
//! a mesh upload it once; bad transforms and indices are errors.

mod common;

use common::{max_relative_difference, stages};

use glam::{Mat4, Vec3};
use std::sync::Arc;

use ssbc::renderer::{Frame, RenderSettings, Renderer};
use ssbc::resident::ResidentScene;
use ssbc::scene::{Object, Scene};
use ssbc::vk::ValidationLog;

/// A renderer with validation and synchronization validation whose log
/// must be empty once it is dropped (leaks and late messages included).
struct Validated {
    renderer: Option<Renderer>,
    log: Arc<ValidationLog>,
}

fn validated() -> Validated {
    let renderer = common::validated_renderer();
    let log = renderer.validation_log();
    Validated {
        renderer: Some(renderer),
        log,
    }
}

impl std::ops::Deref for Validated {
    type Target = Renderer;
    fn deref(&self) -> &Renderer {
        self.renderer.as_ref().expect("dropped only at the end")
    }
}

impl std::ops::DerefMut for Validated {
    fn deref_mut(&mut self) -> &mut Renderer {
        self.renderer.as_mut().expect("dropped only at the end")
    }
}

impl Drop for Validated {
    fn drop(&mut self) {
        self.renderer = None;
        if !std::thread::panicking() {
            assert_eq!(self.log.total(), 0, "{:?}", self.log.messages());
        }
    }
}

fn settings() -> RenderSettings {
    let mut s = common::tiny_settings();
    s.history.enabled = false;
    s
}

/// Cornell's box with a 30 cm cube (the last object) to move about.
fn scene_with_cube() -> (Scene, usize) {
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let m = scene.add_material(Vec3::new(0.7, 0.5, 0.3), None);
    ssbc::scene::builtin::axis_box(&mut scene, Vec3::splat(-0.15), Vec3::splat(0.15), m).unwrap();
    let cube = scene.objects().len() - 1;
    (scene, cube)
}

#[test]
fn a_moving_object_renders_as_the_static_scene_at_each_pose() {
    let (scene, cube) = scene_with_cube();
    let s = settings();
    let mut renderer = validated();
    let mut reference = validated();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    for _ in 0..2 {
        renderer.render_resident(&resident, &s).unwrap();
    }
    let created = renderer.device().resources_created();
    // Rigid moves, and a mirror (one-sided faces and tangent frames must
    // still face out). A scaled object is checked below: its ISM points
    // keep the density they were sampled with.
    let poses = [
        Mat4::from_translation(Vec3::new(-0.5, 1.4, 0.5)),
        Mat4::from_translation(Vec3::new(-0.45, 1.3, 0.55)) * Mat4::from_rotation_y(0.4),
        Mat4::from_translation(Vec3::new(0.2, 1.0, 0.1)) * Mat4::from_rotation_x(0.7),
        Mat4::from_translation(Vec3::new(0.1, 1.2, 0.3))
            * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
    ];
    for (k, &pose) in poses.iter().enumerate() {
        resident.set_transform(cube, pose).unwrap();
        let moving = renderer.render_resident(&resident, &s).unwrap();
        let ran = stages(&moving);
        assert!(ran.contains(&"objects_moved"), "frame {k}: {ran:?}");
        for redone in ["bvh_build", "scene_upload", "point_sampling"] {
            assert!(!ran.contains(&redone), "frame {k} redid {redone}: {ran:?}");
        }
        let mut fixed = scene.clone();
        fixed.set_transform(cube, pose).unwrap();
        let still = reference.render(&fixed, &s).unwrap();
        let d = max_relative_difference(&moving, &still);
        assert!(d < 1e-5, "frame {k}: differs from the static scene by {d}");
    }
    assert_eq!(
        renderer.device().resources_created(),
        created,
        "object-moved frames create no resource"
    );
    // Scaled: the same up to the ISM points (sampled at the first pose's
    // area, not again: the static scene samples them at this one).
    let scaled = Mat4::from_translation(Vec3::new(-0.2, 0.9, 0.4))
        * Mat4::from_scale(Vec3::new(1.5, 0.5, 1.0));
    resident.set_transform(cube, scaled).unwrap();
    let moving = renderer.render_resident(&resident, &s).unwrap();
    let mut fixed = scene.clone();
    fixed.set_transform(cube, scaled).unwrap();
    let still = reference.render(&fixed, &s).unwrap();
    let sum = |f: &Frame| f.image.rgba.iter().map(|&v| v as f64).sum::<f64>();
    let ratio = sum(&moving) / sum(&still);
    // (1.0032 since ISM discs, 2026-11-29: their widths and edge clips
    // were also sampled at the first pose's mean scale.)
    assert!((ratio - 1.0).abs() < 4e-3, "scaled: mean ratio {ratio}");
    // Setting the transform it has is no change: nothing is redone.
    let last = resident.scene().objects()[cube].transform;
    resident.set_transform(cube, last).unwrap();
    let same = renderer.render_resident(&resident, &s).unwrap();
    assert!(
        !stages(&same).contains(&"vpl_generation"),
        "{:?}",
        stages(&same)
    );
    drop(renderer);
    drop(reference);
}

#[test]
fn hiding_an_object_removes_it_from_every_pass() {
    let (scene, cube) = scene_with_cube();
    let s = settings();
    let mut renderer = validated();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    resident
        .set_transform(cube, Mat4::from_translation(Vec3::new(-0.5, 1.4, 0.5)))
        .unwrap();
    let shown = renderer.render_resident(&resident, &s).unwrap();
    resident.set_visible(cube, false).unwrap();
    let hidden = renderer.render_resident(&resident, &s).unwrap();
    assert!(!stages(&hidden).contains(&"bvh_build"));
    let mut without = ssbc::scene::builtin::cornell();
    without.ensure_light();
    let empty = validated().render(&without, &s).unwrap();
    let mean = |f: &Frame| f.image.rgba.iter().map(|&v| v as f64).sum::<f64>();
    let (h, e, sh) = (mean(&hidden), mean(&empty), mean(&shown));
    // Hidden, its ISM points are skipped rather than drawn again elsewhere:
    // the image is the box without the cube up to the points' noise.
    assert!((h / e - 1.0).abs() < 0.01, "hidden {h} vs without {e}");
    assert!(
        max_relative_difference(&shown, &empty) > 0.03,
        "the cube shows: {sh} vs {e}"
    );
    resident.set_visible(cube, true).unwrap();
    let again = renderer.render_resident(&resident, &s).unwrap();
    assert!(max_relative_difference(&again, &shown) < 1e-5);
}

#[test]
fn bad_transforms_and_indices_are_errors() {
    let (scene, cube) = scene_with_cube();
    let mut resident = ResidentScene::new(scene).unwrap();
    let versions = resident.versions();
    let nan = Mat4::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
    let flat = Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0));
    let mut projective = Mat4::IDENTITY;
    projective.x_axis.w = 0.5;
    for (m, expected) in [
        (nan, "not finite"),
        (flat, "not invertible"),
        (projective, "not affine"),
    ] {
        let e = resident.set_transform(cube, m).unwrap_err().to_string();
        assert!(e.contains(expected), "{e}");
    }
    let e = resident
        .set_transform(999, Mat4::IDENTITY)
        .unwrap_err()
        .to_string();
    assert!(e.contains("object 999 does not exist"), "{e}");
    assert!(resident.set_visible(999, false).is_err());
    assert!(resident.remove_object(999).is_err());
    let e = resident
        .add_object(Object::new(77, Mat4::IDENTITY))
        .unwrap_err()
        .to_string();
    assert!(e.contains("mesh 77 does not exist"), "{e}");
    assert_eq!(resident.versions(), versions, "errors change nothing");
}

/// A quad mesh drawn by `nodes` nodes, or `nodes` copies of it drawn once each.
fn quads_gltf(nodes: usize, shared: bool) -> Vec<u8> {
    let (bin, _) = common::quad_buffer(4);
    let meshes = if shared { 1 } else { nodes };
    let mesh = r#"{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}"#;
    let node_list: Vec<String> = (0..nodes)
        .map(|i| {
            format!(
                r#"{{"mesh": {}, "translation": [{}, 0, 0]}}"#,
                if shared { 0 } else { i },
                2.5 * i as f32
            )
        })
        .collect();
    let json = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scene": 0,
        "scenes": [{{"nodes": [{}]}}],
        "nodes": [{}],
        "meshes": [{}],
        "buffers": [{{"byteLength": {}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
                        {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
                        {{"buffer": 0, "byteOffset": 128, "byteLength": 24}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                        "min": [-1, 0, -1], "max": [1, 0, 1]}},
                      {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
                      {{"bufferView": 2, "componentType": 5125, "count": 6, "type": "SCALAR"}}]}}"#,
        (0..nodes)
            .map(|i| i.to_string())
            .collect::<Vec<_>>()
            .join(","),
        node_list.join(","),
        vec![mesh; meshes].join(","),
        bin.len()
    );
    common::glb(&json, &bin)
}

#[test]
fn nodes_sharing_a_mesh_upload_it_once() {
    let dir = tempfile::tempdir().unwrap();
    let s = settings();
    let mut uploaded = Vec::new();
    for shared in [true, false] {
        let bytes = quads_gltf(16, shared);
        let mut scene = ssbc::scene::load_gltf_bytes("quads.glb", &bytes, dir.path()).unwrap();
        assert_eq!(scene.objects().len(), 16);
        assert_eq!(scene.meshes().len(), if shared { 1 } else { 16 });
        assert_eq!(scene.triangle_count(), 32);
        scene.ensure_light();
        let mut renderer = validated();
        let before = renderer.device().bytes_uploaded();
        let frame = renderer
            .render_resident(&ResidentScene::new(scene).unwrap(), &s)
            .unwrap();
        assert!(frame.image.rgba.iter().any(|&v| v > 0.0));
        uploaded.push(renderer.device().bytes_uploaded() - before);
    }
    // 15 copies of 4 vertices and 6 indices fewer, and of a mesh's range
    // (its first index and vertex, 8 bytes: `GpuScene::mesh_ranges`).
    assert_eq!(
        uploaded[1] - uploaded[0],
        15 * (4 * std::mem::size_of::<ssbc::scene::Vertex>() as u64 + 6 * 4 + 8),
        "{uploaded:?}"
    );
}

/// With temporal history, a moved object is a change like a light's: the
/// pixels it left or covers start anew (no ghost of it), the others keep
/// a few frames where the indirect light changed little.
#[test]
fn history_follows_a_moving_object_without_ghosts() {
    let (scene, cube) = scene_with_cube();
    // Enough VPLs that one frame's noise stays well below a ghost's error.
    let mut s = common::small(128, 96);
    s.vpl.count = 512;
    s.history.enabled = true;
    let mut renderer = validated();
    let mut fresh = validated();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 1.4, 0.5));
    resident.set_transform(cube, at(-0.5)).unwrap();
    for _ in 0..6 {
        renderer.render_resident(&resident, &s).unwrap();
    }
    assert_eq!(renderer.accumulated_frames(), 6);
    // Its width to the right: every pixel it covered is uncovered.
    resident.set_transform(cube, at(-0.15)).unwrap();
    let moved = renderer.render_resident(&resident, &s).unwrap();
    assert_eq!(renderer.accumulated_frames(), 1);
    let mut fixed = scene.clone();
    fixed.set_transform(cube, at(-0.15)).unwrap();
    let mut alone = s.clone();
    alone.history.enabled = false;
    let truth = fresh.render(&fixed, &alone).unwrap();
    let before = {
        let mut old = scene.clone();
        old.set_transform(cube, at(-0.5)).unwrap();
        fresh.render(&old, &alone).unwrap()
    };
    // Around where the cube was (now the wall behind it), the moved frame
    // shows the wall: no trace of the cube's old shading.
    let camera = scene.camera(None).unwrap();
    let (w, h) = (s.width as f32, s.height as f32);
    let clip = camera.projection(w / h, 0.01, 100.0)
        * camera.view()
        * Vec3::new(-0.5, 1.4, 0.5).extend(1.0);
    let (cx, cy) = (
        ((clip.x / clip.w * 0.5 + 0.5) * w) as i32,
        ((clip.y / clip.w * 0.5 + 0.5) * h) as i32,
    );
    let window = |f: &Frame| {
        let mut sum = 0.0;
        for y in cy - 2..=cy + 2 {
            for x in cx - 2..=cx + 2 {
                let i = (y as usize * s.width as usize + x as usize) * 4;
                sum += f.image.rgba[i..i + 3].iter().sum::<f32>();
            }
        }
        sum
    };
    let (m, t, b) = (window(&moved), window(&truth), window(&before));
    assert!(
        (b / t - 1.0).abs() > 0.2,
        "the cube changed the window: {b} vs {t}"
    );
    assert!(
        (m / t - 1.0).abs() < 0.1,
        "a ghost: {m} vs {t} (the cube: {b})"
    );
}

/// Adding an instance of a mesh the scene has, and removing it: no BVH
/// build, no upload of meshes; each frame is the static scene's.
#[test]
fn objects_added_and_removed_keep_the_meshes() {
    let (scene, cube) = scene_with_cube();
    let s = settings();
    let mut renderer = validated();
    let mut reference = validated();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    renderer.render_resident(&resident, &s).unwrap();
    let mesh = scene.objects()[cube].mesh;
    let second = Object::new(mesh, Mat4::from_translation(Vec3::new(0.4, 1.2, 0.3)));
    let added = resident.add_object(second.clone()).unwrap();
    let frame = renderer.render_resident(&resident, &s).unwrap();
    for redone in ["bvh_build", "scene_upload"] {
        assert!(!stages(&frame).contains(&redone), "{:?}", stages(&frame));
    }
    let mut fixed = scene.clone();
    fixed.add_object(second).unwrap();
    let still = reference.render(&fixed, &s).unwrap();
    let d = max_relative_difference(&frame, &still);
    assert!(d < 1e-5, "with the object added: {d}");
    resident.remove_object(added).unwrap();
    let frame = renderer.render_resident(&resident, &s).unwrap();
    assert!(!stages(&frame).contains(&"bvh_build"));
    let still = reference.render(&scene, &s).unwrap();
    let d = max_relative_difference(&frame, &still);
    assert!(d < 1e-5, "with the object removed again: {d}");
    // The last visible objects cannot all go.
    let mut lone = ResidentScene::new({
        let mut s = Scene::new("lone");
        let m = s.add_material(Vec3::ONE, None);
        ssbc::scene::builtin::axis_box(&mut s, Vec3::ZERO, Vec3::ONE, m).unwrap();
        s
    })
    .unwrap();
    assert!(lone.remove_object(0).is_err());
}

/// A scene keeps its glTF animation: posing it at a time moves its
/// objects where loading the file at that time puts them.
#[test]
fn a_scene_poses_its_objects_as_loading_at_that_time_does() {
    let dir = tempfile::tempdir().unwrap();
    for interpolation in ["STEP", "LINEAR", "CUBICSPLINE"] {
        let bytes = common::animated_quad(interpolation, common::CHANNEL);
        let rest = ssbc::scene::load_gltf_bytes("a.gltf", &bytes, dir.path()).unwrap();
        for t in [0.0, 0.4, 1.0, 1.7, 5.0] {
            let at = ssbc::scene::load_gltf_bytes_at("a.gltf", &bytes, dir.path(), t).unwrap();
            let pose = rest.pose(t);
            assert_eq!(pose.len(), 1, "{interpolation}");
            assert_eq!(
                pose[0],
                (0, Some(at.objects()[0].transform)),
                "{interpolation} at {t}"
            );
        }
    }
    assert!(ssbc::scene::builtin::cornell().pose(1.0).is_empty());
}
