//! CPU milliseconds per frame on the host thread, for a resident scene:
//! nothing changed, the camera moved, a light moved, an object moved, and
//! a still frame with
//! temporal history (which traces a new VPL set); on `cornell`, `tori` and
//! a generated scene of about 100k triangles (a rippled terrain of 320x160
//! quads inside a room), 79k triangles of instanced spheres, and 1M
//! triangles of terrain under spheres. Also GPU resources created per frame. The other
//! columns have history off (they measure what a change costs).
//! "object moved" moves the scene's last object by 1 mm per frame with
//! `ResidentScene::set_transform`.
//!
//! `cargo bench --bench frame_cpu` (`-- --frames N`, default 20). The CPU
//! time is the sum of the frame's CPU stages (BVH, upload, VPL tracing, ISM
//! points, slot resources, recording); waiting for the GPU is excluded.
//! Frames are 320x240 with the defaults for that size (2048 VPLs, one SSBC
//! step).

mod common;

use glam::{Mat4, Vec3};
use ssbc::renderer::{Frame, RenderSettings, Renderer};
use ssbc::resident::ResidentScene;
use ssbc::scene::Scene;

/// A rippled terrain of `nx` x `nz` quads (two triangles each) over the
/// Cornell box's floor, as one object.
fn add_terrain(scene: &mut Scene, nx: usize, nz: usize) {
    let m = scene.add_material(Vec3::new(0.6, 0.55, 0.5), None);
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
}

/// `count` spheres of 2 x 32 x 31 triangles floating in the box: one mesh,
/// `count` objects.
fn add_spheres(scene: &mut Scene, count: usize) {
    let m = scene.add_material(Vec3::new(0.5, 0.6, 0.7), None);
    let (rings, segments) = (32u32, 32u32);
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for k in 0..=segments {
            let phi = std::f32::consts::TAU * k as f32 / segments as f32;
            positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ));
        }
    }
    let mut indices = Vec::new();
    let row = segments + 1;
    for r in 0..rings {
        for k in 0..segments {
            let a = r * row + k;
            if r > 0 {
                indices.extend([a, a + 1, a + row]);
            }
            if r + 1 < rings {
                indices.extend([a + 1, a + row + 1, a + row]);
            }
        }
    }
    let mesh = scene
        .new_mesh(
            ssbc::scene::MeshData {
                positions: &positions,
                normals: &positions,
                indices: &indices,
                ..Default::default()
            },
            m,
        )
        .expect("sphere mesh");
    let side = (count as f32).sqrt().ceil() as usize;
    for i in 0..count {
        let (x, z) = ((i % side) as f32, (i / side) as f32);
        let at = Vec3::new(
            -0.8 + 1.6 * x / side as f32,
            1.2 + 0.1 * (i % 3) as f32,
            -0.8 + 1.6 * z / side as f32,
        );
        let transform = Mat4::from_translation(at) * Mat4::from_scale(Vec3::splat(0.06));
        scene
            .add_object(ssbc::scene::Object::new(mesh, transform))
            .expect("sphere object");
    }
}

/// The Cornell box with 39 instanced spheres (79k triangles, like
/// meet_mat.glb): moving one sphere is the case the target is set for.
fn spheres_79k() -> Scene {
    let mut scene = ssbc::scene::builtin::cornell();
    add_spheres(&mut scene, 40);
    scene.name = "spheres-79k".into();
    scene
}

fn terrain_100k() -> Scene {
    let mut scene = ssbc::scene::builtin::cornell();
    add_terrain(&mut scene, 320, 160);
    scene.name = "terrain-100k".into();
    scene
}

