//! Per-pass GPU time from timestamp queries, reported as ratios within one
//! run (machines are shared and noisy). Run with
//! `cargo bench --bench passes` (`-- --frames N` for the median of N warm
//! frames per configuration; default 3; `--quick` measures 320x240 only;
//! `--only glossy`, `--only reuse`, `--only history` or `--only visibility`
//! runs table 6, 7, 8 or 9 alone).
//!
//! Every configuration is measured as `ssbc render --frames N` does
//! ([`ssbc::profile::render_frames`]): one warm-up frame (pipelines, first
//! touch of memory), then N frames; the tables give medians.
//!
//! Tables, for cornell and tori at 320x240 and 1024x768 with the defaults:
//! 1. per-pass GPU ms without SSBC (the bounded gather with its parts);
//! 2. the interleaved gather against the full one with the same 1024 VPLs;
//! 3. SSBC: frame GPU ms with 0..2 steps, what a step costs against the rest
//!    of its frame and against the 0-step frame, texels read per pixel;
//! 4. where one step's time goes (its parts), at 1024x768;
//! 5. hierarchical vs brute-force integration: time and texel ratios (at
//!    256x192: brute force is quadratic in the radius);
//! 6. glTF metallic-roughness against Lambertian: `spheres` and the glTF
//!    open-front box (rough dielectrics) with their materials and with each
//!    made Lambertian of its base colour, the same VPL count: the gather, an
//!    SSBC step (and its ratio over the ratio of texels read: what a texel
//!    costs), direct light; then the step's parts at the larger size;
//! 7. camera-only frames of a resident scene (the camera moved 1 cm per
//!    frame) with shadow maps and ISMs kept from the slot's previous frame,
//!    against the same frames redrawing them (`reuse_unchanged` off);
//! 8. still, camera-moved and light-moved resident frames with temporal
//!    history and kept passes (the defaults) against frames standing alone
//!    that redraw everything: per-pass GPU ms and the CPU's ms;
//! 9. VPL visibility, where the device has ray queries: ISMs splatted,
//!    ISMs traced (`--visibility traced`) and exact, for cornell and
//!    `spheres` (whose tessellated spheres make rays dear): the ISM passes
//!    and the frame, and the frame's ratio to the splatted one.

mod common;

use ssbc::profile::{render_frames, FrameStats};
use ssbc::renderer::{Frame, RenderSettings, Renderer};
use ssbc::settings::Gather;
use ssbc::settings::{Integration, SsbcSettings};
use ssbc::timings::Timings;
use ssbc::Scene;

fn stats(f: &Frame) -> &FrameStats {
    f.timings
        .stats
        .as_ref()
        .expect("measured with render_frames")
}

/// Median GPU ms of the pass `name` (0 if it did not run).
fn pass_ms(f: &Frame, name: &str) -> f64 {
    stats(f)
        .passes
        .iter()
        .find(|p| p.name == name)
        .map_or(0.0, |p| p.ms.median)
}

/// Median GPU ms of the whole frame.
fn frame_ms(f: &Frame) -> f64 {
    stats(f)
        .frame_gpu_ms
        .expect("this benchmark needs GPU timestamps")
        .median
}

/// Median GPU ms of SSBC step `k` (1-based).
fn step_ms(f: &Frame, k: usize) -> f64 {
    pass_ms(f, &format!("ssbc_step_{k}"))
}

/// One warm-up frame, then `frames` frames (medians in the stats).
fn measure(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    frames: u32,
) -> Frame {
    render_frames(renderer, scene, settings, frames, None).expect("frames")
}

fn geometry_pixels(f: &Frame) -> usize {
    f.image.rgba.chunks_exact(4).filter(|p| p[3] != 0.0).count()
}

