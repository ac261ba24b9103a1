//! The `ssbc` command line: the library's settings as flags, progress
//! bars, Ctrl-C and logging to stderr (none of which the library has).

#[cfg(feature = "viewer")]
mod swapchain;
#[cfg(feature = "viewer")]
mod viewer;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::{Parser, Subcommand};

use ssbc::reference::{Method, Reference, ReferenceSettings};
use ssbc::settings::{
    Bound, Gather, HistorySettings, Integration, LayerResolution, NamedChoice, RenderSettings,
    RendererConfig, SsbcSettings, Visibility, VplSettings, DEFAULT_BOUNCES,
};
use ssbc::vk::DeviceSelector;
use ssbc::{Layer, Renderer};

/// A flag taking one of the names of a settings enum.
fn choice<T: NamedChoice + Send + Sync + Clone>() -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(T::NAMES).map(|name| T::from_name(&name).expect("a listed name"))
}

#[derive(Parser)]
#[command(
    name = "ssbc",
    version,
    about = "Screen-Space Bias Compensation for VPL global illumination, on Vulkan"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene headless and write the image.
    Render(RenderArgs),
    /// Ground truth on the CPU: path tracing, or the VPL baselines.
    Reference(ReferenceArgs),
    /// Compare two EXR images (A against reference B).
    Compare(CompareArgs),
    /// Interactive viewer (winit window; X11 or Wayland).
    View(ViewArgs),
}

#[derive(clap::Args)]
struct ReferenceArgs {
    /// Scene: a .gltf/.glb path or a built-in name (cornell, tori, spheres).
    #[arg(default_value = "cornell")]
    scene: String,
    /// Play the glTF file's first animation to T seconds (node translation,
    /// rotation and scale; clamped to its span) and render that pose.
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    time: Option<f32>,
    /// Image size.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    size: (u32, u32),
    /// Output: .exr (linear radiance) or .png (exposed from the image, tonemapped).
    #[arg(short, long, default_value = "reference.exr")]
    output: PathBuf,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..))]
    spp: u32,
    /// Most indirect bounces (0 = direct light only). Russian roulette ends
    /// paths; this is a safety net (a low value biases the image).
    #[arg(long, default_value_t = DEFAULT_BOUNCES)]
    bounces: u32,
    /// Seed.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Estimator: path-trace (truth), vpl (VPL sum, exact visibility), or
    /// kollig-keller (clamped VPL sum + path-traced residual, unbiased).
    #[arg(long, value_parser = choice::<Method>(), default_value_t = Method::PathTrace)]
    method: Method,
    /// VPLs for the VPL methods.
    #[arg(long, default_value_t = 256, allow_negative_numbers = true, value_parser = parse_number)]
    vpls: usize,
    /// Clamping bound b (number, inf, or auto) for the VPL methods.
    #[arg(long, default_value = "auto", value_parser = parse_bound, allow_negative_numbers = true)]
    bound: Bound,
    /// Camera index.
    #[arg(long)]
    camera: Option<usize>,
    /// Average each pixel over its area (random points in it) instead of
    /// sampling its centre as the GPU renderer does: the image other path
    /// tracers give.
    #[arg(long)]
    antialias: bool,
}

#[derive(clap::Args)]
struct CompareArgs {
    /// Image to judge (EXR).
    a: PathBuf,
    /// Reference image (EXR).
    b: PathBuf,
    /// Print the figures as JSON.
    #[arg(long)]
    json: bool,
    /// Write a false-colour relative-error map (PNG).
    #[arg(long, value_name = "OUT.png")]
    heatmap: Option<PathBuf>,
    /// Compare the means of N x N pixel blocks instead of pixels (the error
    /// left once pixel noise is blurred away).
    #[arg(long, value_name = "N", default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=4096))]
    blocks: u32,
}

/// Parses `WxH`.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("'{s}' is not WxH"))?;
    let w: u32 = w
        .trim()
        .parse()
        .map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h
        .trim()
        .parse()
        .map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 {
        return Err(format!("size {w}x{h} is empty"));
    }
    Ok((w, h))
}

