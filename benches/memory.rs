//! Device memory of one frame slot at the defaults, by part, in bytes per
//! pixel: against image size (320x240 to 3840x2160, cornell's one light)
//! and against the VPL count (1920x1080). Hardware-independent counts,
//! estimated from the settings before anything is allocated
//! (`ssbc::renderer::frame_memory_of`, as `ssbc render` refuses a frame that
//! does not fit); then measured from the allocator after one frame at the
//! sizes this machine renders in seconds, against the estimate on the same
//! device. Run with `cargo bench --bench memory` (`-- --quick`: no
//! rendering).

#[allow(dead_code)]
mod common;

use ssbc::memory::FrameMemory;
use ssbc::renderer::{frame_memory_of, RenderSettings, SlotUse};

const SIZES: [(u32, u32); 4] = [(320, 240), (1024, 768), (1920, 1080), (3840, 2160)];

fn header() {
    let parts: Vec<&str> = FrameMemory::default()
        .parts()
        .iter()
        .map(|(n, _)| *n)
        .collect();
    println!("| what | MiB | B/px | {} |", parts.join(" | "));
    println!("|---|---|---|{}", "---|".repeat(parts.len()));
}

fn row(what: &str, m: &FrameMemory, pixels: u64) {
    let per_pixel = |b: u64| b as f64 / pixels as f64;
    let parts: Vec<String> = m
        .parts()
        .iter()
        .map(|(_, b)| format!("{:.1}", per_pixel(*b)))
        .collect();
    println!(
        "| {what} | {:.0} | {:.1} | {} |",
        m.total() as f64 / (1u64 << 20) as f64,
        per_pixel(m.total()),
        parts.join(" | ")
    );
}

fn main() -> ssbc::Result<()> {
    let quick = std::env::args().any(|a| a == "--quick");
    let mut scene = ssbc::scene::load("cornell")?;
    scene.ensure_light();
    let pixels = |s: &RenderSettings| s.width as u64 * s.height as u64;

    println!("## Bytes per pixel of a frame slot (estimated), by image size\n");
    println!(
        "Defaults: one SSBC step, one layer, the VPL count the size chooses. Immediate frames \
         (`render`) read back the final image and the texels read, and keep no history:\n"
    );
    header();
    for (w, h) in SIZES {
        let s = RenderSettings::new(w, h);
        let m = frame_memory_of(&scene, &s, SlotUse::Immediate);
        row(&format!("{w}x{h}, {} VPLs", s.vpl.count), &m, pixels(&s));
    }
    println!("\nResident frames add the temporal history and read nothing back:\n");
    header();
    for (w, h) in SIZES {
        let s = RenderSettings::new(w, h);
        let m = frame_memory_of(&scene, &s, SlotUse::Resident);
        row(&format!("{w}x{h} resident"), &m, pixels(&s));
    }

    println!("\n## By VPL count, 1920x1080, immediate\n");
    header();
    for vpls in [256, 1024, 2048, 4096, 8192, 16384] {
        let mut s = RenderSettings::new(1920, 1080);
        s.vpl.count = vpls;
        let m = frame_memory_of(&scene, &s, SlotUse::Immediate);
        row(&format!("{vpls} VPLs"), &m, pixels(&s));
    }

    println!(
        "\n## By scene, 1920x1080, immediate (glossy materials keep the evaluation points' glossy \
         rests)\n"
    );
    header();
    for name in ["cornell", "spheres"] {
        let mut scene = ssbc::scene::load(name)?;
        scene.ensure_light();
        let s = RenderSettings::new(1920, 1080);
        let m = frame_memory_of(&scene, &s, SlotUse::Immediate);
        let kind = if scene.has_glossy_materials() {
            "glossy"
        } else {
            "Lambertian"
        };
        let maps = if scene.has_normal_maps() {
            ", normal maps"
        } else {
            ""
        };
        row(&format!("{name} ({kind}{maps})"), &m, pixels(&s));
    }

    if quick {
        return Ok(());
    }
    println!(
        "\n## Measured after one frame (the allocator), against the estimate on the same device\n"
    );
    header();
    for (w, h) in [(320, 240), (1024, 768)] {
        // A renderer per size: one frame slot holds resources.
        let mut renderer = common::timing_renderer();
        let s = RenderSettings::new(w, h);
        let report = renderer.render(&scene, &s)?.timings.memory;
        let what = format!("{w}x{h} on {}", renderer.device().name());
        row(&format!("{what}, estimated"), &report.estimated, pixels(&s));
        row(
            &format!("{what}, measured ({} slot)", report.slots),
            &report.measured,
            pixels(&s),
        );
    }
    Ok(())
}