fn main() {
    let args = common::BenchArgs::parse(3);
    let reps = args.frames;
    let sizes = args.sizes();
    let mut renderer = common::timing_renderer();
    let device = renderer.device().name().to_string();
    println!("# ssbc benchmark on {device}, defaults, median of {reps} warm frames\n");
    if args.only.as_deref() == Some("glossy") {
        glossy_against_lambertian(&mut renderer, sizes, reps);
        return;
    }
    if args.only.as_deref() == Some("reuse") {
        camera_only_frames(&mut renderer, sizes, reps);
        return;
    }
    if args.only.as_deref() == Some("history") {
        frame_kinds(&mut renderer, sizes, reps);
        return;
    }
    if args.only.as_deref() == Some("visibility") {
        visibility_modes(&mut renderer, sizes, reps);
        return;
    }
    let scenes = ["cornell", "tori"];
    let settings = |size: (u32, u32), steps: u32| {
        let mut s = RenderSettings::new(size.0, size.1);
        s.ssbc.steps = steps;
        s
    };

    println!("## Per pass, no SSBC: GPU ms\n");
    let passes = [
        "shadow_maps",
        "ism_splat",
        "gbuffer",
        "direct_lighting",
        "indirect_bounded",
        "indirect_bounded/gather",
        "indirect_bounded/filter",
        "indirect_bounded/creases",
    ];
    println!("| scene | size | VPLs | {} | frame |", passes.join(" | "));
    println!("|---|---|---|{}---|", "---|".repeat(passes.len()));
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for &size in sizes {
            let f = measure(&mut renderer, &scene, &settings(size, 0), reps);
            let cells: Vec<String> = passes
                .iter()
                .map(|p| format!("{:.1}", pass_ms(&f, p)))
                .collect();
            println!(
                "| {scene_name} | {}x{} | {} | {} | {:.1} |",
                size.0,
                size.1,
                f.timings.vpl_count,
                cells.join(" | "),
                frame_ms(&f)
            );
        }
    }

    println!("\n## Interleaved gather against the full gather, the same 1024 VPLs, no SSBC\n");
    println!("| scene | size | full ms | interleaved ms (gather + filter + creases) | speed-up | pixels x VPLs per us, full | interleaved |");
    println!("|---|---|---|---|---|---|---|");
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for &size in sizes {
            let mut s = settings(size, 0);
            s.vpl.count = 1024;
            let interleaved = measure(&mut renderer, &scene, &s, reps);
            s.gather = Gather::Full;
            let full = measure(&mut renderer, &scene, &s, reps);
            let pairs = geometry_pixels(&full) as f64 * full.timings.vpl_count as f64;
            let (tf, ti) = (
                pass_ms(&full, "indirect_bounded"),
                pass_ms(&interleaved, "indirect_bounded"),
            );
            println!(
                "| {scene_name} | {}x{} | {tf:.1} | {ti:.1} ({:.1} + {:.1} + {:.1}) | {:.1}x | {:.0} | {:.0} |",
                size.0,
                size.1,
                pass_ms(&interleaved, "indirect_bounded/gather"),
                pass_ms(&interleaved, "indirect_bounded/filter"),
                pass_ms(&interleaved, "indirect_bounded/creases"),
                tf / ti,
                pairs / tf / 1e3,
                pairs / ti / 1e3,
            );
        }
    }

    println!("\n## SSBC: frame GPU ms with K steps at the defaults\n");
    println!(
        "SSBC ms: the geometry pyramid and the K steps, from the frame's own timestamps; \
         per step / rest: (SSBC ms / K) over the rest of the same frame (robust to the \
         machine's noise); per step / 0-step: (frame - 0-step frame) / K over the 0-step \
         frame (two frames). Texels: read per geometry pixel by step 1 (average, most of \
         any one pixel); ns/texel: GPU ns of step 1 per texel read.\n"
    );
    println!("| scene | size | VPLs | K | frame ms | SSBC ms | per step / rest | per step / 0-step | texels/px avg | max | ns/texel |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut parts = Vec::new();
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for &size in sizes {
            let frames: Vec<Frame> = (0..3)
                .map(|k| measure(&mut renderer, &scene, &settings(size, k), reps))
                .collect();
            let base = frame_ms(&frames[0]);
            let vpls = frames[0].timings.vpl_count;
            let (w, h) = size;
            for (k, f) in frames.iter().enumerate() {
                if k == 0 {
                    println!("| {scene_name} | {w}x{h} | {vpls} | 0 | {base:.1} | — | — | — | — | — | — |");
                    continue;
                }
                let ssbc_ms =
                    pass_ms(f, "ssbc_geometry_mips") + (1..=k).map(|j| step_ms(f, j)).sum::<f64>();
                let rest = frame_ms(f) - ssbc_ms;
                let per_step = (frame_ms(f) - base) / k as f64;
                let step = &f.timings.ssbc_steps[0];
                let reads = step.samples_per_pixel_avg * geometry_pixels(f) as f64;
                println!(
                    "| {scene_name} | {w}x{h} | {vpls} | {k} | {:.1} | {ssbc_ms:.1} | {:.0}% | {:.0}% | {:.1} | {:.0} | {:.1} |",
                    frame_ms(f),
                    100.0 * ssbc_ms / k as f64 / rest,
                    100.0 * per_step / base,
                    step.samples_per_pixel_avg,
                    step.samples_per_pixel_max,
                    step_ms(f, 1) * 1e6 / reads.max(1.0)
                );
            }
            if size == *sizes.last().unwrap() {
                parts.push((scene_name, frames[1].clone()));
            }
        }
    }

    let (pw, ph) = *sizes.last().unwrap();
    println!("\n## One step's parts ({pw}x{ph}, K = 1): GPU ms\n");
    for (scene_name, f) in &parts {
        let cells: Vec<String> = std::iter::once(format!(
            "ssbc_geometry_mips {:.1}",
            pass_ms(f, "ssbc_geometry_mips")
        ))
        .chain(
            stats(f)
                .passes
                .iter()
                .filter(|p| p.name.starts_with("ssbc_step_1/"))
                .map(|p| format!("{} {:.1}", &p.name["ssbc_step_1/".len()..], p.ms.median)),
        )
        .collect();
        let step = &f.timings.ssbc_steps[0];
        println!(
            "- {scene_name}: {}; evaluation points from level {}, {:.1}% of pixels evaluated alone",
            cells.join(", "),
            step.eval_level,
            step.fallback_fraction * 100.0
        );
    }

    let (bw, bh) = (256, 192);
    println!("\n## Hierarchical vs brute force, one step at {bw}x{bh}\n");
    println!("| scene | hierarchical ms | brute ms | time ratio | texels/px hier | brute | texel ratio |");
    println!("|---|---|---|---|---|---|---|");
    for scene_name in scenes {
        let scene = ssbc::scene::load(scene_name).unwrap();
        let hier = measure(
            &mut renderer,
            &scene,
            &one_step(Integration::Hierarchical, (bw, bh)),
            reps,
        );
        let brute = measure(
            &mut renderer,
            &scene,
            &one_step(Integration::Brute, (bw, bh)),
            reps,
        );
        let (th, tb) = (step_ms(&hier, 1), step_ms(&brute, 1));
        let (sh, sb) = (
            hier.timings.ssbc_steps[0].samples_per_pixel_avg,
            brute.timings.ssbc_steps[0].samples_per_pixel_avg,
        );
        println!(
            "| {scene_name} | {th:.1} | {tb:.1} | {:.1}x | {sh:.1} | {sb:.1} | {:.1}x |",
            tb / th,
            sb / sh
        );
    }
    glossy_against_lambertian(&mut renderer, sizes, reps);
}