/// Parses a non-negative count with a clear message for negative numbers.
/// `--vpls`: a number, or chosen from the image size.
#[derive(Clone, Copy, Debug)]
enum VplCount {
    Auto,
    Exactly(usize),
}

/// Parses a VPL count: a whole number, or `auto`.
fn parse_count(s: &str) -> Result<VplCount, String> {
    if s.trim() == "auto" {
        return Ok(VplCount::Auto);
    }
    let negative = s.trim().starts_with('-');
    parse_number(s).map(VplCount::Exactly).map_err(|e| {
        if negative {
            e
        } else {
            format!("'{s}' is not a whole number or 'auto'")
        }
    })
}

/// Parses a whole number of VPLs.
fn parse_number(s: &str) -> Result<usize, String> {
    if s.trim().starts_with('-') {
        return Err(format!(
            "{s} is negative; use 0 to switch indirect light off"
        ));
    }
    s.trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number"))
}

/// Parses the clamping bound: `auto`, `inf`, or a positive number (1/m^2).
fn parse_bound(s: &str) -> Result<Bound, String> {
    match s {
        "auto" => Ok(Bound::Auto),
        "inf" | "infinity" => Ok(Bound::Value(f32::INFINITY)),
        _ => {
            let b: f32 = s
                .parse()
                .map_err(|_| format!("'{s}' is not a number, 'inf' or 'auto'"))?;
            if b.is_nan() || b <= 0.0 {
                return Err(format!("the bound must be positive, got {s}"));
            }
            Ok(Bound::Value(b))
        }
    }
}

