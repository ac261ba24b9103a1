//! The interleaved bounded gather against the full gather with the same
//! VPLs (relative RMSE and mean ratio of `indirect_bounded` over every
//! geometry pixel, over discontinuity pixels and over the rest), with the
//! GPU ms of both, on cornell, tori and the open box.
//!
//! `cargo run --release --example gather_accuracy -- [WxH ...] [--vpls N] [--interleave N]`
//! (default 320x240 and 1024x768, 1024 VPLs, the default pattern).

#[path = "../tests/common/gather_accuracy.rs"]
mod gather_accuracy;
#[path = "../tests/common/ssbc_accuracy.rs"]
mod ssbc_accuracy;

use ssbc::renderer::{RenderSettings, Renderer, RendererConfig};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let value = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .and_then(|v| v.parse::<u32>().ok())
    };
    let mut sizes: Vec<(u32, u32)> = args
        .iter()
        .filter_map(|a| {
            let (w, h) = a.split_once('x')?;
            Some((w.parse().ok()?, h.parse().ok()?))
        })
        .collect();
    if sizes.is_empty() {
        sizes = vec![(320, 240), (1024, 768)];
    }
    let mut renderer = Renderer::new(&RendererConfig::default())?;
    let scenes = [
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
        ssbc_accuracy::open_box(),
    ];
    println!("| scene | size | VPLs | N | rel. RMSE | mean ratio | discontinuity px | rel. RMSE | mean ratio | rest: rel. RMSE | mean ratio | full ms | interleaved ms (gather + filter) | speed-up |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    for scene in &scenes {
        for &(width, height) in &sizes {
            let mut settings = RenderSettings {
                width,
                height,
                ..Default::default()
            };
            settings.vpl.count = value("--vpls").unwrap_or(1024) as usize;
            settings.interleave = value("--interleave").unwrap_or(settings.interleave);
            let c = gather_accuracy::compare_gathers(&mut renderer, scene, &settings);
            let share = c.discontinuity.pixels as f64 / c.all.pixels.max(1) as f64;
            println!(
                "| {} | {width}x{height} | {} | {} | {:.2}% | {:.4} | {:.1}% | {:.2}% | {:.4} | {:.2}% | {:.4} | {:.1} | {:.1} ({:.1} + {:.1}) | {:.1}x |",
                scene.name,
                c.full.vpls.len(),
                settings.interleave,
                100.0 * c.all.relative_rmse,
                c.all.mean_ratio,
                100.0 * share,
                100.0 * c.discontinuity.relative_rmse,
                c.discontinuity.mean_ratio,
                100.0 * c.continuous.relative_rmse,
                c.continuous.mean_ratio,
                c.full_ms,
                c.interleaved_ms.0,
                c.interleaved_ms.1,
                c.interleaved_ms.2,
                c.full_ms / c.interleaved_ms.0,
            );
            if std::env::var("SSBC_HYBRID").is_ok() {
                for (reach, k) in [(1, 2.0), (1, 4.0), (2, 2.0), (2, 4.0)] {
                    let mask = gather_accuracy::crease_mask(&c.full, reach, k);
                    let (f, n) = gather_accuracy::with_full_where(&c, &mask);
                    println!("  full gather within {reach} px of a crease ({k} footprints; {:.1}% of geometry px): rel. RMSE {:.2}%, mean {:.4}", 100.0 * n as f64 / c.all.pixels as f64, 100.0 * f.relative_rmse, f.mean_ratio);
                }
                for reach in [1, 2] {
                    let mask = gather_accuracy::discontinuity_mask(&c.full, reach);
                    let (f, n) = gather_accuracy::with_full_where(&c, &mask);
                    println!("  full gather within {reach} px of a discontinuity ({:.1}% of geometry px): rel. RMSE {:.2}%, mean {:.4}", 100.0 * n as f64 / c.all.pixels as f64, 100.0 * f.relative_rmse, f.mean_ratio);
                }
            }
        }
    }
    Ok(())
}
