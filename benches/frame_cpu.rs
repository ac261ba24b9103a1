//! CPU milliseconds per frame on the host thread, for a resident scene:
//! nothing changed, the camera moved, a light moved, an object moved (a
//! tenth of the vertices by 1 mm through `ResidentScene::edit`: objects
//! are not yet separate, so this redoes the scene), and a still frame with
//! temporal history (which traces a new VPL set); on `cornell`, `tori` and
//! a generated scene of about 100k triangles (a rippled terrain of 320x160
//! quads inside a room). Also GPU resources created per frame. The other
//! columns have history off (they measure what a change costs).
//!
//! `cargo bench --bench frame_cpu` (`-- --frames N`, default 20). The CPU
//! time is the sum of the frame's CPU stages (BVH, upload, VPL tracing, ISM
//! points, slot resources, recording); waiting for the GPU is excluded.
//! Frames are 320x240 with the defaults for that size (2048 VPLs, one SSBC
//! step).

mod common;

use glam::{Mat4, Vec3};
use ssbc::renderer::{Frame, RenderSettings, Renderer, RendererConfig};
use ssbc::resident::ResidentScene;
use ssbc::scene::Scene;

fn terrain() -> Scene {
    let mut scene = ssbc::scene::builtin::cornell();
    let m = scene.add_material(Vec3::new(0.6, 0.55, 0.5), None);
    let (nx, nz) = (320usize, 160usize);
    let mut positions = Vec::new();
    for j in 0..=nz {
        for i in 0..=nx {
            let (u, v) = (i as f32 / nx as f32, j as f32 / nz as f32);
            let y = 0.05 * ((u * 31.0).sin() * (v * 17.0).cos() + 1.0);
            positions.push(Vec3::new(-0.9 + 1.8 * u, y, -0.9 + 1.8 * v));
        }
    }
    let normals = vec![Vec3::Y; positions.len()];
    let uvs = vec![[0.0, 0.0]; positions.len()];
    let mut indices = Vec::new();
    let row = nx as u32 + 1;
    for j in 0..nz as u32 {
        for i in 0..nx as u32 {
            let a = j * row + i;
            indices.extend([a, a + row, a + 1, a + 1, a + row, a + row + 1]);
        }
    }
    scene
        .add_mesh(&positions, &normals, &uvs, &indices, Mat4::IDENTITY, m)
        .expect("terrain mesh");
    scene.name = "terrain-100k".into();
    scene
}

fn cpu_ms(frame: &Frame) -> f64 {
    frame
        .timings
        .cpu_spans
        .iter()
        .filter(|s| s.name != "wait_for_gpu")
        .map(|s| s.ms())
        .sum()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() {
    let args = common::BenchArgs::parse(20);
    let frames = args.frames as usize;
    let mut renderer = Renderer::new(&RendererConfig::default()).expect("renderer");
    let mut settings = RenderSettings::new(320, 240);
    settings.history.enabled = false;
    println!(
        "# CPU ms per frame on the host thread, resident scene, median of {frames} frames ({})\n",
        renderer.device().name()
    );
    println!("| scene | triangles | first frame | nothing changed | camera moved | light moved | object moved | still, with history | immediate mode | resources created per light-moved frame |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut scenes = vec![
        ssbc::scene::load("cornell").unwrap(),
        ssbc::scene::load("tori").unwrap(),
        terrain(),
    ];
    for scene in &mut scenes {
        scene.ensure_light();
        let triangles = scene.triangle_count();
        let name = scene.name.clone();
        let mut resident = ResidentScene::new(scene.clone()).expect("valid scene");
        let first = cpu_ms(&renderer.render_resident(&resident, &settings).unwrap());
        renderer.render_resident(&resident, &settings).unwrap(); // the other slot
        let same = median(
            (0..frames)
                .map(|_| cpu_ms(&renderer.render_resident(&resident, &settings).unwrap()))
                .collect(),
        );
        let mut camera = resident.scene().camera(None).unwrap();
        let camera_moved = median(
            (0..frames)
                .map(|i| {
                    camera.position.x += 0.002 * if i % 2 == 0 { 1.0 } else { -1.0 };
                    resident.set_camera(camera.clone());
                    cpu_ms(&renderer.render_resident(&resident, &settings).unwrap())
                })
                .collect(),
        );
        let created = renderer.device().resources_created();
        let mut light = resident.scene().lights[0].clone();
        let light_moved = median(
            (0..frames)
                .map(|i| {
                    light.position.x += 0.002 * if i % 2 == 0 { 1.0 } else { -1.0 };
                    resident.set_light(0, light.clone()).unwrap();
                    cpu_ms(&renderer.render_resident(&resident, &settings).unwrap())
                })
                .collect(),
        );
        let per_frame = (renderer.device().resources_created() - created) as f64 / frames as f64;
        let count = resident.scene().vertices.len();
        let object_moved = median(
            (0..frames.min(5))
                .map(|i| {
                    let dy = 0.001 * if i % 2 == 0 { 1.0 } else { -1.0 };
                    resident
                        .edit(|s| {
                            s.vertices[..count / 10]
                                .iter_mut()
                                .for_each(|v| v.position[1] += dy)
                        })
                        .unwrap();
                    cpu_ms(&renderer.render_resident(&resident, &settings).unwrap())
                })
                .collect(),
        );
        let mut with_history = settings.clone();
        with_history.history.enabled = true;
        renderer.render_resident(&resident, &with_history).unwrap();
        let still_history = median(
            (0..frames.min(5))
                .map(|_| cpu_ms(&renderer.render_resident(&resident, &with_history).unwrap()))
                .collect(),
        );
        let immediate = median(
            (0..frames.min(5))
                .map(|_| cpu_ms(&renderer.render(resident.scene(), &settings).unwrap()))
                .collect(),
        );
        println!(
            "| {name} | {triangles} | {first:.1} | {same:.2} | {camera_moved:.2} | {light_moved:.2} | {object_moved:.1} | {still_history:.1} | {immediate:.1} | {per_frame:.1} |"
        );
    }
}