/// `scene` with every material made Lambertian of its base colour.
fn lambertian(scene: &Scene) -> Scene {
    let mut s = scene.clone();
    for m in &mut s.materials {
        m.reflectance = ssbc::scene::Reflectance::Lambertian;
    }
    s
}

/// Median over adjacent pairs of frames of `a`'s `ms` over `b`'s.
fn pair_ratio(a: &[Timings], b: &[Timings], ms: impl Fn(&Timings) -> Option<f64>) -> f64 {
    let mut ratios: Vec<f64> = a
        .iter()
        .zip(b)
        .filter_map(|(a, b)| Some(ms(a)? / ms(b)?))
        .collect();
    ratios.sort_by(f64::total_cmp);
    ratios.get(ratios.len() / 2).copied().unwrap_or(f64::NAN)
}

/// A pass's GPU ms in one frame's timings.
fn timed_pass(name: &str) -> impl Fn(&Timings) -> Option<f64> + '_ {
    move |t| {
        t.passes
            .as_ref()?
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.gpu_ms)
    }
}

/// `frames` frames of `a` and of `b` taken in turn (after a warm-up frame
/// of each), so that both see the same load on a shared machine: the
/// last frame of each, with the medians in its stats, and every frame's
/// timings.
fn measure_in_turn(
    renderer: &mut Renderer,
    (a, b): (&Scene, &Scene),
    settings: &RenderSettings,
    frames: u32,
) -> [(Frame, Vec<Timings>); 2] {
    let mut timings = [Vec::new(), Vec::new()];
    let mut last = [None, None];
    for i in 0..=frames.max(1) {
        for (k, scene) in [a, b].into_iter().enumerate() {
            let frame = renderer.render(scene, settings).expect("frame");
            if i > 0 {
                timings[k].push(frame.timings.clone());
            }
            last[k] = Some(frame);
        }
    }
    let [ta, tb] = timings;
    let [fa, fb] = last.map(|f| f.expect("rendered"));
    [(fa, ta), (fb, tb)].map(|(mut f, t)| {
        f.timings.stats = Some(FrameStats::of(&t));
        (f, t)
    })
}