/// A 1M-triangle terrain under 16 spheres (one of them moves).
fn terrain_1m() -> Scene {
    let mut scene = ssbc::scene::builtin::cornell();
    add_terrain(&mut scene, 1000, 500);
    add_spheres(&mut scene, 16);
    scene.name = "terrain-1m".into();
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

/// (CPU, GPU) ms medians of `count` resident frames, each after `change`.
fn measure(
    renderer: &mut Renderer,
    settings: &RenderSettings,
    resident: &mut ResidentScene,
    count: usize,
    change: &mut dyn FnMut(&mut ResidentScene, usize),
) -> (f64, f64) {
    let (cpu, gpu): (Vec<f64>, Vec<f64>) = (0..count)
        .map(|i| {
            change(resident, i);
            let f = renderer.render_resident(resident, settings).unwrap();
            (cpu_ms(&f), f.timings.frame_gpu_ms.unwrap_or(f64::NAN))
        })
        .unzip();
    (median(cpu), median(gpu))
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
    let mut renderer = common::timing_renderer();
    let mut settings = RenderSettings::new(320, 240);
    settings.history.enabled = false;
    println!(
        "# CPU ms per frame on the host thread, resident scene, median of {frames} frames ({})\n",
        renderer.device().name()
    );
    println!("| scene | triangles | first frame | nothing changed | camera moved | light moved | object moved | object moved through `edit` (everything redone, as before objects) | still, with history | immediate mode | resources created per light-moved / object-moved frame |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut gpu_rows = Vec::new();
    let mut scenes = vec![
        ssbc::scene::load("cornell").unwrap(),
        ssbc::scene::load("tori").unwrap(),
        terrain_100k(),
        spheres_79k(),
        terrain_1m(),
    ];
    for scene in &mut scenes {
        scene.ensure_light();
        let triangles = scene.triangle_count();
        let name = scene.name.clone();
        let mut resident = ResidentScene::new(scene.clone()).expect("valid scene");
        let device = renderer.device().clone();
        let first = cpu_ms(&renderer.render_resident(&resident, &settings).unwrap());
        renderer.render_resident(&resident, &settings).unwrap(); // the other slot
        let mut run = |resident: &mut ResidentScene,
                       count: usize,
                       change: &mut dyn FnMut(&mut ResidentScene, usize)| {
            measure(&mut renderer, &settings, resident, count, change)
        };
        let sign = |i: usize| if i % 2 == 0 { 1.0 } else { -1.0 };
        let same = run(&mut resident, frames, &mut |_, _| {});
        let mut camera = resident.scene().camera(None).unwrap();
        let camera_moved = run(&mut resident, frames, &mut |r, i| {
            camera.position.x += 0.002 * sign(i);
            r.set_camera(camera.clone());
        });
        let created = device.resources_created();
        let mut light = resident.scene().lights[0].clone();
        let light_moved = run(&mut resident, frames, &mut |r, i| {
            light.position.x += 0.002 * sign(i);
            r.set_light(0, light.clone()).unwrap();
        });
        let per_frame = (device.resources_created() - created) as f64 / frames as f64;
        // The last object: the tall block, the second torus, the terrain
        // (every path crosses it), a sphere; by 1 mm up and down.
        let moved = resident.scene().objects().len() - 1;
        let rest = resident.scene().objects()[moved].transform;
        let lift = |i: usize| Mat4::from_translation(Vec3::new(0.0, 0.001 * sign(i), 0.0)) * rest;
        let created = device.resources_created();
        let object_moved = run(&mut resident, frames, &mut |r, i| {
            r.set_transform(moved, lift(i)).unwrap();
        });
        let per_object_frame = (device.resources_created() - created) as f64 / frames as f64;
        let edited = run(&mut resident, frames.min(5), &mut |r, i| {
            r.edit(|s| s.set_transform(moved, lift(i)))
                .unwrap()
                .unwrap();
        });
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
            "| {name} | {triangles} | {first:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {still_history:.1} | {immediate:.1} | {per_frame:.1} / {per_object_frame:.1} |",
            same.0, camera_moved.0, light_moved.0, object_moved.0, edited.0
        );
        gpu_rows.push(format!(
            "| {name} | {:.0} | {:.0} | {:.0} | {:.0} | {:.0} |",
            same.1, camera_moved.1, light_moved.1, object_moved.1, edited.1
        ));
    }
    println!("\n# GPU ms per frame (timestamps), the same frames\n");
    println!("| scene | nothing changed | camera moved | light moved | object moved | object moved through `edit` |");
    println!("|---|---|---|---|---|---|");
    for row in gpu_rows {
        println!("{row}");
    }
}
