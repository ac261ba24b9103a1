//! A resident scene: frames redo only what the host's changes require, reuse
//! every resource, give the same images as immediate-mode frames, and a
//! frame that fails half-way leaves the renderer usable.

mod common;

use common::{max_relative_difference, stages};

use glam::{Vec3, Vec4};
use ssbc::renderer::{RenderSettings, Renderer};
use ssbc::resident::ResidentScene;
use ssbc::scene::{Camera, Scene};

/// Frames without temporal history: each resident frame must equal the
/// immediate-mode frame (history has its own tests, tests/history.rs).
fn settings() -> RenderSettings {
    let mut s = common::tiny_settings();
    s.history.enabled = false;
    s
}

fn validated() -> Renderer {
    common::validated_renderer()
}

fn cornell() -> Scene {
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    scene
}

fn moved_camera(scene: &Scene) -> Camera {
    let mut camera = scene.camera(None).unwrap();
    camera.position += Vec3::new(0.15, -0.05, -0.3);
    camera
}

#[test]
fn frames_redo_only_what_changed_and_allocate_nothing() {
    let mut renderer = validated();
    let log = renderer.validation_log();
    // Immediate-mode frames for comparison come from a second renderer (an
    // immediate frame replaces the renderer's scene cache).
    let mut immediate_renderer = validated();
    let mut resident = ResidentScene::new(cornell()).unwrap();
    let s = settings();
    // One frame per slot creates every resource.
    let first = renderer.render_resident(&resident, &s).unwrap();
    for stage in [
        "bvh_build",
        "scene_upload",
        "vpl_generation",
        "point_sampling",
    ] {
        assert!(
            stages(&first).contains(&stage),
            "{stage} missing from {:?}",
            stages(&first)
        );
    }
    assert!(first.timings.reused_passes.is_empty());
    renderer.render_resident(&resident, &s).unwrap();
    let created = renderer.device().resources_created();
    let view_independent = ["shadow_maps", "ism"];

    // Nothing changed: no CPU stage but recording and the wait.
    let same = renderer.render_resident(&resident, &s).unwrap();
    let cpu_work = [
        "bvh_build",
        "scene_upload",
        "vpl_generation",
        "point_sampling",
    ];
    for stage in cpu_work {
        assert!(
            !stages(&same).contains(&stage),
            "unchanged frame ran {stage}"
        );
    }
    assert!(max_relative_difference(&same, &first) == 0.0);
    assert_eq!(same.timings.reused_passes, view_independent);

    // A camera move: still none; the image is the immediate-mode image.
    resident.set_camera(moved_camera(resident.scene()));
    let moved = renderer.render_resident(&resident, &s).unwrap();
    for stage in cpu_work {
        assert!(!stages(&moved).contains(&stage), "camera move ran {stage}");
    }
    // Shadow maps and ISMs are kept, not redrawn, and not timed.
    assert_eq!(moved.timings.reused_passes, view_independent);
    for scope in ["shadow_maps", "ism_splat"] {
        assert!(first.timings.pass_ms(scope).is_some(), "{scope} not timed");
        assert!(moved.timings.pass_ms(scope).is_none(), "{scope} ran");
    }
    let immediate = immediate_renderer.render(resident.scene(), &s).unwrap();
    let d = max_relative_difference(&moved, &immediate);
    assert!(
        d < 1e-5,
        "camera-moved frame differs from immediate mode by {d}"
    );
    assert!(
        max_relative_difference(&moved, &first) > 1e-3,
        "the camera did not move"
    );

    // A light move: VPLs again, but no BVH, upload or points.
    let mut light = resident.scene().lights[0].clone();
    light.position += Vec3::new(0.2, -0.1, 0.1);
    resident.set_light(0, light.clone()).unwrap();
    let relit = renderer.render_resident(&resident, &s).unwrap();
    assert!(stages(&relit).contains(&"vpl_generation"));
    assert!(relit.timings.reused_passes.is_empty());
    for stage in ["bvh_build", "scene_upload", "point_sampling"] {
        assert!(!stages(&relit).contains(&stage), "light move ran {stage}");
    }
    let immediate = immediate_renderer.render(resident.scene(), &s).unwrap();
    let d = max_relative_difference(&relit, &immediate);
    assert!(d < 1e-5, "relit frame differs from immediate mode by {d}");

    // Resident frames create nothing after the first one in each slot.
    let before = renderer.device().resources_created();
    for i in 0..6 {
        let mut c = moved_camera(resident.scene());
        c.position.x += 0.01 * i as f32;
        resident.set_camera(c);
        light.position.y -= 0.01;
        resident.set_light(0, light.clone()).unwrap();
        renderer.render_resident(&resident, &s).unwrap();
    }
    assert_eq!(
        renderer.device().resources_created(),
        before,
        "frames with camera and light changes created resources"
    );
    assert_eq!(renderer.device().resources_created(), created);
    drop(renderer);
    drop(immediate_renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

#[test]
fn material_and_geometry_edits_are_picked_up() {
    let mut renderer = validated();
    let log = renderer.validation_log();
    let mut resident = ResidentScene::new(cornell()).unwrap();
    let s = settings();
    let before = renderer.render_resident(&resident, &s).unwrap();
    let mut m = resident.scene().materials[0].clone();
    m.base_color *= Vec4::new(0.5, 0.5, 0.5, 1.0);
    resident.set_material(0, m).unwrap();
    let after = renderer.render_resident(&resident, &s).unwrap();
    assert!(stages(&after).contains(&"scene_upload"));
    let immediate = renderer.render(resident.scene(), &s).unwrap();
    assert!(max_relative_difference(&after, &immediate) < 1e-5);
    assert!(max_relative_difference(&after, &before) > 1e-3);

    // A bad edit is refused with an error, and the renderer carries on.
    let mut bad = resident.scene().materials[0].clone();
    bad.base_color = Vec4::splat(f32::NAN);
    assert!(resident.set_material(0, bad).is_err());
    let light = resident.scene().lights[0].clone();
    assert!(resident.set_light(99, light).is_err());
    resident
        .edit(|scene| {
            for m in 0..scene.meshes().len() {
                for v in &mut scene.mesh_mut(m).unwrap().vertices {
                    v.position[1] += 0.5;
                }
            }
        })
        .unwrap();
    let lifted = renderer.render_resident(&resident, &s).unwrap();
    assert!(stages(&lifted).contains(&"bvh_build"));
    let immediate = renderer.render(resident.scene(), &s).unwrap();
    assert!(max_relative_difference(&lifted, &immediate) < 1e-5);
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// A frame that fails after any pass has been recorded (but before it is
/// submitted) returns the error, and the next frame is right and clean.
#[test]
fn a_failed_frame_leaves_the_renderer_usable() {
    let mut renderer = validated();
    let log = renderer.validation_log();
    let resident = ResidentScene::new(cornell()).unwrap();
    let s = settings();
    let reference = renderer.render_resident(&resident, &s).unwrap();
    for pass in ["shadow_maps", "ism", "gbuffer", "indirect_bounded", "ssbc"] {
        renderer.inject_fault_after(pass);
        let err = renderer
            .render_resident(&resident, &s)
            .expect_err("the injected fault");
        assert!(err.to_string().contains(pass), "{err}");
        // Twice, so both frame slots come round after the failure.
        for _ in 0..2 {
            let next = renderer.render_resident(&resident, &s).unwrap();
            let d = max_relative_difference(&next, &reference);
            assert!(d < 1e-6, "after a fault in {pass}: differs by {d}");
        }
        // And on the GPU path, two frames in flight.
        renderer
            .render_resident_to_gpu(&resident, &s, ssbc::Layer::Final)
            .unwrap();
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}

/// The full renderer recorded into a host's command buffer, its final image
/// copied into the host's image; the host submits with its own fence and
/// reads back what ssbc's own read-back frame gives.
#[test]
fn the_renderer_records_into_a_hosts_command_buffer() {
    let mut renderer = validated();
    let log = renderer.validation_log();
    let resident = ResidentScene::new(cornell()).unwrap();
    let s = settings();
    // The second of ssbc's own frames: the first also compiles the
    // driver's shaders, which would weigh in the per-pass comparison.
    renderer.render_resident(&resident, &s).unwrap();
    let own = renderer.render_resident(&resident, &s).unwrap();
    let device = renderer.device().clone();
    device.wait_idle().unwrap();
    let mut host = common::host_frame::HostFrames::new(&renderer, &s);
    let host_pixels = host.frame(&mut renderer, &resident, &s, 1);
    // The host's frame was timed in its own command buffer: the same
    // passes as ssbc's own frame, read without waiting now it is done.
    let times = renderer
        .host_timings(1)
        .unwrap()
        .expect("the host's frame has timings");
    let names: Vec<&str> = times.passes.iter().map(|p| p.name.as_str()).collect();
    let own_names: Vec<&str> = own
        .timings
        .passes
        .as_ref()
        .unwrap()
        .iter()
        .map(|p| p.name.as_str())
        .collect();
    for (host, own) in times
        .passes
        .iter()
        .zip(own.timings.passes.as_ref().unwrap())
    {
        eprintln!(
            "{}: host {:.2} ms, own {:.2} ms",
            host.name, host.gpu_ms, own.gpu_ms
        );
    }
    for pass in ["gbuffer", "indirect_bounded", "ssbc_step_1"] {
        assert!(names.contains(&pass), "{pass} not in {names:?}");
    }
    assert_eq!(
        names, own_names,
        "the host's frame's passes are ssbc's own frame's"
    );
    assert!(times.frame_ms > 0.0 && times.passes.iter().all(|p| p.gpu_ms >= 0.0));
    let peak = own.image.rgba.iter().fold(0f32, |m, v| m.max(v.abs()));
    let d = host_pixels
        .iter()
        .zip(&own.image.rgba)
        .fold(0f32, |m, (a, b)| m.max((a - b).abs()))
        / peak;
    assert!(
        d < 1e-6,
        "the host's image differs from ssbc's own frame by {d}"
    );
    drop(host);
    drop(renderer);
    drop(device);
    assert_eq!(log.total(), 0, "{:?}", log.messages());
}
