//! Temporal history of resident frames: a still view's frames average into
//! exactly the mean of the same frames taken one by one; a moved camera
//! reprojects history and never carries it onto surfaces the previous
//! frame did not see; changed lights drop history where the indirect light
//! changed; the host can cut it; frames recorded into the host's command
//! buffer keep it too; no resources are made per frame.

mod common;

use std::sync::atomic::AtomicBool;

use glam::Vec3;
use ssbc::resident::ResidentScene;
use ssbc::scene::{Camera, Scene};
use ssbc::{Frame, RenderSettings};

/// ISM visibility throughout: these tests check history's bookkeeping,
/// which `Visibility::Auto` would mix with exact visibility on still
/// frames (where the device has ray queries).
fn settings() -> RenderSettings {
    let mut s = common::small(64, 48);
    s.vpl.count = 64;
    s.visibility = ssbc::settings::Visibility::Ism;
    s
}

fn without_history(s: &RenderSettings) -> RenderSettings {
    let mut s = s.clone();
    s.history.enabled = false;
    s
}

/// Renders `n` still frames of `resident`; returns the settings of a frame
/// standing alone with the last one's light paths (each still frame traces
/// the paths after its predecessors'; a camera or light change keeps the
/// last frame's).
fn still_frames(
    renderer: &mut ssbc::Renderer,
    resident: &ResidentScene,
    s: &RenderSettings,
    n: usize,
) -> RenderSettings {
    let mut alone = without_history(s);
    for k in 0..n {
        let frame = renderer.render_resident(resident, s).unwrap();
        if k + 1 < n {
            alone.vpl.first_path += frame.timings.light_paths;
        }
    }
    alone
}

fn open_box() -> Scene {
    ssbc::scene::load("assets/open-front-box.gltf").unwrap()
}

/// Largest difference between two frames' final images relative to the
/// brightest pixel of `b`.
fn max_difference(a: &Frame, b: &Frame) -> f32 {
    let peak = b.image.rgba.iter().fold(0.0f32, |m, v| m.max(*v));
    let d = a
        .image
        .rgba
        .iter()
        .zip(&b.image.rgba)
        .fold(0.0f32, |m, (x, y)| m.max((x - y).abs()));
    d / peak
}

/// Mean absolute difference of the geometry pixels' indirect light (final
/// minus direct), relative to `truth`'s mean indirect light.
fn indirect_error(frame: &Frame, truth: &Frame) -> f64 {
    let indirect = |f: &Frame| -> Vec<f32> {
        let direct = f.layer(ssbc::Layer::Direct).expect("read back");
        f.image
            .rgba
            .iter()
            .zip(&direct.rgba)
            .map(|(a, d)| a - d)
            .collect()
    };
    let (a, t) = (indirect(frame), indirect(truth));
    let (mut err, mut sum) = (0.0f64, 0.0f64);
    for (i, (x, y)) in a.iter().zip(&t).enumerate() {
        if i % 4 != 3 {
            err += (x - y).abs() as f64;
            sum += y.abs() as f64;
        }
    }
    err / sum
}

