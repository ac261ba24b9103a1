//! VPL visibility through thin walls (tests/scenes/thin-*: boxes of closed
//! slabs 1 mm to 20 cm thick seen from outside and inside, two rooms
//! sharing a 1 mm or 20 cm wall with the light in one or a light in
//! each), against the CPU
//! path tracer. Exact visibility (ray queries) leaves every surface the
//! path tracer shows unlit unlit; imperfect shadow maps let light through,
//! as measured (a known limit, pinned so that it can only get better).

mod common;

use std::sync::atomic::AtomicBool;

use ssbc::reference::{Reference, ReferenceSettings};
use ssbc::settings::{Gather, Visibility};
use ssbc::{Layer, Scene};

const SIZE: (u32, u32) = (96, 72);

const SCENES: [&str; 6] = [
    "thin-box-13cm-outside",
    "thin-box-1mm-outside",
    "thin-box-20cm-outside",
    "thin-box-1mm-inside",
    "thin-two-rooms-1mm",
    "thin-two-rooms-20cm",
];

fn load(name: &str) -> Scene {
    let path = format!("{}/tests/scenes/{name}.gltf", env!("CARGO_MANIFEST_DIR"));
    let mut scene = ssbc::scene::load(&path).expect("test scene");
    scene.ensure_light();
    scene
}

/// The path tracer's image (`spp` samples at each pixel's centre, as the
/// GPU samples).
fn truth(scene: &Scene, spp: u32) -> Vec<f32> {
    let settings = ReferenceSettings {
        width: SIZE.0,
        height: SIZE.1,
        spp,
        ..Default::default()
    };
    let reference = Reference::new(scene, settings).unwrap();
    reference.render(&AtomicBool::new(false), |_| {}).0
}

fn luminance(rgba: &[f32], i: usize) -> f64 {
    (rgba[i * 4] + rgba[i * 4 + 1] + rgba[i * 4 + 2]) as f64 / 3.0
}

/// How an image agrees with the truth on light and dark: its mean over the
/// truth's; and its mean over the pixels the truth leaves unlit (they and
/// their eight neighbours exactly black: no path reaches them) over its
/// whole mean.
fn light_and_dark(image: &[f32], truth: &[f32]) -> (f64, f64, usize) {
    let (w, h) = (SIZE.0 as i64, SIZE.1 as i64);
    let n = (w * h) as usize;
    let mean = |img: &[f32]| (0..n).map(|i| luminance(img, i)).sum::<f64>() / n as f64;
    let dark: Vec<usize> = (0..n)
        .filter(|&i| {
            let (x, y) = (i as i64 % w, i as i64 / w);
            (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (u, v) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                    luminance(truth, (v * w + u) as usize) == 0.0
                })
            })
        })
        .collect();
    let dark_mean =
        dark.iter().map(|&i| luminance(image, i)).sum::<f64>() / dark.len().max(1) as f64;
    let whole = mean(image);
    (
        whole / mean(truth),
        dark_mean / whole.max(1e-30),
        dark.len(),
    )
}

