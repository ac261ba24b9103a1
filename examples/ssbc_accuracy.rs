//! Hierarchical SSBC against brute force, one step: relative RMSE and mean
//! ratio of `residual_1` against the brute-force CPU twin (on a spread sample
//! of pixels), texels read per pixel, the fraction of pixels evaluated alone,
//! and the step's GPU time, for the built-in scenes and an open-front box.
//!
//! `cargo run --release --example ssbc_accuracy -- [WxH ...] [SCENE.gltf ...]`
//! (default 256x192 320x240 640x480; bounds: auto and 10 /m²; scene files
//! after the built-ins).
//!
//! Tuning and diagnosis, from the environment: `SSBC_<SETTING>=value`
//! overrides an `SsbcSettings` field (see `tests/common/ssbc_accuracy.rs`),
//! `SSBC_REPEAT=n` keeps the fastest of n frames, `SSBC_PARTS=1` prints the
//! parts of the step, `SSBC_HEATMAP=dir` writes the texels read per pixel as
//! a PNG (log scale, blue few, red most), `SSBC_SCENES=spheres,tori` measures
//! only those scenes.

#[path = "../tests/common/ssbc_accuracy.rs"]
mod ssbc_accuracy;

use ssbc::renderer::{Bound, Renderer, RendererConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut sizes: Vec<(u32, u32)> = std::env::args()
        .skip(1)
        .filter_map(|a| {
            let (w, h) = a.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .collect();
    if sizes.is_empty() {
        sizes = vec![(256, 192), (320, 240), (640, 480)];
    }
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    let mut scenes = vec![
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
        ssbc_accuracy::open_box(),
        ssbc::scene::builtin::spheres(),
        // glTF materials: rough dielectrics, nearly Lambertian receivers.
        ssbc::scene::load("assets/open-front-box.gltf").expect("the open-front box"),
    ];
    // Scene files named on the command line are measured after them.
    for path in std::env::args()
        .skip(1)
        .filter(|a| a.ends_with(".gltf") || a.ends_with(".glb"))
    {
        let mut scene = ssbc::scene::load(&path)?;
        scene.ensure_light();
        scenes.push(scene);
    }
    let only = std::env::var("SSBC_SCENES").ok();
    let scenes: Vec<_> = scenes
        .into_iter()
        .filter(|s| {
            only.as_ref()
                .is_none_or(|o| o.split(',').any(|n| n == s.name))
        })
        .collect();
    println!("| scene | size | bound | rel. RMSE | mean ratio | texels/px avg | max | alone | eval level | step ms |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for scene in &scenes {
        for &size in &sizes {
            for bound in [Bound::Auto, Bound::Value(10.0)] {
                let settings = ssbc_accuracy::one_step(size, bound);
                let stride = ((size.0 * size.1) as usize / 4000).max(1) | 1;
                let (c, mut f) =
                    ssbc_accuracy::residual_vs_twin(&mut renderer, scene, &settings, stride);
                // SSBC_REPEAT=n: the fastest of n renders (timings are noisy).
                let repeat: usize = std::env::var("SSBC_REPEAT")
                    .ok()
                    .and_then(|v| v.parse().ok())
                    .unwrap_or(1);
                for _ in 1..repeat {
                    let g = renderer.render(scene, &settings)?;
                    if g.timings.ssbc_steps[0].gpu_ms < f.timings.ssbc_steps[0].gpu_ms {
                        f = g;
                    }
                }
                if std::env::var("SSBC_PARTS").is_ok() {
                    for p in f
                        .timings
                        .timed_passes()
                        .iter()
                        .filter(|p| p.name.contains('/'))
                    {
                        eprintln!("    {:<28} {:>9.1} ms", p.name, p.gpu_ms);
                    }
                }
                let step = &f.timings.ssbc_steps[0];
                if let Ok(dir) = std::env::var("SSBC_HEATMAP") {
                    let counts = &f.samples[0];
                    let max = counts.iter().copied().fold(1.0f32, f32::max).ln();
                    let img = image::RgbImage::from_fn(f.width, f.height, |x, y| {
                        let c = counts[(y * f.width + x) as usize];
                        let t = (c.max(1.0).ln() / max).clamp(0.0, 1.0);
                        image::Rgb([
                            (255.0 * t) as u8,
                            (255.0 * (1.0 - (2.0 * t - 1.0).abs())) as u8,
                            (255.0 * (1.0 - t)) as u8,
                        ])
                    });
                    img.save(format!(
                        "{dir}/{}-{}x{}-{}.png",
                        scene.name, size.0, size.1, f.bound
                    ))
                    .unwrap();
                }
                println!(
                    "| {} | {}x{} | {} | {:.2}% | {:.4} | {:.1} | {:.0} | {:.1}% | {} | {:.1} |",
                    scene.name,
                    size.0,
                    size.1,
                    match bound {
                        Bound::Auto | Bound::Converging(_) => format!("auto ({:.2})", f.bound),
                        Bound::Value(b) => format!("{b}"),
                    },
                    c.relative_rmse * 100.0,
                    c.mean_ratio,
                    step.samples_per_pixel_avg,
                    step.samples_per_pixel_max,
                    step.fallback_fraction * 100.0,
                    step.eval_level,
                    step.gpu_ms.unwrap_or(f64::NAN)
                );
            }
        }
    }
    Ok(())
}