#[test]
fn a_still_view_averages_its_frames_exactly() {
    let scene = open_box();
    let s = settings();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let resident = ResidentScene::new(scene.clone()).unwrap();
    let mut last = None;
    let mut created = 0;
    for k in 1..=8u32 {
        let frame = renderer.render_resident(&resident, &s).unwrap();
        assert_eq!(frame.accumulated, k);
        assert_eq!(renderer.accumulated_frames(), k);
        if k == 2 {
            created = renderer.device().resources_created();
        }
        last = Some(frame);
    }
    let last = last.unwrap();
    assert_eq!(
        renderer.device().resources_created(),
        created,
        "still frames created resources"
    );
    let (w, h) = (s.width as u64, s.height as u64);
    // Output and history per slot (the reprojection lives in the slot's
    // transient memory, with SSBC's pyramids).
    assert_eq!(renderer.history_memory(), 2 * 32 * w * h);
    // The same eight frames (the same light paths), averaged on the host.
    let stop = AtomicBool::new(false);
    let mean = renderer
        .render_accumulated(&scene, &s, 8, &stop, |_| {})
        .unwrap();
    let d = max_difference(&last, &mean);
    eprintln!("8 still frames vs their mean on the host: {d:.2e} of the peak");
    assert!(d < 1e-4, "differs by {d}");
    // They converge: 8 frames are closer to 32 frames' mean than 1 is.
    let truth = renderer
        .render_accumulated(&scene, &s, 32, &stop, |_| {})
        .unwrap();
    let one = renderer.render(&scene, &s).unwrap();
    // Immediate frames keep no history, nor its memory.
    assert_eq!(renderer.history_memory(), 0);
    let (e1, e8) = (max_difference(&one, &truth), max_difference(&last, &truth));
    eprintln!("largest difference from 32 frames: 1 frame {e1:.4}, 8 frames {e8:.4}");
    assert!(e8 < 0.6 * e1);
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

fn camera(scene: &Scene) -> Camera {
    scene.camera(None).unwrap()
}

#[test]
fn a_moving_camera_keeps_history_where_it_saw_the_surface() {
    let scene = open_box();
    let mut s = settings();
    s.debug_readback = true;
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    for _ in 0..16 {
        renderer.render_resident(&resident, &s).unwrap();
    }
    let created = renderer.device().resources_created();
    // Pan a little: history is reprojected.
    let start = camera(&scene);
    let mut moved = start;
    moved.position += 0.02 * scene_size(&scene) * Vec3::X;
    resident.set_camera(moved.clone());
    let panned = renderer.render_resident(&resident, &s).unwrap();
    assert_eq!(panned.accumulated, 1);
    assert_eq!(renderer.device().resources_created(), created);
    // The truth: many frames at the moved camera, standing alone.
    let mut at_moved = scene.clone();
    at_moved.cameras = vec![moved.clone()];
    let stop = AtomicBool::new(false);
    let truth = renderer
        .render_accumulated(&at_moved, &s, 32, &stop, |_| {})
        .unwrap();
    let fresh = renderer.render(&at_moved, &without_history(&s)).unwrap();
    let (e_fresh, e_panned) = (
        indirect_error(&fresh, &truth),
        indirect_error(&panned, &truth),
    );
    eprintln!(
        "indirect light after a pan, mean |error| / mean: a fresh frame {e_fresh:.4}, with \
         history {e_panned:.4}"
    );
    assert!(e_panned < 0.8 * e_fresh, "{e_panned} vs {e_fresh}");
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// In a closed room, turning round sees only what was behind the camera:
/// no pixel takes history (the frame is the frame alone), and none of the
/// previous view's light is smeared onto the new surfaces.
#[test]
fn turning_round_carries_nothing_over() {
    let mut scene = ssbc::scene::load("tests/scenes/closed-room.gltf").unwrap();
    scene.ensure_light();
    let s = settings();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    let same_paths = still_frames(&mut renderer, &resident, &s, 4);
    let mut turned = camera(&scene);
    turned.forward = -turned.forward;
    resident.set_camera(turned.clone());
    let back = renderer.render_resident(&resident, &s).unwrap();
    let mut at_turned = scene.clone();
    at_turned.cameras = vec![turned];
    let alone = renderer.render(&at_turned, &same_paths).unwrap();
    let covered = alone.image.rgba.chunks(4).filter(|p| p[3] > 0.0).count();
    assert!(
        covered == alone.image.rgba.len() / 4,
        "the room surrounds the camera"
    );
    let d = max_difference(&back, &alone);
    assert!(d < 1e-5, "turned round: history carried over ({d})");
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

fn scene_size(scene: &Scene) -> f32 {
    let (lo, hi) = scene.world_triangles().flatten().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), v| {
            let p = Vec3::from(v.position);
            (lo.min(p), hi.max(p))
        },
    );
    (hi - lo).length()
}

#[test]
fn changed_lights_drop_history_where_the_light_changed() {
    let scene = open_box();
    let mut s = settings();
    s.debug_readback = true;
    let mut renderer = common::validated_renderer();
    // Frames standing alone come from a second renderer (an immediate-mode
    // frame would cut the first one's history).
    let mut other = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    // A light-changed frame traces the same light paths as the last frame.
    let alone = still_frames(&mut renderer, &resident, &s, 8);
    let mut alone_frame = |scene: &Scene| other.render(scene, &alone).unwrap();

    // Every light off: no indirect light at once, and no dark history after.
    let mut dark = scene.lights.clone();
    dark.iter_mut().for_each(|l| l.intensity = Vec3::ZERO);
    resident.set_lights(dark).unwrap();
    let off = renderer.render_resident(&resident, &s).unwrap();
    assert!(max_difference(&off, &alone_frame(resident.scene())) < 1e-5);
    resident.set_lights(scene.lights.clone()).unwrap();
    let back = renderer.render_resident(&resident, &s).unwrap();
    let d = max_difference(&back, &alone_frame(&scene));
    assert!(d < 1e-5, "lights back on: {d}");

    // A light jumps by half the box: history is dropped where the light
    // changed, so the frame is as good as one standing alone.
    let mut jumped = scene.lights.clone();
    jumped[0].position += 0.5 * scene_size(&scene) * Vec3::new(0.4, -0.8, 0.2).normalize();
    resident.set_lights(jumped.clone()).unwrap();
    let after_jump = renderer.render_resident(&resident, &s).unwrap();
    let mut at_jump = scene.clone();
    at_jump.lights = jumped;
    let stop = AtomicBool::new(false);
    let truth = other
        .render_accumulated(&at_jump, &s, 32, &stop, |_| {})
        .unwrap();
    let standalone = other.render(&at_jump, &alone).unwrap();
    let (e_jump, e_alone) = (
        indirect_error(&after_jump, &truth),
        indirect_error(&standalone, &truth),
    );
    eprintln!("after a jump: mean |error| of the indirect light {e_jump:.4}, alone {e_alone:.4}");
    assert!(e_jump < 1.1 * e_alone, "{e_jump} vs {e_alone}");
    drop((renderer, other));
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

#[test]
fn the_host_cuts_history() {
    let scene = open_box();
    let s = settings();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    for _ in 0..4 {
        renderer.render_resident(&resident, &s).unwrap();
    }
    assert_eq!(renderer.accumulated_frames(), 4);
    resident.reset_history();
    let cut = renderer.render_resident(&resident, &s).unwrap();
    assert_eq!(cut.accumulated, 1);
    // A cut starts the light paths anew too.
    let alone = renderer.render(&scene, &without_history(&s)).unwrap();
    assert!(max_difference(&cut, &alone) < 1e-5);
    // Immediate-mode frames stand alone and cut it too.
    assert_eq!(renderer.accumulated_frames(), 0);
    let next = renderer.render_resident(&resident, &s).unwrap();
    assert_eq!(next.accumulated, 1);
    // On the GPU path too.
    for k in 2..=3 {
        renderer
            .render_resident_to_gpu(&resident, &s, ssbc::Layer::Final)
            .unwrap();
        assert_eq!(renderer.accumulated_frames(), k);
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// Frames a host records into its own command buffer
/// (`Renderer::record_resident`) keep history as ssbc's own frames do
/// while the host alternates the frame slots: the same images, the same
/// count; a host that records every frame into one slot starts anew.
#[test]
fn frames_in_a_hosts_command_buffer_keep_history() {
    let s = settings();
    let mut own = common::validated_renderer();
    let mut renderer = common::validated_renderer();
    let logs = [own.validation_log(), renderer.validation_log()];
    let mut resident = ResidentScene::new(open_box()).unwrap();
    let mut host = common::host_frame::HostFrames::new(&renderer, &s);
    let mut camera = resident.scene().camera(None).unwrap();
    for k in 1..=5u32 {
        if k == 4 {
            // A small camera move: reprojected, one frame again.
            camera.position += Vec3::new(0.02, 0.0, 0.0);
            resident.set_camera(camera.clone());
        }
        let mine = own.render_resident(&resident, &s).unwrap();
        let theirs = host.frame(&mut renderer, &resident, &s, k as usize % 2);
        assert_eq!(renderer.accumulated_frames(), own.accumulated_frames());
        assert_eq!(mine.accumulated, [1, 2, 3, 1, 2][k as usize - 1]);
        let peak = mine.image.rgba.iter().fold(0f32, |m, v| m.max(v.abs()));
        let d = theirs
            .iter()
            .zip(&mine.image.rgba)
            .fold(0f32, |m, (a, b)| m.max((a - b).abs()))
            / peak;
        assert!(d < 1e-5, "frame {k}: the host's image differs by {d}");
    }
    resident.reset_history();
    host.frame(&mut renderer, &resident, &s, 0);
    assert_eq!(renderer.accumulated_frames(), 1, "reset");
    host.frame(&mut renderer, &resident, &s, 1);
    assert_eq!(renderer.accumulated_frames(), 2);
    // One slot: a frame cannot read the history it overwrites.
    host.frame(&mut renderer, &resident, &s, 1);
    assert_eq!(renderer.accumulated_frames(), 1, "the same slot again");
    drop(host);
    drop((own, renderer));
    for log in logs {
        assert_eq!(log.total(), 0, "{:?}", log.messages());
    }
}

/// A glossy surface's light depends on the view: orbiting the camera by
/// more than its lobe's width drops its history (smooth metal pixels are
/// the frame alone), while the diffuse walls keep theirs.
#[test]
fn glossy_history_follows_the_view() {
    let mut scene = ssbc::scene::load("spheres").unwrap();
    scene.ensure_light();
    let mut s = settings();
    s.debug_readback = true;
    let mut renderer = common::validated_renderer();
    let mut other = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    let alone = still_frames(&mut renderer, &resident, &s, 4);
    // Orbit 10 degrees about a point 3 m ahead.
    let start = camera(&scene);
    let pivot = start.position + 3.0 * start.forward;
    let turn = glam::Quat::from_rotation_y(10f32.to_radians());
    let mut orbited = start.clone();
    orbited.position = pivot + turn * (start.position - pivot);
    orbited.forward = (turn * start.forward).normalize();
    orbited.up = (turn * start.up).normalize();
    resident.set_camera(orbited.clone());
    let moved = renderer.render_resident(&resident, &s).unwrap();
    let mut posed = scene.clone();
    posed.cameras = vec![orbited];
    let fresh = other.render(&posed, &alone).unwrap();
    let albedo = &fresh.layer(ssbc::Layer::GBufferAlbedo).unwrap().rgba;
    let normal = &fresh.layer(ssbc::Layer::GBufferNormal).unwrap().rgba;
    let (mut smooth_metal, mut diffuse_kept) = (0, 0);
    let peak = fresh.image.rgba.iter().fold(0.0f32, |m, v| m.max(*v));
    for i in 0..albedo.len() / 4 {
        let (metallic, roughness) = (albedo[i * 4 + 3], normal[i * 4 + 3]);
        let d = (0..3)
            .map(|c| (moved.image.rgba[i * 4 + c] - fresh.image.rgba[i * 4 + c]).abs())
            .fold(0.0f32, f32::max);
        if metallic > 0.5 && (0.0..0.35).contains(&roughness) {
            smooth_metal += 1;
            assert!(d < 1e-5 * peak, "smooth metal pixel {i} kept history ({d})");
        } else if roughness < 0.0 && d > 1e-4 * peak {
            diffuse_kept += 1;
        }
    }
    eprintln!(
        "{smooth_metal} smooth metal pixels alone, {diffuse_kept} diffuse pixels kept history"
    );
    assert!(smooth_metal > 20 && diffuse_kept > 200);
    drop((renderer, other));
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// Engines set the camera and lights every frame: setting the same ones
/// again, or only a new sub-pixel jitter, is no change, and the view keeps
/// converging.
#[test]
fn setting_the_same_camera_and_lights_keeps_accumulating() {
    let mut scene = open_box();
    scene.ensure_light();
    let s = settings();
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene.clone()).unwrap();
    let camera = camera(&scene);
    for k in 1..=3 {
        resident.set_camera(camera.clone());
        resident.set_lights(scene.lights.clone()).unwrap();
        let frame = renderer.render_resident(&resident, &s).unwrap();
        assert_eq!(frame.accumulated, k);
    }
    // A TAA engine's jitter changes every frame: still no move (the
    // reprojection places the sub-pixel shift).
    renderer.render_resident(&resident, &s).unwrap();
    for (k, jitter) in [(5, (0.25, -0.25)), (6, (-0.25, 0.25)), (7, (0.4, 0.1))] {
        let mut jittered = camera.clone();
        jittered.jitter = glam::Vec2::new(jitter.0, jitter.1);
        resident.set_camera(jittered);
        let frame = renderer.render_resident(&resident, &s).unwrap();
        assert_eq!(frame.accumulated, k);
        assert!(frame.image.rgba.iter().all(|v| v.is_finite()));
    }
    let mut moved = camera.clone();
    moved.position.x += 0.01;
    resident.set_camera(moved);
    assert_eq!(
        renderer.render_resident(&resident, &s).unwrap().accumulated,
        1
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// With `Visibility::Auto` (the default) a still view's frames after the
/// first test VPL visibility exactly where the device has ray queries (an
/// accumulated still view then converges to the truth, not to the ISMs'
/// bias): they draw no ISMs; a moved camera's frame draws them again.
#[test]
fn a_still_view_turns_to_exact_visibility() {
    let scene = open_box();
    let mut s = settings();
    s.visibility = ssbc::settings::Visibility::Auto;
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    let mut resident = ResidentScene::new(scene).unwrap();
    let splats = |f: &Frame| {
        f.timings
            .timed_passes()
            .iter()
            .any(|p| p.name == "ism_splat")
    };
    let frames: Vec<_> = (0..4)
        .map(|_| renderer.render_resident(&resident, &s).unwrap())
        .collect();
    let drew: Vec<bool> = frames.iter().map(splats).collect();
    assert_eq!(drew, [true, false, false, false], "ISMs drawn per frame");
    let used: Vec<_> = frames.iter().map(|f| f.timings.visibility).collect();
    use ssbc::settings::Visibility::{Exact, Ism};
    assert_eq!(used, [Ism, Exact, Exact, Exact], "visibility per frame");
    let mut camera = resident.scene().camera(None).unwrap();
    camera.position += glam::Vec3::new(0.01, 0.0, 0.0);
    resident.set_camera(camera);
    let moved = renderer.render_resident(&resident, &s).unwrap();
    assert!(splats(&moved), "a moved camera's frame drew no ISMs");
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// Where exact visibility is not possible (no ray queries, or, as here, an
/// alpha-masked material), with `history.converging_isms` (the viewer's) a
/// still view's frames after the first take the ISMs an accumulation takes
/// there, finer and with back-face maps, and a moved camera's frame the
/// host's ISMs again: the viewer's still view converges where
/// `render_accumulated` does. Without it (the library's default) they keep
/// the host's ISMs, and the memory it budgeted.
#[test]
fn a_still_view_without_exact_visibility_takes_finer_back_face_maps() {
    let mut scene = open_box();
    scene.materials[0].alpha = ssbc::scene::AlphaMode::Mask(0.5);
    let mut s = settings();
    s.visibility = ssbc::settings::Visibility::Auto;
    s.history.converging_isms = true;
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(scene).unwrap();
    let back_faces = |f: &Frame| {
        assert_eq!(f.timings.visibility, ssbc::settings::Visibility::Ism);
        let finer = f.timings.ism_tile == ssbc::settings::CONVERGING_ISM_TILE
            && f.timings.points_per_vpl == ssbc::settings::CONVERGING_POINTS_PER_VPL;
        assert_eq!(
            finer, f.timings.ism_back_faces,
            "finer ISMs go with back faces"
        );
        f.timings.ism_back_faces
    };
    // Each point set is sampled once: the viewer alternates them as the
    // view stops and moves.
    let sampled = |f: &Frame| {
        f.timings
            .cpu_spans
            .iter()
            .any(|span| span.name == "point_sampling")
    };
    let frames: Vec<Frame> = (0..4)
        .map(|_| renderer.render_resident(&resident, &s).unwrap())
        .collect();
    let used: Vec<bool> = frames.iter().map(back_faces).collect();
    assert_eq!(used, [false, true, true, true], "back-face maps per frame");
    let sampling: Vec<bool> = frames.iter().map(sampled).collect();
    assert_eq!(
        sampling,
        [true, true, false, false],
        "points sampled per frame"
    );
    let mut camera = resident.scene().camera(None).unwrap();
    camera.position += glam::Vec3::new(0.01, 0.0, 0.0);
    resident.set_camera(camera);
    let moved = renderer.render_resident(&resident, &s).unwrap();
    assert!(
        !back_faces(&moved),
        "a moved camera's frame kept back-face maps"
    );
    let stopped = renderer.render_resident(&resident, &s).unwrap();
    assert!(back_faces(&stopped), "the stopped view's frame");
    assert!(
        !sampled(&moved) && !sampled(&stopped),
        "points sampled again after the view moved or stopped"
    );
    // The estimate a host budgets with counts the still view's ISMs.
    let slot = ssbc::renderer::SlotUse::Resident;
    let budget = |s: &RenderSettings| ssbc::renderer::frame_memory_of(resident.scene(), s, slot);
    let converging = budget(&s).total();
    // Off: the host's ISMs throughout.
    s.history.converging_isms = false;
    assert!(converging > budget(&s).total());
    let resident = ResidentScene::new(resident.scene().clone()).unwrap();
    let used: Vec<bool> = (0..3)
        .map(|_| back_faces(&renderer.render_resident(&resident, &s).unwrap()))
        .collect();
    assert_eq!(used, [false, false, false], "without converging ISMs");
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}
