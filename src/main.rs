//! The `ssbc` command line.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Parser, Subcommand};

use ssbc::renderer::{RenderSettings, Renderer, RendererConfig};
use ssbc::vk::DeviceSelector;

#[derive(Parser)]
#[command(name = "ssbc", version, about = "Screen-Space Bias Compensation for VPL global illumination, on Vulkan")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene headless and write the image.
    Render(RenderArgs),
}

/// Parses `WxH`.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WxH"))?;
    let w: u32 = w.trim().parse().map_err(|_| format!("bad width in '{s}'"))?;
    let h: u32 = h.trim().parse().map_err(|_| format!("bad height in '{s}'"))?;
    if w == 0 || h == 0 {
        return Err(format!("size {w}x{h} is empty"));
    }
    Ok((w, h))
}

#[derive(clap::Args)]
struct RenderArgs {
    /// Scene: a .gltf/.glb path or a built-in name (cornell, tori).
    #[arg(default_value = "cornell")]
    scene: String,
    /// Image size.
    #[arg(long, default_value = "1024x768", value_parser = parse_size)]
    size: (u32, u32),
    /// Output image: .exr (32-bit float linear RGB) or .png (tonemapped sRGB).
    #[arg(short, long, default_value = "out.exr")]
    output: PathBuf,
    /// Also write the component layers into the EXR as named channels.
    #[arg(long)]
    layers: bool,
    /// Write per-pass GPU timings as JSON.
    #[arg(long, value_name = "FILE.json")]
    timings: Option<PathBuf>,
    /// Camera index (default: the scene's first camera, or one framing the scene).
    #[arg(long)]
    camera: Option<usize>,
    /// Shadow-map resolution (texels per side).
    #[arg(long, default_value_t = 1024)]
    shadow_map_size: u32,
    /// Exposure multiplier for PNG output.
    #[arg(long, default_value_t = 1.0)]
    exposure: f32,
    /// Enable Vulkan validation (also: SSBC_VALIDATION=1); any message makes the exit status non-zero.
    #[arg(long)]
    validate: bool,
    /// Use the device whose name contains this (case-insensitive).
    #[arg(long, value_name = "NAME")]
    device: Option<String>,
}

fn validation_from_env() -> bool {
    std::env::var("SSBC_VALIDATION").is_ok_and(|v| v != "0" && !v.is_empty())
}

fn render(args: RenderArgs) -> Result<u32, ssbc::Error> {
    let mut scene = ssbc::scene::load(&args.scene)?;
    scene.ensure_light();
    let config = RendererConfig {
        validation: args.validate || validation_from_env(),
        device: DeviceSelector { name_contains: args.device.clone() },
    };
    let settings = RenderSettings {
        width: args.size.0,
        height: args.size.1,
        camera: args.camera,
        shadow_map_size: args.shadow_map_size,
    };
    let mut renderer = Renderer::new(&config)?;
    let log = renderer.validation_log();
    let frame = renderer.render(&scene, &settings);
    drop(renderer);
    let frame = frame?;
    ssbc::output::write_image(&frame, &args.output, args.layers, args.exposure)?;
    log::info!("wrote {}", args.output.display());
    if let Some(path) = &args.timings {
        ssbc::output::write_timings(&frame, path)?;
    }
    eprint!("{}", ssbc::output::timings_table(&frame));
    Ok(log.total())
}

fn main() -> ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .target(env_logger::Target::Stderr)
        .init();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render(args),
    };
    match result {
        Ok(0) => ExitCode::SUCCESS,
        Ok(n) => {
            eprintln!("error: Vulkan validation reported {n} message(s)");
            ExitCode::from(3)
        }
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