#[derive(clap::Args)]
struct SceneOptions {
    /// Scene: a .gltf/.glb path or a built-in name (cornell, tori, spheres).
    #[arg(default_value = "cornell")]
    scene: String,
    /// Play the glTF file's first animation to T seconds (node translation,
    /// rotation and scale; clamped to its span) and render that pose.
    #[arg(long, value_name = "T", allow_negative_numbers = true)]
    time: Option<f32>,
    /// Image size.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    size: (u32, u32),
    /// Camera index (default: the scene's first camera, or one framing the scene).
    #[arg(long)]
    camera: Option<usize>,
    /// Shadow-map resolution (texels per side).
    #[arg(long, default_value_t = RenderSettings::default().shadow_map_size)]
    shadow_map_size: u32,
    /// Number of VPLs wanted (0 switches indirect light off), or `auto`: one
    /// per 150 pixels, 2048 to 8192 (5120 at 1024x768).
    #[arg(long, default_value = "auto", allow_negative_numbers = true, value_parser = parse_count)]
    vpls: VplCount,
    /// Most diffuse hits of a light path, at least 1. Russian roulette ends
    /// paths; this is a safety net (a low value biases the image).
    #[arg(long, default_value_t = DEFAULT_BOUNCES)]
    bounces: u32,
    /// Seed of the low-discrepancy light-path sequence.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// ISM tile side per VPL in texels (power of two).
    #[arg(long = "ism-res", default_value_t = RenderSettings::default().ism_tile)]
    ism_res: u32,
    /// Scene points each VPL splats into its ISM.
    #[arg(long, default_value_t = RenderSettings::default().points_per_vpl)]
    points_per_vpl: u32,
    /// Splatted ISMs also keep a back-face map per VPL, which hides what
    /// lies behind a closed solid's far side (thin walls leak half as
    /// much, for about 1.1x the frame). On by default for --accumulate
    /// where visibility is auto and stays ISMs.
    #[arg(long)]
    ism_back_faces: bool,
    /// How the bounded VPL lighting visits the VPLs: interleaved (each pixel
    /// of an N x N block one subset, then a depth/normal-aware filter) or
    /// full (every VPL at every pixel; the reference).
    #[arg(long, value_parser = choice::<Gather>(), default_value_t = RenderSettings::default().gather)]
    gather: Gather,
    /// How a VPL's visibility is tested: ism (imperfect shadow maps), traced
    /// (ISMs whose texels are ray-traced, not splatted), exact (a ray per
    /// pixel and VPL), or auto (ISMs for a frame, exact for --accumulate
    /// where possible). traced and exact need ray queries
    /// (VK_KHR_ray_query) and a scene without alpha masks.
    #[arg(long, value_parser = choice::<Visibility>(), default_value_t = RenderSettings::default().visibility)]
    visibility: Visibility,
    /// Side N of the interleaved pattern (N x N subsets of the VPLs). With
    /// --visibility auto, --accumulate's and the viewer's still frames take
    /// at most 2: what the filter blurs is a bias that frames keep.
    #[arg(long, default_value_t = RenderSettings::default().interleave)]
    interleave: u32,
    /// Clamping bound b of the geometry term in 1/m^2: a number, `inf` (no
    /// clamping), or `auto` = (10 / scene bounding-box diagonal)^2, i.e.
    /// clamping starts within a tenth of the scene's diagonal; with `auto`,
    /// --accumulate's and the viewer's still frames clamp less as they
    /// average more VPLs (x sqrt(n) after n sets of 2048).
    #[arg(long, default_value = "auto", value_parser = parse_bound, allow_negative_numbers = true)]
    bound: Bound,
    /// SSBC steps K (0 = no compensation).
    #[arg(long, default_value_t = RenderSettings::default().ssbc.steps)]
    steps: u32,
    /// SSBC integration: hierarchical (the paper's) or brute (reference).
    #[arg(long, value_parser = choice::<Integration>(), default_value_t = Integration::Hierarchical)]
    integration: Integration,
    /// G-buffer layers SSBC gathers from: 1 (the visible surfaces) or 2 (also
    /// a deep G-buffer's second layer: the nearest
    /// surfaces behind the visible ones, back faces included, which light
    /// what the camera sees).
    #[arg(long = "ssbc-layers", default_value_t = RenderSettings::default().ssbc.layers)]
    ssbc_layers: u32,
    /// Resolution of the second layer: full (its pixels split at creases
    /// like the first's) or half (a quarter of its cost).
    #[arg(long = "ssbc-layer1", value_parser = choice::<LayerResolution>(), default_value_t = LayerResolution::Full)]
    ssbc_layer1: LayerResolution,
    /// Minimum separation of the second layer behind the first, as a
    /// fraction of the scene's bounding-box diagonal.
    #[arg(long, default_value_t = RenderSettings::default().ssbc.layer_separation)]
    layer_separation: f32,
    /// Also gather from a guard band: the view widened on every side by
    /// 1/sqrt(b) at the nearest visible depth (at most half the shorter
    /// side), cropped back (not in the viewer).
    #[arg(long)]
    guard_band: bool,
    /// Frames stand alone: no temporal history (the viewer and
    /// `render --sequence` keep one by default: a running mean of the
    /// indirect light that converges while nothing moves).
    #[arg(long)]
    no_history: bool,
    /// Lower clamp of cos(view angle) in the pixel area A_y (grazing views).
    #[arg(long, default_value_t = RenderSettings::default().ssbc.min_cos_view)]
    min_cos_view: f32,
    /// Exposure of PNG output (and of the viewer). Default: chosen from the
    /// image (middle grey at its log-average luminance) for PNGs, 1 in the
    /// viewer.
    #[arg(long)]
    exposure: Option<f32>,
    /// Enable Vulkan validation (also: SSBC_VALIDATION=1); any message makes the exit status non-zero.
    #[arg(long)]
    validate: bool,
    /// Use the device whose name contains this (case-insensitive).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    common: SceneOptions,
    /// Output image: .exr (32-bit float linear RGB) or .png (tonemapped
    /// sRGB); repeat to write several.
    #[arg(short, long, default_value = "out.exr")]
    output: Vec<PathBuf>,

