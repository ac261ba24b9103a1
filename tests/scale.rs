//! Radiance does not depend on the unit a scene is modelled in: the same
//! scene scaled by s (point and spot lights s² as intense, so that the
//! irradiance they give stays; emitters keep their radiance) is the same
//! image. Checked on the built-in Cornell box and a box of 13 cm slabs
//! (2-3 m across) scaled by 0.001 to 10^7: measured means within 0.2%,
//! RMSE at most 1.1% of the mean at 96x72; also with traced ISM texels and
//! exact visibility at 0.001 (RMSE 0.05-2.3%: exact visibility's ray
//! offsets at contacts follow the diagonal only below a metre). Before ray
//! offsets and the ISM test's floor followed scenes under a metre, the 2 mm
//! box was 1.6x too bright (traced texels 0.46x at 0.0001); before SSBC's
//! cluster extents were stored in units of depth and rays into scaled
//! objects were made unit again, 10^6 was 1-3% dark and 10^7 0.7-0.8x
//! (docs/development.md, "Scale"). Geometry beyond `MAX_COORDINATE` is
//! refused.

mod common;

use glam::{Mat4, Vec3};
use ssbc::settings::{RenderSettings, Visibility};
use ssbc::{Layer, Scene};

const SIZE: (u32, u32) = (96, 72);

/// `scene` scaled by `s` about the origin, with its lights and cameras.
fn scaled(scene: &Scene, s: f32) -> Scene {
    let mut out = scene.clone();
    for i in 0..out.objects().len() {
        let t = out.objects()[i].transform;
        out.set_transform(i, Mat4::from_scale(Vec3::splat(s)) * t)
            .unwrap();
    }
    for l in &mut out.lights {
        l.position *= s;
        l.intensity *= s * s;
    }
    for c in &mut out.cameras {
        c.position *= s;
    }
    out
}

fn image(scene: &Scene, visibility: Visibility) -> Vec<f32> {
    let settings = RenderSettings {
        visibility,
        ..common::small(SIZE.0, SIZE.1)
    };
    let frame = common::render_validated(scene, &settings);
    frame.layer(Layer::Final).unwrap().rgba.clone()
}

/// The mean over `b`'s, and the RMSE over `b`'s mean, of the RGB values.
fn compare(a: &[f32], b: &[f32]) -> (f64, f64) {
    let rgb = |x: &[f32]| -> Vec<f64> {
        x.chunks_exact(4)
            .flat_map(|p| p[..3].iter().map(|&v| v as f64))
            .collect()
    };
    let (a, b) = (rgb(a), rgb(b));
    let n = a.len() as f64;
    let mean_b = b.iter().sum::<f64>() / n;
    let mean_a = a.iter().sum::<f64>() / n;
    let mse = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        / n;
    (mean_a / mean_b, mse.sqrt() / mean_b)
}

#[test]
fn a_scene_scaled_from_millimetres_to_10000_km_renders_the_same_image() {
    let thin_box = format!(
        "{}/tests/scenes/thin-box-13cm-outside.gltf",
        env!("CARGO_MANIFEST_DIR")
    );
    for name in ["cornell", thin_box.as_str()] {
        let mut scene = ssbc::scene::load(name).unwrap();
        scene.ensure_light();
        if scene.cameras.is_empty() {
            let camera = scene.camera(None).unwrap();
            scene.cameras.push(camera);
        }
        // ISMs at every scale; traced ISM texels and exact visibility
        // (ray queries, their own offsets) in a 2 mm box.
        let cases = [
            (
                Visibility::Ism,
                &[0.001, 0.01, 0.1, 100.0, 1e5, 1e6, 1e7][..],
            ),
            (Visibility::Traced, &[0.001][..]),
            (Visibility::Exact, &[0.001][..]),
        ];
        for (visibility, scales) in cases {
            let truth = image(&scene, visibility);
            for &s in scales {
                let (mean, rmse) = compare(&image(&scaled(&scene, s), visibility), &truth);
                let what = format!(
                    "{name} x {s:e}, {visibility:?}: mean {mean:.4}, RMSE {rmse:.4} of the mean"
                );
                eprintln!("{what}");
                assert!((mean - 1.0).abs() < 0.01 && rmse < 0.03, "{what}");
            }
        }
    }
}

/// Geometry beyond `MAX_COORDINATE` is refused with one line naming it (a
/// scene scaled by 10^12 had NaN VPLs and took a minute a frame; 10^20
/// panicked in the BVH builder).
#[test]
fn geometry_beyond_max_coordinate_is_refused() {
    let scene = ssbc::scene::load("cornell").unwrap();
    let far = scaled(&scene, 1e12);
    let e = far.validate().unwrap_err().to_string();
    assert!(e.contains("beyond the 1e9 m") && !e.contains('\n'), "{e}");
    let mut renderer = common::validated_renderer();
    let e = renderer
        .render(&far, &common::small(SIZE.0, SIZE.1))
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(e.contains("beyond the 1e9 m"), "{e}");
    // An object of a resident scene moved there: that frame is refused,
    // and the next one, the object back, renders.
    let mut resident = ssbc::resident::ResidentScene::new(scene).unwrap();
    let settings = common::small(SIZE.0, SIZE.1);
    renderer.render_resident(&resident, &settings).unwrap();
    let home = resident.scene().objects()[0].transform;
    resident
        .set_transform(0, Mat4::from_translation(Vec3::splat(2e9)) * home)
        .unwrap();
    let e = renderer
        .render_resident(&resident, &settings)
        .map(|_| ())
        .expect_err("refused")
        .to_string();
    assert!(
        e.contains("object 0") && e.contains("beyond the 1e9 m"),
        "{e}"
    );
    resident.set_transform(0, home).unwrap();
    renderer.render_resident(&resident, &settings).unwrap();
    common::finish_clean(renderer);
}
