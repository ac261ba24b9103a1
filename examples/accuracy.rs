//! The accuracy table of docs/accuracy.md: relMSE and mean-radiance ratio against a
//! path-traced reference for the clamped image, SSBC with 1..3 steps and the
//! unclamped image, on the built-in scenes, with the time each took; and the
//! Kollig–Keller baseline's time.
//!
//! `cargo run --release --example accuracy -- [WxH] [reference spp] [Kollig-Keller WxH] [Kollig-Keller spp] [scenes]`
//! (defaults 512x384, 256, 1024x768, 4, `cornell,tori,spheres`; a Kollig-Keller
//! size of `0x0` skips it).

use std::sync::atomic::AtomicBool;
use std::time::Instant;

use ssbc::compare::{block_average, compare};
use ssbc::reference::{Method, Reference, ReferenceSettings};
use ssbc::renderer::{Bound, RenderSettings, Renderer, RendererConfig};

fn size(arg: Option<String>, default: (u32, u32)) -> (u32, u32) {
    arg.and_then(|s| {
        let (w, h) = s.split_once('x')?;
        Some((w.parse().ok()?, h.parse().ok()?))
    })
    .unwrap_or(default)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let (w, h) = size(args.next(), (512, 384));
    let spp: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(256);
    let (kw, kh) = size(args.next(), (1024, 768));
    let kk_spp: u32 = args.next().and_then(|s| s.parse().ok()).unwrap_or(4);
    let scenes = args
        .next()
        .unwrap_or_else(|| "cornell,tori,spheres".to_string());
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    println!("| scene | image | relMSE | relMSE (4x4) | mean / truth | time |");
    println!("|---|---|---|---|---|---|");
    for name in scenes.split(',') {
        let scene = ssbc::scene::load(name)?;
        let t = Instant::now();
        let settings = ReferenceSettings {
            width: w,
            height: h,
            spp,
            ..Default::default()
        };
        let (truth, _) = Reference::new(&scene, settings)?.render(&AtomicBool::new(false), |_| {});
        println!(
            "| {name} | path-traced reference, {spp} spp | — | — | 1 | {:.1} s CPU |",
            t.elapsed().as_secs_f64()
        );
        let configs: [(&str, u32, Bound); 5] = [
            ("clamped (b auto)", 0, Bound::Auto),
            ("SSBC 1 step", 1, Bound::Auto),
            ("SSBC 2 steps", 2, Bound::Auto),
            ("SSBC 3 steps", 3, Bound::Auto),
            ("unclamped (b = inf)", 0, Bound::Value(f32::INFINITY)),
        ];
        for (label, steps, bound) in configs {
            let mut s = RenderSettings::new(w, h);
            s.bound = bound;
            s.ssbc.steps = steps;
            let frame = renderer.render(&scene, &s)?;
            let c = compare(&frame.image.rgba, &truth)?;
            let blocks = compare(
                &block_average(&frame.image.rgba, w, h, 4),
                &block_average(&truth, w, h, 4),
            )?;
            println!(
                "| {name} | {label} | {:.4} | {:.4} | {:.4} | {:.0} ms GPU |",
                c.rel_mse,
                blocks.rel_mse,
                c.mean_ratio,
                frame.timings.frame_gpu_ms.unwrap_or(f64::NAN)
            );
        }
    }
    if kw == 0 || kh == 0 {
        return Ok(());
    }
    let scene = ssbc::scene::load("cornell")?;
    let settings = ReferenceSettings {
        width: kw,
        height: kh,
        spp: kk_spp,
        method: Method::KolligKeller,
        bound: Bound::Auto.resolve(2.0 * scene.bounds().radius()),
        ..Default::default()
    };
    let t = Instant::now();
    Reference::new(&scene, settings)?.render(&AtomicBool::new(false), |_| {});
    println!(
        "\nKollig-Keller on cornell at {kw}x{kh}, 256 VPLs, {kk_spp} spp: {:.1} s on {} CPU threads",
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    Ok(())
}