    /// Also write the component layers into the EXR as named channels.
    #[arg(long)]
    layers: bool,

    /// Write this layer as the output image instead of the final image
    /// (direct, indirect_bounded, residual_1, ...).
    #[arg(long, value_name = "LAYER")]
    output_layer: Option<Layer>,

    /// Write per-pass GPU timings as JSON.
    #[arg(long, value_name = "FILE.json")]
    timings: Option<PathBuf>,

    /// Render one warm-up frame and then N frames of the same image; report
    /// min / median / max GPU ms per pass (stderr and the timings JSON).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    frames: Option<u32>,

    /// Progressive refinement: average N frames with independent VPL sets
    /// (each frame the light paths after the previous frame's) into one
    /// image, as N times the VPLs would give (Ctrl-C writes the mean so far).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000), conflicts_with = "frames")]
    accumulate: Option<u32>,

    /// Render one frame per entry of SEQ.json (camera and light changes,
    /// see the library's `sequence` module), keeping temporal history
    /// between frames as the viewer does; `-o`, `--timings` name each frame
    /// with a printf-style number: `-o 'frame_%03d.exr'`.
    #[arg(long, value_name = "SEQ.json", conflicts_with_all = ["frames", "accumulate"])]
    sequence: Option<PathBuf>,

    /// Do not count shader invocations per pass (pipeline-statistics
    /// queries, on by default where the device supports them).
    #[arg(long)]
    no_pipeline_statistics: bool,

    /// Write a Chrome trace-event file (Perfetto, chrome://tracing): GPU
    /// passes and CPU stages of every frame rendered.
    #[arg(long, value_name = "FILE.json")]
    trace: Option<PathBuf>,
}

#[derive(clap::Args)]
struct ViewArgs {
    #[command(flatten)]
    common: SceneOptions,
    /// Render this many frames, then exit (with --screenshot: for tests).
    #[arg(long)]
    frames: Option<u64>,
    /// Screenshot written on exit: FILE.exr (linear) and FILE.png (as shown).
    #[arg(long, value_name = "FILE")]
    screenshot: Option<std::path::PathBuf>,
    /// Move the camera and the light a little every frame (soak runs).
    #[arg(long)]
    animate: bool,
    /// Resize the window N times (one per frame), then minimise and restore it.
    #[arg(long, value_name = "N", default_value_t = 0)]
    resize_storm: u32,
}

fn validation_from_env() -> bool {
    std::env::var("SSBC_VALIDATION").is_ok_and(|v| v != "0" && !v.is_empty())
}

impl SceneOptions {
    fn settings(&self) -> RenderSettings {
        RenderSettings {
            width: self.size.0,
            height: self.size.1,
            camera: self.camera,
            shadow_map_size: self.shadow_map_size,
            vpl: VplSettings {
                count: match self.vpls {
                    VplCount::Exactly(n) => n,
                    VplCount::Auto => ssbc::settings::auto_vpl_count(self.size.0, self.size.1),
                },
                bounces: self.bounces,
                seed: self.seed,
                first_path: 0,
            },
            ism_tile: self.ism_res,
            points_per_vpl: self.points_per_vpl,
            ism_back_faces: self.ism_back_faces,
            gather: self.gather,
            visibility: self.visibility,
            interleave: self.interleave,
            bound: self.bound,
            ssbc: SsbcSettings {
                steps: self.steps,
                integration: self.integration,
                min_cos_view: self.min_cos_view,
                layers: self.ssbc_layers,
                layer1_resolution: self.ssbc_layer1,
                layer_separation: self.layer_separation,
                guard_band: self.guard_band,
                ..Default::default()
            },
            output_layers: false,
            debug_readback: false,
            reuse_unchanged: true,
            history: HistorySettings {
                enabled: !self.no_history,
                // The viewer's still view converges where `--accumulate` does.
                converging_isms: true,
                ..Default::default()
            },
        }
    }