#[test]
fn exact_visibility_leaks_nothing_through_thin_walls() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    let mut failures = Vec::new();
    for name in SCENES {
        let scene = load(name);
        let mut settings = common::small(SIZE.0, SIZE.1);
        settings.visibility = Visibility::Exact;
        let frame = renderer.render(&scene, &settings).expect("render");
        let truth = truth(&scene, 128);
        let (ratio, dark, dark_pixels) = light_and_dark(&frame.image.rgba, &truth);
        eprintln!(
            "{name}: exact visibility: mean / path tracer {ratio:.4}; on the {dark_pixels} pixels the path tracer leaves unlit, {:.3}% of the mean",
            dark * 100.0
        );
        // The path tracer's mean is good to about 1% at 128 samples here.
        if (ratio - 1.0).abs() > 0.03 {
            failures.push(format!("{name}: mean / path tracer {ratio}"));
        }
        if dark > 1e-3 {
            failures.push(format!("{name}: unlit pixels at {dark} of the mean"));
        }
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Imperfect shadow maps (the default for a single frame) let light into
/// the unlit room through its shared wall, 1 mm or 20 cm thick: measured
/// 2026-11-30 at 0.79% (1 mm) and 0.20% (20 cm) of the image's mean on the
/// other room's pixels (means 1.013 and 1.0065 of the path tracer's) since
/// the ray-cast layer's blocks keep the plane their corners met (0.88% and
/// 0.26% before, means 1.014 and 1.007), since
/// the interleaved filter keeps apart what other lights reach (1.22% and
/// 0.26% before, means 1.015 and 1.007), since
/// neither the stored plane's test nor the slope term leaves room for a
/// curve (1.61% and 0.37% before, means 1.020 and 1.008), since
/// the relative tolerance is 0.05 (1.94% and 0.50% at 0.08), since tiles
/// map by projected solid angle (2.1% and 0.54% with the paraboloid,
/// means 1.024 and 1.009), since
/// one-texel holes are filled (2.2% and 0.67% before, means 1.025 and
/// 1.011), since the test follows the plane of a stored wall that turns
/// across the receiver's surface (3.0% and 1.2% before, means 1.033 and
/// 1.015; 4.1% and 2.3% before ISM discs). Pinned below 1.5 times that, so that it can
/// only get better; every thin scene's mean within issue 61's 3%.
#[test]
fn isms_leak_through_a_shared_wall_no_more_than_measured() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    isms_through_thin_walls(&mut renderer, Visibility::Ism, false, |name| match name {
        "thin-two-rooms-1mm" => 0.0079,
        "thin-two-rooms-20cm" => 0.0020,
        _ => f64::NAN,
    });
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// ISMs whose texels are traced (`Visibility::Traced`) leak less through
/// the shared wall: measured 2026-11-30 at 0.45% (1 mm) and 0.10% (20 cm)
/// of the image's mean on the other room's pixels (means 1.009 and 1.006;
/// 0.83% and 0.10% before the interleaved filter kept apart what other
/// lights reach; 1.22% and 0.10% before the stored plane's test left no
/// room for a curve; 1.18% and 0.05% with paraboloid tiles, before their
/// projected map, whose last ring spans the 20 degrees above the
/// horizon), against 0.88% and 0.26% with splatted texels. Pinned below
/// 1.5 times that; every thin scene's mean within issue 61's 3%.
#[test]
fn traced_isms_leak_through_a_shared_wall_no_more_than_measured() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    isms_through_thin_walls(
        &mut renderer,
        Visibility::Traced,
        false,
        |name| match name {
            "thin-two-rooms-1mm" => 0.0045,
            "thin-two-rooms-20cm" => 0.0010,
            _ => f64::NAN,
        },
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// ISMs with back-face maps (`RenderSettings::ism_back_faces`, on for
/// accumulated frames without ray queries) hide what lies beyond the
/// shared wall's far side: measured 2026-11-30 at 0.48% (1 mm) and
/// 0.11% (20 cm) of the image's mean on the other room's pixels, against
/// 0.79% and 0.20% without (means 1.009 and 1.006 of the path tracer's,
/// against 1.013 and 1.0065; the boxes seen from outside 0.1% darker;
/// 0.57% and 0.14% before the ray-cast layer's blocks kept their planes;
/// 0.95% and 0.14% before the interleaved filter kept apart what other
/// lights reach; 1.04% and 0.18% before the stored plane's test left no
/// room for a curve).
/// Pinned below 1.5 times that, and below what the same frames leak
/// without them.
#[test]
fn back_face_maps_leak_less_through_a_shared_wall() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let plain = isms_through_thin_walls(&mut renderer, Visibility::Ism, false, |_| f64::NAN);
    let back = isms_through_thin_walls(&mut renderer, Visibility::Ism, true, |name| match name {
        "thin-two-rooms-1mm" => 0.0048,
        "thin-two-rooms-20cm" => 0.0011,
        _ => f64::NAN,
    });
    for ((name, plain), (_, back)) in plain.iter().zip(&back) {
        if name.starts_with("thin-two-rooms") {
            assert!(
                back < plain,
                "{name}: back-face maps leak {back}, plain ISMs {plain}"
            );
        }
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// An accumulation where visibility stays ISMs (no ray queries: here
/// asked for) takes finer ISMs with back-face maps, and a bound that grows
/// as its frames average more VPLs, and a 2 x 2 interleaved pattern
/// (`settings::CONVERGING_INTERLEAVE`): 4 frames of the two rooms leak
/// 0.22% (1 mm) and 0.04% (20 cm) of the image's mean into the unlit
/// room, measured 2026-11-30 (0.24% and 0.04% before the ray-cast
/// layer's blocks kept their planes; 0.76% and 0.04% with the 4 x 4 pattern,
/// whose filter averaged the floors either side of the 1 mm wall; 0.80%
/// and 0.04% before the stored plane's test left no room for a curve;
/// the thin boxes seen from outside 0.00-0.01%), against 0.48% and 0.11%
/// with back-face maps at 32 texels and 0.79% and 0.20% with a single
/// frame's ISMs. Pinned below 1.5 times that, and below the back-face
/// maps' measure.
#[test]
fn a_converging_accumulation_with_isms_leaks_less() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let configure = |s: &mut ssbc::RenderSettings| {
        s.visibility = Visibility::Ism;
        s.ism_back_faces = true;
        s.ism_tile = ssbc::settings::CONVERGING_ISM_TILE;
        s.points_per_vpl = ssbc::settings::CONVERGING_POINTS_PER_VPL;
        s.interleave = ssbc::settings::CONVERGING_INTERLEAVE;
    };
    let rooms = ["thin-two-rooms-1mm", "thin-two-rooms-20cm"];
    let measured = |name: &str| match name {
        "thin-two-rooms-1mm" => 0.0022,
        _ => 0.0004,
    };
    for (name, leak) in thin_walls(&mut renderer, &rooms, configure, 4, measured) {
        let back_faces = if name == "thin-two-rooms-1mm" {
            0.0048
        } else {
            0.0011
        };
        assert!(leak < back_faces, "{name}: {leak} of the mean");
    }
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// Two rooms sharing a 1 mm wall, each lit by a point light of its own (2
/// and 0.2 W/sr): beside the wall, thinner than a pixel, the dim room's
/// floor and back wall lie on the bright room's planes, and only the
/// lights that reach them tell them apart (`direct_lights`). The dim
/// room's mean over the path tracer's, ISMs: measured 2026-11-30 at
/// 1.075 with the interleaved gather (1.082 before the ray-cast layer's
/// blocks kept their planes), against 1.171 before its filter kept apart
/// what other lights reach and 1.090 with the full gather (no filter):
/// what is left is the ISMs' own leak. Pinned below 1.5 times
/// that excess, and at most 2% above the full gather's.
#[test]
fn the_filter_keeps_apart_what_other_lights_reach() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let scene = load("thin-two-rooms-1mm-two-lights");
    let truth = truth(&scene, 64);
    let mut ratios = Vec::new();
    for gather in [Gather::Interleaved, Gather::Full] {
        let mut settings = common::small(SIZE.0, SIZE.1);
        settings.visibility = Visibility::Ism;
        settings.gather = gather;
        settings.debug_readback = true; // (the G-buffer's positions)
        let frame = renderer.render(&scene, &settings).expect("render");
        // The dim room: what lies beyond the wall's far face (x = 0.5 mm).
        let position = frame.layer(Layer::GBufferPosition).expect("positions");
        let room: Vec<usize> = (0..(SIZE.0 * SIZE.1) as usize)
            .filter(|&i| position.rgba[4 * i + 3] != 0.0 && position.rgba[4 * i] > 0.001)
            .collect();
        assert!(
            room.len() > 1000,
            "only {} pixels in the dim room",
            room.len()
        );
        let sum = |image: &[f32]| room.iter().map(|&i| luminance(image, i)).sum::<f64>();
        let ratio = sum(&frame.image.rgba) / sum(&truth);
        eprintln!("{gather:?} gather: the dim room's mean / path tracer {ratio:.4}");
        ratios.push(ratio);
    }
    let (interleaved, full) = (ratios[0], ratios[1]);
    assert!(interleaved < 1.0 + 1.5 * 0.075, "interleaved {interleaved}");
    assert!(
        interleaved < full + 0.02,
        "interleaved {interleaved}, full {full}"
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// Every thin scene with ISMs made as `visibility` makes them (with
/// back-face maps if `back_faces`): its mean within issue 61's 3% of the
/// path tracer's, and the rooms' leak (the unlit room's share of the mean)
/// below 1.5 times `measured`. Returns each scene's leak.
fn isms_through_thin_walls(
    renderer: &mut ssbc::Renderer,
    visibility: Visibility,
    back_faces: bool,
    measured: impl Fn(&str) -> f64,
) -> Vec<(&'static str, f64)> {
    let configure = |s: &mut ssbc::RenderSettings| {
        s.visibility = visibility;
        s.ism_back_faces = back_faces;
    };
    thin_walls(renderer, &SCENES, configure, 1, measured)
}

/// [`isms_through_thin_walls`] for `scenes` in frames of settings that
/// `configure` makes, `frames` of them accumulated.
fn thin_walls(
    renderer: &mut ssbc::Renderer,
    scenes: &[&'static str],
    configure: impl Fn(&mut ssbc::RenderSettings),
    frames: u32,
    measured: impl Fn(&str) -> f64,
) -> Vec<(&'static str, f64)> {
    let mut leaks = Vec::new();
    for &name in scenes {
        let scene = load(name);
        let mut settings = common::small(SIZE.0, SIZE.1);
        configure(&mut settings);
        let (visibility, back_faces) = (settings.visibility, settings.ism_back_faces);
        let frame = if frames == 1 {
            renderer.render(&scene, &settings)
        } else {
            let stop = AtomicBool::new(false);
            renderer.render_accumulated(&scene, &settings, frames, &stop, |_| {})
        }
        .expect("render");
        let truth = truth(&scene, 64);
        let (ratio, dark, pixels) = light_and_dark(&frame.image.rgba, &truth);
        eprintln!(
            "{name}: {visibility} ISMs{} ({} texels, {} points, {frames} frames): mean / path tracer {ratio:.4}; on the {pixels} unlit pixels {:.2}% of the mean",
            if back_faces { " with back-face maps" } else { "" },
            settings.ism_tile,
            settings.points_per_vpl,
            dark * 100.0
        );
        let measured = measured(name);
        if measured.is_finite() {
            assert!(pixels > 500, "{name}: only {pixels} unlit pixels");
            assert!(dark < 1.5 * measured, "{name}: unlit pixels at {dark}");
        }
        assert!(
            (ratio - 1.0).abs() < 0.03,
            "{name}: {visibility} ISMs' mean / path tracer {ratio}"
        );
        leaks.push((name, dark));
    }
    leaks
}

/// Frames with and without back-face maps, in turn on one renderer (the
/// atlas reallocated each time): the plain ISMs' image after is the
/// plain ISMs' image before.
#[test]
fn isms_after_back_face_frames_are_the_same_isms() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let scene = load("thin-two-rooms-1mm");
    let settings = |back_faces| {
        let mut s = common::small(SIZE.0, SIZE.1);
        s.visibility = Visibility::Ism;
        s.ism_back_faces = back_faces;
        s
    };
    let first = renderer.render(&scene, &settings(false)).expect("render");
    let back = renderer.render(&scene, &settings(true)).expect("render");
    let after = renderer.render(&scene, &settings(false)).expect("render");
    assert!(first.image.rgba.iter().any(|&v| v > 0.0));
    assert!(
        first.image.rgba != back.image.rgba,
        "back-face maps changed nothing"
    );
    assert!(
        first.image.rgba == after.image.rgba,
        "ISMs after a frame with back-face maps differ from a first frame's"
    );
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// A frame that splats ISMs after frames that traced them (or tested
/// visibility exactly) on the same VPLs, which cast no ISM layer and
/// sampled no points, renders what a first frame with ISMs renders.
#[test]
fn isms_after_traced_and_exact_frames_are_the_same_isms() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    if !common::has_ray_queries(&renderer) {
        return;
    }
    let scene = load("thin-two-rooms-20cm");
    let scene = ssbc::resident::ResidentScene::new(scene).unwrap();
    let settings = |visibility| {
        let mut s = common::small(SIZE.0, SIZE.1);
        s.visibility = visibility;
        s
    };
    let first = renderer
        .render_resident(&scene, &settings(Visibility::Ism))
        .expect("render");
    let mut again = common::validated_renderer();
    let again_log = again.validation_log();
    for visibility in [Visibility::Traced, Visibility::Exact] {
        again
            .render_resident(&scene, &settings(visibility))
            .expect("render");
    }
    let after = again
        .render_resident(&scene, &settings(Visibility::Ism))
        .expect("render");
    assert!(first.image.rgba.iter().any(|&v| v > 0.0));
    assert!(
        first.image.rgba == after.image.rgba,
        "ISMs after traced and exact frames differ from a first frame's"
    );
    drop((renderer, again));
    assert_eq!(log.total() + again_log.total(), 0, "validation messages");
}

/// The weighted replay of a frame's ISM test (examples/visibility.rs):
/// of the light the VPLs send to every `stride`-th geometry pixel (flux x
/// min(G, b)), the share of the exactly visible light the ISMs pass.
fn replayed_passed_light(scene: &Scene, frame: &ssbc::Frame, stride: usize) -> f64 {
    use ssbc::passes::indirect_bounded::{ism_bias, ism_test_for};
    let bvh = ssbc::cpu::bvh::SceneBvh::new(scene);
    let ism = frame.ism.as_ref().expect("debug readback");
    let layer = |name: &str| &frame.layer(name.parse().unwrap()).unwrap().rgba;
    let (pos, nrm, alb) = (
        layer("gbuffer_position"),
        layer("gbuffer_normal"),
        layer("gbuffer_albedo"),
    );
    let v = |img: &[f32], i: usize| glam::Vec3::new(img[i * 4], img[i * 4 + 1], img[i * 4 + 2]);
    let (mut visible, mut passed) = (0.0f64, 0.0f64);
    let pixels = (0..(frame.width * frame.height) as usize).filter(|&i| pos[i * 4 + 3] != 0.0);
    for i in pixels.step_by(stride) {
        let (x, n) = (v(pos, i), v(nrm, i));
        let albedo = glam::Vec4::from_slice(&alb[i * 4..i * 4 + 4]);
        let brdf = ssbc::cpu::brdf::Brdf::from_gbuffer(albedo, nrm[i * 4 + 3]);
        let test = ism_test_for(&brdf, ism_bias(Visibility::Ism));
        for (k, vpl) in frame.vpls.iter().enumerate() {
            let d = x - vpl.position;
            let d2 = d.length_squared();
            let w = d / d2.sqrt();
            let (cos_z, cos_x) = (vpl.normal.dot(w), -n.dot(w));
            if d2 < 1e-10 || cos_z <= 0.0 || cos_x <= 0.0 {
                continue;
            }
            if bvh.occluded(vpl.position + vpl.normal * 1e-4, x + n * 1e-4) {
                continue;
            }
            let weight = (ssbc::cpu::emitters::luminance(vpl.flux)
                * (cos_z * cos_x / d2).min(frame.bound)) as f64;
            visible += weight;
            passed += weight * ism.visible(k, vpl, x, n, test) as u8 as f64;
        }
    }
    passed / visible
}

/// The ISMs of frames that converge without exact visibility (64 texels,
/// 4096 points, back-face maps: `ssbc::settings::CONVERGING_ISM_TILE`)
/// combine the ray-cast layer with the splat in the fill, where a block's
/// farthest corner lies before a crease or a curve within it. Replayed on
/// the open box (96x72, 512 VPLs), the share of the exactly visible light
/// they pass: measured 2026-11-30 at 0.9927, against 0.9881 with the layer
/// written first, as the 32-texel default keeps it (which passes 0.9851).
/// Pinned at 0.991.
#[test]
fn finer_isms_pass_what_their_ray_cast_layer_hid() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let scene = ssbc::scene::load("assets/open-front-box.gltf").unwrap();
    let passed = |renderer: &mut ssbc::Renderer, tile, points| {
        let mut s = common::small(SIZE.0, SIZE.1);
        s.vpl.count = 512;
        s.visibility = Visibility::Ism;
        s.ism_back_faces = true;
        s.ism_tile = tile;
        s.points_per_vpl = points;
        s.debug_readback = true;
        s.ssbc.steps = 0;
        let frame = renderer.render(&scene, &s).expect("render");
        replayed_passed_light(&scene, &frame, 2)
    };
    let coarse = passed(&mut renderer, 32, 1024);
    let fine = passed(
        &mut renderer,
        ssbc::settings::CONVERGING_ISM_TILE,
        ssbc::settings::CONVERGING_POINTS_PER_VPL,
    );
    eprintln!(
        "open box: ISMs pass {coarse:.4} (32 texels) and {fine:.4} (64) of the visible light"
    );
    assert!(fine > 0.991, "finer ISMs pass {fine} of the visible light");
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}

/// Where no point lands, an ISM texel holds the ray-cast layer: where its
/// block's four corners met one plane, that plane's own distance along
/// the texel's centre ray (`ism_layer_texel`), else the farthest corner.
/// Cornell at 96x72 with one point per VPL (so the layer shows almost
/// everywhere): of the (receiver, VPL) texels, the share whose stored
/// distance is the exact distance along their centre ray (within 0.1%,
/// cast on the CPU), measured 2026-11-30 at 0.273 against 0.016 when
/// every block held its farthest corner (the rest lie in blocks across
/// creases and edges); and the share more than 0.1% nearer, 0.0651
/// against 0.0645 (the one point's disc, a third of a metre wide, reaches
/// past its surface's edges; the planes add no occluder). Pinned at 0.2
/// and 0.068.
#[test]
fn the_layer_holds_the_plane_its_corners_met() {
    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let mut scene = ssbc::scene::load("cornell").expect("cornell");
    scene.ensure_light();
    let mut s = common::small(SIZE.0, SIZE.1);
    s.vpl.count = 64;
    s.visibility = Visibility::Ism;
    s.points_per_vpl = 1;
    s.debug_readback = true;
    s.ssbc.steps = 0;
    let frame = renderer.render(&scene, &s).expect("render");
    let bvh = ssbc::cpu::bvh::SceneBvh::new(&scene);
    let ism = frame.ism.as_ref().expect("debug readback");
    let pos = &frame
        .layer("gbuffer_position".parse().unwrap())
        .unwrap()
        .rgba;
    let (mut exact, mut nearer, mut texels) = (0usize, 0usize, 0usize);
    let pixels = (0..(frame.width * frame.height) as usize).filter(|&i| pos[i * 4 + 3] != 0.0);
    for i in pixels.step_by(5) {
        let x = glam::Vec3::from_slice(&pos[i * 4..i * 4 + 3]);
        for (k, vpl) in frame.vpls.iter().enumerate() {
            if vpl.normal.dot(x - vpl.position) <= 1e-4 {
                continue;
            }
            let (ray, stored) = ism.texel_centre_ray(k, vpl, x);
            let from = vpl.position + vpl.normal * 1e-4;
            let Some(hit) = bvh.intersect(from, ray, 0.0, f32::MAX) else {
                continue;
            };
            texels += 1;
            exact += ((stored - hit.t).abs() <= 1e-3 * hit.t) as usize;
            nearer += (stored < hit.t * (1.0 - 1e-3)) as usize;
        }
    }
    let (exact, nearer) = (exact as f64 / texels as f64, nearer as f64 / texels as f64);
    eprintln!(
        "cornell, one point per VPL: {exact:.4} of {texels} texels exact, {nearer:.4} nearer"
    );
    assert!(texels > 10_000, "{texels} texels");
    assert!(
        exact > 0.2,
        "{exact} of the texels hold their centre ray's distance"
    );
    assert!(nearer < 0.068, "{nearer} of the texels lie nearer");
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");
}