/// Table 6: what glossy materials cost against Lambertian ones. The two
/// variants' frames alternate, and each ratio is the median over adjacent
/// pairs of frames: on a shared machine a ratio of the two medians, taken
/// one after the other, moved by 15% between runs.
fn glossy_against_lambertian(renderer: &mut Renderer, sizes: &[(u32, u32)], reps: u32) {
    println!("\n## glTF metallic-roughness against Lambertian (one step): GPU ms\n");
    println!("| scene | size | VPLs | direct | gather | gather ratio | step | step ratio | texels/px | per texel | glossy px alone | frame ratio |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    // The step's parts of each scene's largest size, printed after.
    let mut parts = Vec::new();
    let scenes = [
        ssbc::scene::builtin::spheres(),
        // Rough dielectrics, as most glTF assets' materials.
        ssbc::scene::load("assets/open-front-box.gltf").expect("the open-front box"),
    ];
    for (glossy, &size) in scenes
        .iter()
        .flat_map(|s| sizes.iter().map(move |z| (s, z)))
    {
        let matte = lambertian(glossy);
        let s = RenderSettings::new(size.0, size.1);
        let [(g, gt), (m, mt)] = measure_in_turn(renderer, (glossy, &matte), &s, reps);
        let ratio = |name: &str| pair_ratio(&gt, &mt, timed_pass(name));
        let frame_ratio = pair_ratio(&gt, &mt, |t| t.frame_gpu_ms);
        let texels = |f: &Frame| f.timings.ssbc_steps[0].samples_per_pixel_avg;
        let step_ratio = ratio("ssbc_step_1");
        println!(
            "| {} | {}x{} | {} | {:.1} / {:.1} | {:.1} / {:.1} | {:.2}x | {:.1} / {:.1} | {:.2}x | {:.1} / {:.1} | {:.2}x | {:.1}% / {:.1}% | {:.2}x |",
            glossy.name,
            size.0,
            size.1,
            g.timings.vpl_count,
            pass_ms(&g, "direct_lighting"),
            pass_ms(&m, "direct_lighting"),
            pass_ms(&g, "indirect_bounded"),
            pass_ms(&m, "indirect_bounded"),
            ratio("indirect_bounded"),
            step_ms(&g, 1),
            step_ms(&m, 1),
            step_ratio,
            texels(&g),
            texels(&m),
            step_ratio / (texels(&g) / texels(&m)),
            g.timings.ssbc_steps[0].fallback_fraction * 100.0,
            m.timings.ssbc_steps[0].fallback_fraction * 100.0,
            frame_ratio,
        );
        if Some(&size) == sizes.last() {
            parts.push((
                format!("{} {}x{}", glossy.name, size.0, size.1),
                step_parts(&g, &m, &gt, &mt),
            ));
        }
    }
    // Where the step's excess goes: its kernels, glossy / Lambertian, and
    // of each the kernel that evaluates the points or pixels at glossy
    // receivers (on a CPU device it runs after the one without glossy
    // code; on a GPU one dispatch runs both and has no part of its own).
    for (name, rows) in parts {
        println!("\n### {name}: one step's parts, GPU ms (glossy / Lambertian, pair ratio)\n");
        println!("| part | glossy | Lambertian | ratio | of it, the glossy kernel |");
        println!("|---|---|---|---|---|");
        for row in rows {
            println!("{row}");
        }
    }
}

/// Table rows for the parts of step 1 (`ssbc_step_1/...`) of the frames
/// `g` (glossy) and `m` (its Lambertian twin), measured in turn.
fn step_parts(g: &Frame, m: &Frame, gt: &[Timings], mt: &[Timings]) -> Vec<String> {
    let prefix = "ssbc_step_1/";
    stats(g)
        .passes
        .iter()
        .map(|p| p.name.as_str())
        .filter(|n| n.starts_with(prefix) && !n.ends_with("/glossy"))
        .map(|name| {
            let glossy_kernel = format!("{name}/glossy");
            let own = pass_ms(g, &glossy_kernel);
            format!(
                "| {} | {:.1} | {:.1} | {:.2}x | {} |",
                &name[prefix.len()..],
                pass_ms(g, name),
                pass_ms(m, name),
                pair_ratio(gt, mt, timed_pass(name)),
                if own > 0.0 {
                    format!("{own:.1}")
                } else {
                    "-".to_string()
                },
            )
        })
        .collect()
}

/// Table 9: ISMs splatted, traced and exact visibility, in turn per
/// repetition so that each ratio comes from one stretch of the run.
fn visibility_modes(renderer: &mut Renderer, sizes: &[(u32, u32)], reps: u32) {
    use ssbc::settings::Visibility;
    if renderer.device().ray_queries().is_none() {
        println!("\n(no ray queries on this device: table 9 needs them)");
        return;
    }
    println!(
        "\n## VPL visibility: GPU ms (ISM passes, frame) and the frame over the splatted ISMs'\n"
    );
    println!(
        "| scene | size | splatted: ISM, frame | traced: ISM, frame, ratio | exact: frame, ratio |"
    );
    println!("|---|---|---|---|---|");
    let ism_ms =
        |f: &Frame| pass_ms(f, "ism_points") + pass_ms(f, "ism_splat") + pass_ms(f, "ism_traced");
    for scene_name in ["cornell", "spheres"] {
        let scene = ssbc::scene::load(scene_name).unwrap();
        for &size in sizes {
            let run = |renderer: &mut Renderer, visibility| {
                let mut settings = RenderSettings::new(size.0, size.1);
                settings.visibility = visibility;
                measure(renderer, &scene, &settings, reps)
            };
            let splatted = run(renderer, Visibility::Ism);
            let traced = run(renderer, Visibility::Traced);
            let exact = run(renderer, Visibility::Exact);
            let base = frame_ms(&splatted);
            println!(
                "| {scene_name} | {}x{} | {:.1}, {:.1} | {:.1}, {:.1}, {:.2}x | {:.1}, {:.2}x |",
                size.0,
                size.1,
                ism_ms(&splatted),
                base,
                ism_ms(&traced),
                frame_ms(&traced),
                frame_ms(&traced) / base,
                frame_ms(&exact),
                frame_ms(&exact) / base,
            );
        }
    }
}

/// Table 7: camera-only resident frames keeping the view-independent
/// passes' output, against the same frames redrawing it.
fn camera_only_frames(renderer: &mut Renderer, sizes: &[(u32, u32)], reps: u32) {
    println!(
        "\n## Camera-only frames of a resident scene (camera moved 1 cm per frame): frame GPU ms\n"
    );
    println!("| scene | size | redrawn | kept | ratio | passes kept |");
    println!("|---|---|---|---|---|---|");
    let scenes = [
        ssbc::scene::load("assets/open-front-box.gltf").expect("the open-front box"),
        ssbc::scene::builtin::cornell(),
        ssbc::scene::builtin::tori(),
    ];
    for scene in &scenes {
        for &size in sizes {
            let mut median = |reuse: bool| {
                let mut settings = RenderSettings::new(size.0, size.1);
                settings.reuse_unchanged = reuse;
                // Kept passes alone (table 8 adds history).
                settings.history.enabled = false;
                let mut resident =
                    ssbc::resident::ResidentScene::new(scene.clone()).expect("valid scene");
                let mut camera = scene.camera(None).expect("a camera");
                let mut frames = Vec::new();
                // One warm-up frame per slot, then the measured ones.
                for _ in 0..reps.max(1) + 2 {
                    camera.position += 0.01 * camera.up.cross(camera.forward).normalize();
                    resident.set_camera(camera.clone());
                    frames.push(
                        renderer
                            .render_resident(&resident, &settings)
                            .expect("frame"),
                    );
                }
                let frames = frames.split_off(2);
                let mut ms: Vec<f64> = frames
                    .iter()
                    .map(|f| f.timings.frame_gpu_ms.expect("GPU timestamps"))
                    .collect();
                ms.sort_by(f64::total_cmp);
                (ms[ms.len() / 2], frames[0].timings.reused_passes.join(", "))
            };
            let (redrawn, _) = median(false);
            let (kept, passes) = median(true);
            println!(
                "| {} | {}x{} | {redrawn:.1} | {kept:.1} | {:.2} | {passes} |",
                scene.name,
                size.0,
                size.1,
                kept / redrawn
            );
        }
    }
}

/// What changes between the frames of table 8.
#[derive(Clone, Copy, PartialEq)]
enum Change {
    Still,
    Camera,
    Light,
}

/// Table 8: still, camera-moved (1 cm) and light-moved (1 cm) frames of a
/// resident scene, with the defaults (temporal history, kept passes) and
/// standing alone (both off): median per-pass GPU ms, frame GPU ms and the
/// CPU's ms (its stages and recording, without the wait for the GPU).
fn frame_kinds(renderer: &mut Renderer, sizes: &[(u32, u32)], reps: u32) {
    println!("\n## Resident frames by what changed: median GPU ms per pass, frame, CPU ms\n");
    let groups = [
        "shadow_maps",
        "ism",
        "gbuffer",
        "direct_lighting",
        "indirect_bounded",
        "ssbc",
        "temporal",
    ];
    println!(
        "| scene | size | change | frames | {} | frame GPU | CPU | kept |",
        groups.join(" | ")
    );
    println!(
        "|---|---|---|---|{}---|---|---|",
        "---|".repeat(groups.len())
    );
    let scenes = [
        ssbc::scene::load("assets/open-front-box.gltf").expect("the open-front box"),
        ssbc::scene::builtin::cornell(),
    ];
    for scene in &scenes {
        let mut scene = scene.clone();
        scene.ensure_light();
        for &size in sizes {
            for change in [Change::Still, Change::Camera, Change::Light] {
                let mut rows = Vec::new();
                for defaults in [false, true] {
                    let mut settings = RenderSettings::new(size.0, size.1);
                    settings.history.enabled = defaults;
                    settings.reuse_unchanged = defaults;
                    let mut resident =
                        ssbc::resident::ResidentScene::new(scene.clone()).expect("valid scene");
                    let mut camera = scene.camera(None).expect("a camera");
                    let mut lights = scene.lights.clone();
                    let mut frames = Vec::new();
                    for _ in 0..reps.max(1) + 2 {
                        match change {
                            Change::Still => {}
                            Change::Camera => {
                                camera.position +=
                                    0.01 * camera.up.cross(camera.forward).normalize();
                                resident.set_camera(camera.clone());
                            }
                            Change::Light => {
                                lights[0].position += glam::Vec3::X * 0.01;
                                resident.set_lights(lights.clone()).expect("lights");
                            }
                        }
                        frames.push(
                            renderer
                                .render_resident(&resident, &settings)
                                .expect("frame"),
                        );
                    }
                    let frames = frames.split_off(2);
                    let median = |f: &dyn Fn(&Frame) -> f64| {
                        let mut v: Vec<f64> = frames.iter().map(f).collect();
                        v.sort_by(f64::total_cmp);
                        v[v.len() / 2]
                    };
                    // Top-level passes (their parts are named `pass/part`);
                    // absent: kept from the slot's previous frame.
                    let group_ms = |g: &str| {
                        median(&|f: &Frame| {
                            f.timings
                                .passes
                                .iter()
                                .flatten()
                                .filter(|p| p.name.starts_with(g) && !p.name.contains('/'))
                                .map(|p| p.gpu_ms)
                                .fold(f64::NAN, |sum, ms| if sum.is_nan() { ms } else { sum + ms })
                        })
                    };
                    let passes: Vec<String> = groups
                        .iter()
                        .map(|g| match group_ms(g) {
                            ms if ms.is_nan() => "—".to_string(),
                            ms => format!("{ms:.1}"),
                        })
                        .collect();
                    let gpu = median(&|f: &Frame| f.timings.frame_gpu_ms.expect("GPU timestamps"));
                    let cpu = median(&|f: &Frame| {
                        f.timings
                            .cpu_spans
                            .iter()
                            .filter(|s| s.name != "wait_for_gpu")
                            .map(|s| s.ms())
                            .sum()
                    });
                    rows.push((passes, gpu, cpu, frames[0].timings.reused_passes.join(", ")));
                }
                for (label, (passes, gpu, cpu, kept)) in ["alone", "defaults"].iter().zip(&rows) {
                    println!(
                        "| {} | {}x{} | {} | {label} | {} | {gpu:.1} | {cpu:.1} | {kept} |",
                        scene.name,
                        size.0,
                        size.1,
                        match change {
                            Change::Still => "still",
                            Change::Camera => "camera 1 cm",
                            Change::Light => "light 1 cm",
                        },
                        passes.join(" | ")
                    );
                }
                println!(
                    "| | | | defaults / alone |{} {:.2} | {:.2} | |",
                    " |".repeat(groups.len()),
                    rows[1].1 / rows[0].1,
                    rows[1].2 / rows[0].2.max(1e-9)
                );
            }
        }
    }
}

/// One SSBC step with 256 VPLs (hierarchical vs brute force).
fn one_step(integration: Integration, size: (u32, u32)) -> RenderSettings {
    let mut s = RenderSettings::new(size.0, size.1);
    s.vpl.count = 256;
    s.ssbc = SsbcSettings {
        steps: 1,
        integration,
        ..Default::default()
    };
    s
}