    /// Flag combinations the library would refuse, named as flags.
    fn check(&self) -> Result<(), ssbc::Error> {
        if self.bounces == 0 && !matches!(self.vpls, VplCount::Exactly(0)) {
            return Err(ssbc::Error::InvalidParameter(
                "--bounces 0 leaves no VPLs; use --vpls 0 to switch indirect light off".into(),
            ));
        }
        Ok(())
    }

    fn validation(&self) -> bool {
        self.validate || validation_from_env()
    }

    fn device(&self) -> DeviceSelector {
        DeviceSelector {
            name_contains: self.device.clone(),
        }
    }
}

fn render(args: RenderArgs) -> Result<u32, ssbc::Error> {
    args.common.check()?;
    if let Some(e) = args.common.exposure {
        if !(e.is_finite() && e > 0.0) {
            return Err(ssbc::Error::InvalidParameter(format!(
                "--exposure {e} must be a positive number"
            )));
        }
    }
    let mut scene = load_scene(&args.common.scene, args.common.time)?;
    scene.ensure_light();
    let config = RendererConfig {
        validation: args.common.validation(),
        device: args.common.device(),
        no_pipeline_statistics: args.no_pipeline_statistics,
        ..Default::default()
    };
    let mut settings = args.common.settings();
    // Read back only the layers that will be written.
    settings.output_layers = args.layers || args.output_layer.is_some();
    settings.debug_readback = args.output_layer.is_some_and(Layer::is_debug);
    if let Some(path) = &args.sequence {
        return render_sequence(&args, path, scene, &config, &settings);
    }
    let mut renderer = Renderer::new(&config)?;
    log_memory(&scene, &settings, false);
    let log = renderer.validation_log();
    let mut trace = args
        .trace
        .as_ref()
        .map(|_| ssbc::profile::ChromeTrace::new());
    let frame = match (args.frames, args.accumulate) {
        (Some(n), _) => {
            ssbc::profile::render_frames(&mut renderer, &scene, &settings, n, trace.as_mut())
        }
        (None, Some(n)) => {
            let stop = Arc::new(AtomicBool::new(false));
            {
                let stop = stop.clone();
                // Ctrl-C finishes the frame in flight and writes the mean.
                let _ = ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed));
            }
            let bar = indicatif::ProgressBar::new(n as u64);
            bar.set_style(
                indicatif::ProgressStyle::with_template(
                    "{elapsed_precise} [{bar:40}] {pos}/{len} frames, eta {eta}",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            let frame = renderer
                .render_accumulated(&scene, &settings, n, &stop, |k| bar.set_position(k as u64));
            bar.finish_and_clear();
            frame.inspect(|f| {
                log::info!(
                    "accumulated {} frames, {} VPLs in all",
                    f.accumulated,
                    f.vpls.len()
                )
            })
        }
        (None, None) => renderer.render(&scene, &settings).inspect(|f| {
            if let Some(trace) = trace.as_mut() {
                trace.add_frame(&f.timings);
            }
        }),
    };
    drop(renderer);
    let mut frame = frame?;
    if frame.timings.frame_gpu_ms.is_none() {
        log::warn!("the device's queue has no timestamps: GPU timings are null");
    }
    if let (Some(path), Some(trace)) = (&args.trace, &trace) {
        trace.write(path)?;
        log::info!("wrote {}", path.display());
    }
    select_output_layer(&mut frame, args.output_layer)?;
    for path in &args.output {
        ssbc::output::write_image(&frame, path, args.layers, args.common.exposure)?;
        log::info!("wrote {}", path.display());
    }
    if let Some(path) = &args.timings {
        ssbc::output::write_timings(&frame, path)?;
    }
    eprint!("{}", ssbc::output::timings_table(&frame));
    if let Some(stats) = &frame.timings.stats {
        eprint!("{}", stats.table());
    }
    Ok(log.total())
}

