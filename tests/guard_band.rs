//! The guard band: surfaces just outside the image become SSBC sources, as
//! if the view were that much wider, and nothing else changes.

mod common;

use ssbc::renderer::RenderSettings;
use ssbc::settings::Gather;
use ssbc::settings::Integration;
use ssbc::Frame;

const SIZE: (u32, u32) = (128, 96);

fn settings(size: (u32, u32), guard_band: bool) -> RenderSettings {
    let mut s = common::small(size.0, size.1);
    s.vpl.count = 64;
    // Brute force: the residual is a plain sum over every source pixel, so
    // more sources can only add to it.
    s.ssbc.integration = Integration::Brute;
    s.ssbc.guard_band = guard_band;
    // Every VPL at every pixel: S0 at a pixel does not depend on the image
    // around it (the interleaved gather's filter does).
    s.gather = Gather::Full;
    s
}

fn rgb(f: &Frame, name: &str) -> Vec<f32> {
    let layer = f
        .layer(name.parse().expect("a layer name"))
        .unwrap_or_else(|| panic!("layer {name}"));
    layer
        .rgba
        .chunks_exact(4)
        .flat_map(|p| p[..3].to_vec())
        .collect()
}

fn sum(v: &[f32]) -> f64 {
    v.iter().map(|&x| x as f64).sum()
}

#[test]
fn a_guard_band_adds_the_sources_a_wider_view_sees() {
    // Cornell zoomed in (half its field of view): walls and blocks lie just
    // outside the image.
    let mut scene = ssbc::scene::builtin::cornell();
    scene.ensure_light();
    let mut camera = scene.camera(None).expect("camera");
    camera.yfov *= 0.5;
    scene.cameras = vec![camera.clone()];

    let mut renderer = common::validated_renderer();
    let log = renderer.validation_log();
    let plain = renderer
        .render(&scene, &settings(SIZE, false))
        .expect("frame");
    let banded = renderer
        .render(&scene, &settings(SIZE, true))
        .expect("frame");
    let m = banded.timings.guard_band;
    assert_eq!(plain.timings.guard_band, 0);
    assert!(m > 0 && m % 16 == 0 && m <= SIZE.1 / 2 + 15, "margin {m}");
    assert_eq!((banded.width, banded.height), SIZE);
    // An engine reading the image on the GPU is told where the frame is.
    let out = renderer.output_image().expect("output image");
    assert_eq!((out.origin, out.extent), ((m, m), SIZE));

    // The same view, rendered m pixels wider on every side without a band.
    let wide_size = (SIZE.0 + 2 * m, SIZE.1 + 2 * m);
    let grow = wide_size.1 as f32 / SIZE.1 as f32;
    camera.yfov = 2.0 * ((camera.yfov * 0.5).tan() * grow).atan();
    scene.cameras = vec![camera];
    let wide = renderer
        .render(&scene, &settings(wide_size, false))
        .expect("frame");
    drop(renderer);
    assert_eq!(log.total(), 0, "validation messages");

    let crop = |f: &Frame, name: &str| -> Vec<f32> {
        let all = rgb(f, name);
        let row = wide_size.0 as usize * 3;
        (0..SIZE.1 as usize)
            .flat_map(|y| {
                let start = (y + m as usize) * row + m as usize * 3;
                all[start..start + SIZE.0 as usize * 3].to_vec()
            })
            .collect()
    };
    for name in ["direct", "indirect_bounded", "residual_1", "final"] {
        let (a, b) = (rgb(&banded, name), crop(&wide, name));
        let worst = a
            .iter()
            .zip(&b)
            .map(|(x, y)| (x - y).abs())
            .fold(0f32, f32::max);
        let peak = b.iter().fold(0f32, |p, &y| p.max(y.abs()));
        assert!(
            worst <= 1e-4 * peak,
            "{name}: band vs wider view differ by {worst} (peak {peak})"
        );
    }

    // The band only adds sources (brute force, full gather: S0 at a pixel
    // is its own): no pixel loses residual, and the zoomed view gains some
    // from what lies outside it.
    let (with, without) = (rgb(&banded, "residual_1"), rgb(&plain, "residual_1"));
    let peak = without.iter().fold(0f32, |p, &y| p.max(y));
    for (i, (a, b)) in with.iter().zip(&without).enumerate() {
        assert!(*a >= b - 1e-4 * peak, "pixel {}: {a} < {b}", i / 3);
    }
    let gain = sum(&with) / sum(&without) - 1.0;
    assert!(
        gain > 0.005,
        "the band added {:.3}% of the residual",
        100.0 * gain
    );
    // The image itself is the same (a few silhouette pixels aside: the
    // wider frame's projection rounds differently).
    let (a, b) = (rgb(&banded, "direct"), rgb(&plain, "direct"));
    let peak = b.iter().fold(0f32, |p, &y| p.max(y));
    let moved = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (*x - *y).abs() > 1e-4 * peak)
        .count();
    assert!(
        moved * 200 <= a.len(),
        "{moved} pixel channels of direct light moved"
    );
    println!("the band added {:.2}% of the residual", 100.0 * gain);
}
