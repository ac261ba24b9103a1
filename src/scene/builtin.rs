//! Built-in scenes, generated in code so no files are needed:
//! `cornell` (the default), `tori` (as in the slides) and `spheres` (glossy
//! and metallic spheres in the Cornell box).

use std::f32::consts::PI;

use glam::{Mat4, Quat, Vec3};

use super::{Camera, Light, LightKind, Scene};

/// Names of the built-in scenes.
pub const NAMES: [&str; 3] = ["cornell", "tori", "spheres"];

/// The built-in scene called `name`, if any.
pub fn by_name(name: &str) -> Option<Scene> {
    match name {
        "cornell" => Some(cornell()),
        "tori" => Some(tori()),
        "spheres" => Some(spheres()),
        _ => None,
    }
}

/// An axis-aligned quad (two triangles) from a corner and two edges.
fn quad(scene: &mut Scene, corner: Vec3, u: Vec3, v: Vec3, material: u32) {
    let n = u.cross(v).normalize();
    let p = [corner, corner + u, corner + u + v, corner + v];
    scene
        .add_mesh(
            &p,
            &[n; 4],
            &[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
            &[0, 1, 2, 0, 2, 3],
            Mat4::IDENTITY,
            material,
        )
        .expect("built-in quad is valid");
}

/// A closed box of the given size, centred on the floor at `base`, turned
/// by `angle` around Y; outward normals.
fn block(scene: &mut Scene, base: Vec3, size: Vec3, angle: f32, material: u32) {
    let t = Mat4::from_rotation_translation(Quat::from_rotation_y(angle), base);
    let h = size * 0.5;
    let c = |x: f32, y: f32, z: f32| Vec3::new(x * h.x, y * size.y, z * h.z);
    // Each face: corner, edge u, edge v with u x v pointing outward.
    let faces = [
        (c(-1.0, 0.0, 1.0), Vec3::X * size.x, Vec3::Y * size.y), // +z
        (c(1.0, 0.0, -1.0), -Vec3::X * size.x, Vec3::Y * size.y), // -z
        (c(1.0, 0.0, 1.0), -Vec3::Z * size.z, Vec3::Y * size.y), // +x
        (c(-1.0, 0.0, -1.0), Vec3::Z * size.z, Vec3::Y * size.y), // -x
        (c(-1.0, 1.0, 1.0), Vec3::X * size.x, -Vec3::Z * size.z), // +y
        (c(-1.0, 0.0, -1.0), Vec3::X * size.x, Vec3::Z * size.z), // -y
    ];
    // One object: a mesh of six faces, four vertices each.
    let (mut positions, mut normals, mut indices) = (Vec::new(), Vec::new(), Vec::new());
    for (corner, u, v) in faces {
        let base = positions.len() as u32;
        positions.extend([corner, corner + u, corner + u + v, corner + v]);
        normals.extend([u.cross(v).normalize(); 4]);
        indices.extend([0, 1, 2, 0, 2, 3].map(|i| base + i));
    }
    scene
        .add_mesh(&positions, &normals, &[], &indices, t, material)
        .expect("built-in block is valid");
}

/// The Cornell box: 2 m cube open towards the camera (+Z), red left wall,
/// green right wall, two white blocks, and a 10 W/sr point light 10 cm under
/// the ceiling.
pub fn cornell() -> Scene {
    let mut s = Scene::new("cornell");
    let (white, red, green) = cornell_wall_materials(&mut s);
    cornell_room(&mut s, [white, white, red, green], Vec3::new(0.0, 1.9, 0.0));
    block(
        &mut s,
        Vec3::new(0.33, 0.0, 0.37),
        Vec3::new(0.6, 0.6, 0.6),
        -0.29,
        white,
    );
    block(
        &mut s,
        Vec3::new(-0.35, 0.0, -0.3),
        Vec3::new(0.6, 1.2, 0.6),
        0.29,
        white,
    );
    s
}

/// The Cornell box's Lambertian white, red and green.
fn cornell_wall_materials(s: &mut Scene) -> (u32, u32, u32) {
    (
        s.add_material(Vec3::new(0.73, 0.73, 0.73), None),
        s.add_material(Vec3::new(0.63, 0.065, 0.05), None),
        s.add_material(Vec3::new(0.14, 0.45, 0.091), None),
    )
}

/// The Cornell box's inward-facing walls (floor, ceiling, back, left,
/// right, made of `[floor, white, red, green]`), its camera and a 10 W/sr
/// point light at `light`.
fn cornell_room(s: &mut Scene, [floor, white, red, green]: [u32; 4], light: Vec3) {
    let walls = [
        (
            Vec3::new(-1.0, 0.0, 1.0),
            Vec3::X * 2.0,
            -Vec3::Z * 2.0,
            floor,
        ),
        (
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::X * 2.0,
            Vec3::Z * 2.0,
            white,
        ),
        (
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::X * 2.0,
            Vec3::Y * 2.0,
            white,
        ),
        (
            Vec3::new(-1.0, 0.0, 1.0),
            -Vec3::Z * 2.0,
            Vec3::Y * 2.0,
            red,
        ),
        (
            Vec3::new(1.0, 0.0, -1.0),
            Vec3::Z * 2.0,
            Vec3::Y * 2.0,
            green,
        ),
    ];
    for (corner, u, v, m) in walls {
        quad(s, corner, u, v, m);
    }
    s.lights.push(Light {
        kind: LightKind::Point,
        position: light,
        direction: -Vec3::Y,
        intensity: Vec3::splat(10.0),
    });
    s.cameras.push(Camera::look_at(
        Vec3::new(0.0, 1.0, 3.9),
        Vec3::new(0.0, 1.0, 0.0),
        40f32.to_radians(),
    ));
}

/// A sphere of `radius` at `centre` (smooth normals, UVs by longitude and
/// latitude).
fn sphere(scene: &mut Scene, centre: Vec3, radius: f32, material: u32) {
    let (nu, nv) = (40u32, 20u32);
    let (mut positions, mut normals, mut uvs) = (Vec::new(), Vec::new(), Vec::new());
    for j in 0..=nv {
        let theta = j as f32 / nv as f32 * PI;
        for i in 0..=nu {
            let phi = i as f32 / nu as f32 * 2.0 * PI;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            );
            positions.push(n * radius);
            normals.push(n);
            uvs.push([i as f32 / nu as f32, j as f32 / nv as f32]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..nv {
        for i in 0..nu {
            let a = j * (nu + 1) + i;
            let (b, c, d) = (a + 1, a + nu + 2, a + nu + 1);
            indices.extend([a, b, c, a, c, d]);
        }
    }
    scene
        .add_mesh(
            &positions,
            &normals,
            &uvs,
            &indices,
            Mat4::from_translation(centre),
            material,
        )
        .expect("built-in sphere is valid");
}

/// Nine spheres in the Cornell box, a grid facing the camera of glTF
/// metallic-roughness materials (as Khronos's MetalRoughSpheres): metals at
/// the top (gold), half-metals in the middle (silver), dielectrics at the
/// bottom (red, blue, white), roughness 0.2, 0.45 and 0.7 from left to
/// right, above a glossy floor (white dielectric, roughness 0.5); walls
/// Lambertian; the point light 10 cm under the ceiling, 0.9 m in front of
/// the grid.
pub fn spheres() -> Scene {
    let mut s = Scene::new("spheres");
    let floor = s.materials.len() as u32;
    s.materials.push(super::Material::metallic_roughness(
        Vec3::splat(0.7),
        0.0,
        0.5,
    ));
    // The light 10 cm under the ceiling, in front of the spheres.
    let (white, red, green) = cornell_wall_materials(&mut s);
    cornell_room(&mut s, [floor, white, red, green], Vec3::new(0.0, 1.9, 0.7));
    let rows = [
        (1.35, 1.0, [Vec3::new(1.0, 0.78, 0.34); 3]),
        (0.85, 0.5, [Vec3::new(0.9, 0.9, 0.9); 3]),
        (
            0.35,
            0.0,
            [
                Vec3::new(0.8, 0.1, 0.08),
                Vec3::new(0.1, 0.2, 0.8),
                Vec3::new(0.85, 0.85, 0.85),
            ],
        ),
    ];
    let radius = 0.2;
    for (y, metallic, colors) in rows {
        for (k, (roughness, color)) in [0.2, 0.45, 0.7].into_iter().zip(colors).enumerate() {
            let m = s.materials.len() as u32;
            s.materials.push(super::Material::metallic_roughness(
                color, metallic, roughness,
            ));
            let x = (k as f32 - 1.0) * 0.55;
            sphere(&mut s, Vec3::new(x, y, -0.2), radius, m);
        }
    }
    s
}

/// A torus around the Y axis with `major` and `minor` radii.
fn torus(scene: &mut Scene, major: f32, minor: f32, transform: Mat4, material: u32) {
    let (nu, nv) = (48u32, 24u32);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    for i in 0..nu {
        let u = i as f32 / nu as f32 * 2.0 * PI;
        for j in 0..nv {
            let v = j as f32 / nv as f32 * 2.0 * PI;
            let ring = Vec3::new(u.cos(), 0.0, u.sin());
            let n = ring * v.cos() + Vec3::Y * v.sin();
            positions.push(ring * major + n * minor);
            normals.push(n);
        }
    }
    let mut indices = Vec::new();
    for i in 0..nu {
        for j in 0..nv {
            let a = i * nv + j;
            let b = ((i + 1) % nu) * nv + j;
            let c = ((i + 1) % nu) * nv + (j + 1) % nv;
            let d = i * nv + (j + 1) % nv;
            indices.extend([a, d, c, a, c, b]);
        }
    }
    scene
        .add_mesh(&positions, &normals, &[], &indices, transform, material)
        .expect("built-in torus is valid");
}

/// Several coloured tori on a grey floor in front of a back wall, lit by a
/// spot light from above, as in the slides' "Tori" scene.
pub fn tori() -> Scene {
    let mut s = Scene::new("tori");
    let floor = s.add_material(Vec3::splat(0.6), None);
    let colors = [
        Vec3::new(0.75, 0.2, 0.15),
        Vec3::new(0.2, 0.6, 0.25),
        Vec3::new(0.2, 0.3, 0.75),
        Vec3::new(0.8, 0.7, 0.2),
        Vec3::new(0.7, 0.7, 0.7),
    ];
    let mats: Vec<u32> = colors.iter().map(|&c| s.add_material(c, None)).collect();
    quad(
        &mut s,
        Vec3::new(-4.0, 0.0, 4.0),
        Vec3::new(8.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -8.0),
        floor,
    );
    quad(
        &mut s,
        Vec3::new(-4.0, 0.0, -2.0),
        Vec3::new(8.0, 0.0, 0.0),
        Vec3::new(0.0, 3.0, 0.0),
        floor,
    );
    let (major, minor) = (0.45, 0.15);
    // Lying tori rest on the floor; standing tori touch it with their rim.
    let lying = |x: f32, z: f32| Mat4::from_translation(Vec3::new(x, minor, z));
    let standing = |x: f32, z: f32, yaw: f32| {
        Mat4::from_translation(Vec3::new(x, major + minor, z))
            * Mat4::from_rotation_y(yaw)
            * Mat4::from_rotation_x(PI / 2.0)
    };
    torus(&mut s, major, minor, lying(-1.2, 0.6), mats[0]);
    torus(&mut s, major, minor, standing(-0.2, -0.3, 0.4), mats[1]);
    torus(&mut s, major, minor, lying(0.9, 0.5), mats[2]);
    torus(&mut s, major, minor, standing(1.4, -0.9, -0.6), mats[3]);
    torus(&mut s, major, minor, standing(-1.6, -1.1, 1.1), mats[4]);
    s.lights.push(Light {
        kind: LightKind::Spot {
            inner_cone: 0.6,
            outer_cone: 0.8,
        },
        position: Vec3::new(0.5, 3.5, 2.0),
        direction: (Vec3::new(0.0, 0.0, -0.3) - Vec3::new(0.5, 3.5, 2.0)).normalize(),
        intensity: Vec3::splat(40.0),
    });
    s.cameras.push(Camera::look_at(
        Vec3::new(0.0, 2.0, 4.8),
        Vec3::new(0.0, 0.4, -0.2),
        45f32.to_radians(),
    ));
    s
}

/// Adds a closed axis-aligned box from `lo` to `hi` whose faces (winding
/// and normals) point out: the shape of a modelled cube, a lamp housing or
/// a room made from one.
pub fn axis_box(scene: &mut Scene, lo: Vec3, hi: Vec3, material: u32) -> crate::Result<()> {
    let (half, centre) = ((hi - lo) * 0.5, (hi + lo) * 0.5);
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut indices = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            let u = n.any_orthonormal_vector();
            let v = n.cross(u);
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                positions.push(centre + (n + u * a + v * b) * half);
                normals.push(n);
            }
            // Counter-clockwise seen from outside (u x v = n).
            indices.extend([base, base + 1, base + 2, base, base + 2, base + 3]);
        }
    }
    scene
        .add_mesh(
            &positions,
            &normals,
            &[],
            &indices,
            Mat4::IDENTITY,
            material,
        )
        .map(|_| ())
}