/// The scene, at animation time `time` if given (`--time`).
fn load_scene(name: &str, time: Option<f32>) -> Result<ssbc::scene::Scene, ssbc::Error> {
    let scene = match time {
        Some(t) => ssbc::scene::load_at(name, t),
        None => ssbc::scene::load(name),
    }?;
    log::info!(
        "{}: {} triangles in {} objects drawing {} meshes",
        scene.name,
        scene.triangle_count(),
        scene.objects().len(),
        scene.meshes().len()
    );
    Ok(scene)
}

/// Moves `resident`'s objects to where its glTF animation has them at time
/// `t` (its lights and cameras stay as they are): only the objects that
/// moved change, as cheaply as any object move; nodes scaled to nothing
/// are hidden.
fn show_pose(resident: &mut ssbc::resident::ResidentScene, t: f32) -> Result<(), ssbc::Error> {
    for (object, transform) in resident.scene().pose(t) {
        if let Some(m) = transform {
            resident.set_transform(object, m)?;
        }
        resident.set_visible(object, transform.is_some())?;
    }
    Ok(())
}

/// Logs what a frame slot will take, by part, before anything is
/// allocated (frames read back; resident ones with their history): the
/// bytes asked for, whatever the settings (the device's checks come
/// later, with their own errors).
fn log_memory(scene: &ssbc::Scene, settings: &RenderSettings, resident: bool) {
    use ssbc::renderer::SlotUse;
    let slot = if resident {
        SlotUse::Resident
    } else {
        SlotUse::Immediate
    };
    let m = ssbc::renderer::frame_memory_of(scene, settings, slot);
    let pixels = settings.width as u64 * settings.height as u64;
    log::info!("a frame slot will take {}", m.summary(pixels));
}

/// Makes `wanted` the frame's image (`--output-layer`).
fn select_output_layer(frame: &mut ssbc::Frame, wanted: Option<Layer>) -> Result<(), ssbc::Error> {
    let Some(wanted) = wanted else {
        return Ok(());
    };
    let layer = frame.layer(wanted).cloned().ok_or_else(|| {
        let names: Vec<String> = std::iter::once(&frame.image)
            .chain(&frame.layers)
            .map(|l| l.layer.to_string())
            .collect();
        ssbc::Error::InvalidParameter(format!(
            "--output-layer: no layer {wanted} (have: {})",
            names.join(", ")
        ))
    })?;
    frame.image = layer;
    Ok(())
}

/// `pattern` with its printf-style frame number (`%d`, `%03d`) replaced
/// by `k`; None if it has none.
fn numbered(pattern: &Path, k: usize) -> Option<PathBuf> {
    let text = pattern.to_str()?;
    let start = text.find('%')?;
    let rest = &text[start + 1..];
    let digits = rest.len() - rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    if !rest[digits..].starts_with('d') {
        return None;
    }
    let width: usize = rest[..digits].parse().unwrap_or(0).min(32);
    let number = format!("{k:0width$}");
    Some(PathBuf::from(format!(
        "{}{number}{}",
        &text[..start],
        &rest[digits + 1..]
    )))
}

/// `render --sequence`: one frame per entry, history kept between them.
fn render_sequence(
    args: &RenderArgs,
    path: &Path,
    scene: ssbc::scene::Scene,
    config: &RendererConfig,
    settings: &RenderSettings,
) -> Result<u32, ssbc::Error> {
    let sequence = ssbc::sequence::Sequence::load(path)?;
    let outputs: Vec<&PathBuf> = args.output.iter().chain(&args.timings).collect();
    for out in &outputs {
        if numbered(out, 0).is_none() {
            return Err(ssbc::Error::InvalidParameter(format!(
                "--sequence writes one file per frame: '{}' needs a frame number such as %03d",
                out.display()
            )));
        }
    }
    let mut renderer = Renderer::new(config)?;
    log_memory(&scene, settings, true);
    let mut resident = ssbc::resident::ResidentScene::new(scene)?;
    let log = renderer.validation_log();
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // Ctrl-C stops after the frame in flight (its files are written).
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed));
    }
    let bar = indicatif::ProgressBar::new(sequence.len() as u64);
    let mut time = args.common.time;
    for k in 0..sequence.len() {
        if let Some(t) = sequence.time(k).map(|t| t as f32) {
            if time != Some(t) {
                show_pose(&mut resident, t)?;
                time = Some(t);
            }
        }
        sequence.apply(k, &mut resident)?;
        let mut frame = renderer.render_resident(&resident, settings)?;
        select_output_layer(&mut frame, args.output_layer)?;
        for out in &args.output {
            let file = numbered(out, k).expect("checked above");
            ssbc::output::write_image(&frame, &file, args.layers, args.common.exposure)?;
        }
        if let Some(out) = &args.timings {
            ssbc::output::write_timings(&frame, &numbered(out, k).expect("checked above"))?;
        }
        bar.suspend(|| {
            log::info!(
                "frame {k}: {} still frame(s) averaged, GPU {:.2} ms",
                frame.accumulated,
                frame.timings.frame_gpu_ms.unwrap_or(f64::NAN)
            )
        });
        bar.inc(1);
        if stop.load(Ordering::Relaxed) {
            break;
        }
    }
    bar.finish_and_clear();
    drop(renderer);
    Ok(log.total())
}

fn reference(args: ReferenceArgs) -> Result<u32, ssbc::Error> {
    // Known before a long render: EXR (linear) or PNG (tonemapped).
    let png = match args
        .output
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => false,
        Some("png") => true,
        _ => {
            return Err(ssbc::Error::InvalidParameter(format!(
                "{}: output must end in .exr or .png",
                args.output.display()
            )))
        }
    };
    let mut scene = load_scene(&args.scene, args.time)?;
    scene.ensure_light();
    let bound = args.bound.resolve(2.0 * scene.bounds().radius());
    let settings = ReferenceSettings {
        width: args.size.0,
        height: args.size.1,
        camera: args.camera,
        spp: args.spp,
        bounces: args.bounces,
        seed: args.seed,
        method: args.method,
        vpl: VplSettings {
            count: args.vpls,
            bounces: args.bounces.max(1),
            seed: args.seed,
            first_path: 0,
        },
        bound,
        antialias: args.antialias,
    };
    let start = std::time::Instant::now();
    let reference = Reference::new(&scene, settings)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = stop.clone();
        // Ctrl-C finishes the current pass and writes what is done.
        let _ = ctrlc::set_handler(move || stop.store(true, Ordering::Relaxed));
    }
    let bar = indicatif::ProgressBar::new(args.spp as u64);
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "{elapsed_precise} [{bar:40}] {pos}/{len} passes, eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    let (rgba, done) = reference.render(&stop, |p| bar.set_position(p as u64));
    bar.finish_and_clear();
    let seconds = start.elapsed().as_secs_f64();
    if png {
        ssbc::output::write_png_tonemapped(&args.output, args.size.0, args.size.1, &rgba, None)?;
    } else {
        ssbc::output::write_exr(&args.output, args.size.0, args.size.1, &rgba, &[])?;
    }
    eprintln!(
        "{:?}: {} of {} passes in {:.2} s ({} VPLs, bound {bound}); wrote {}",
        args.method,
        done,
        args.spp,
        seconds,
        reference.vpls().len(),
        args.output.display()
    );
    Ok(0)
}

fn compare(args: CompareArgs) -> Result<u32, ssbc::Error> {
    let (wa, ha, a) = ssbc::output::read_exr_rgb(&args.a)?;
    let (wb, hb, b) = ssbc::output::read_exr_rgb(&args.b)?;
    if (wa, ha) != (wb, hb) {
        return Err(ssbc::Error::InvalidParameter(format!(
            "image sizes differ: {wa}x{ha} vs {wb}x{hb}"
        )));
    }
    if let Some(path) = &args.heatmap {
        ssbc::compare::write_heatmap(&a, &b, wa, ha, path)?;
    }
    let c = if args.blocks > 1 {
        let blocks = |img: &[f32]| ssbc::compare::block_average(img, wa, ha, args.blocks);
        ssbc::compare::compare(&blocks(&a), &blocks(&b))?
    } else {
        ssbc::compare::compare(&a, &b)?
    };
    let mut text = String::new();
    if args.json {
        text = serde_json::to_string_pretty(&c).expect("serialisable") + "\n";
    } else {
        text += &format!(
            "RMSE {:.6}  relative RMSE {:.4}  relMSE {:.6}  mean ratio A/B {:.4}\n",
            c.rmse, c.relative_rmse, c.rel_mse, c.mean_ratio
        );
        for (name, ch) in ["R", "G", "B"].iter().zip(&c.channels) {
            text += &format!(
                "  {name}: RMSE {:.6}  relMSE {:.6}  mean ratio {:.4}\n",
                ch.rmse, ch.rel_mse, ch.mean_ratio
            );
        }
    }
    // A closed pipe (e.g. `| head`) is not an error worth a panic.
    use std::io::Write as _;
    let _ = std::io::stdout().write_all(text.as_bytes());
    Ok(0)
}

#[cfg(not(feature = "viewer"))]
fn view(_: ViewArgs) -> Result<u32, ssbc::Error> {
    Err(ssbc::Error::InvalidParameter(
        "this ssbc was built without the `viewer` feature (cargo build --features viewer)".into(),
    ))
}

#[cfg(feature = "viewer")]
fn view(args: ViewArgs) -> Result<u32, ssbc::Error> {
    args.common.check()?;
    let scene = load_scene(&args.common.scene, args.common.time)?;
    viewer::run(viewer::ViewOptions {
        scene,
        settings: args.common.settings(),
        validation: args.common.validation(),
        device: args.common.device(),
        exposure: args.common.exposure.unwrap_or(1.0),
        frames: args.frames,
        screenshot: args.screenshot,
        animate: args.animate,
        resize_storm: args.resize_storm,
        source: (args.common.scene.clone(), args.common.time.unwrap_or(0.0)),
    })
}

/// The library names its settings (`ssbc.steps`), the command line its
/// flags (`--steps`): errors are shown in the flags' terms.
const FLAGS: [(&str, &str); 17] = [
    ("ssbc.steps", "--steps"),
    ("ssbc.layers", "--ssbc-layers"),
    ("ssbc.layer1_resolution", "--ssbc-layer1"),
    ("ssbc.layer_separation", "--layer-separation"),
    ("ssbc.min_cos_view", "--min-cos-view"),
    ("ssbc.integration", "--integration"),
    ("ssbc.guard_band", "--guard-band"),
    ("vpl.bounces", "--bounces"),
    ("vpl.count", "--vpls"),
    ("points_per_vpl", "--points-per-vpl"),
    ("shadow_map_size", "--shadow-map-size"),
    ("ism_tile", "--ism-res"),
    ("interleave ", "--interleave "),
    ("gather full", "--gather full"),
    ("camera index ", "--camera "),
    ("render smaller", "render smaller (--size)"),
    ("frames must", "--frames must"),
];

/// [`FLAGS`] applied to an error's message.
fn in_flag_terms(e: ssbc::Error) -> ssbc::Error {
    match e {
        ssbc::Error::InvalidParameter(m) => ssbc::Error::InvalidParameter(
            FLAGS
                .iter()
                .fold(m, |m, (setting, flag)| m.replace(setting, flag)),
        ),
        other => other,
    }
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .target(env_logger::Target::Stderr)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
        Command::Reference(args) => reference(args),
        Command::Compare(args) => compare(args),
        Command::View(args) => view(args),
    };
    match result {
        Ok(0) => ExitCode::SUCCESS,
        Ok(n) => {
            eprintln!("error: Vulkan validation reported {n} message(s)");
            ExitCode::from(3)
        }
        Err(e) => {
            eprintln!("error: {}", in_flag_terms(e));
            ExitCode::FAILURE
        }
    }
}
