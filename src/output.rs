//! Writing frames: EXR (32-bit float linear RGB, optionally with named
//! layers as `layer.R/G/B` channels), PNG (tonemapped sRGB) and the timings
//! JSON.

use std::path::Path;

use exr::prelude::*;

use crate::error::{Error, Result};
use crate::renderer::{Frame, LayerImage};

fn output_err(path: &Path, message: impl ToString) -> Error {
    Error::Output {
        path: path.display().to_string(),
        message: message.to_string(),
    }
}

/// Writes `frame` to `path`: `.exr` (linear, with the component layers when
/// `with_layers`) or `.png` (tonemapped: `exposure`, or one chosen from the
/// image when None, then a filmic curve; see [`write_png_tonemapped`]).
pub fn write_image(
    frame: &Frame,
    path: &Path,
    with_layers: bool,
    exposure: Option<f32>,
) -> Result<()> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .as_deref()
    {
        Some("exr") => {
            let extra: &[LayerImage] = if with_layers { &frame.layers } else { &[] };
            write_exr(path, frame.width, frame.height, &frame.image.rgba, extra)
        }
        Some("png") => {
            write_png_tonemapped(path, frame.width, frame.height, &frame.image.rgba, exposure)
        }
        _ => Err(output_err(path, "output must end in .exr or .png")),
    }
}

/// Writes `rgba` (`width * height` pixels) as the default R,G,B channels
/// and each of `layers` (the same size) as `name.R`, `name.G`, `name.B`,
/// all 32-bit float.
pub fn write_exr(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[f32],
    layers: &[LayerImage],
) -> Result<()> {
    let pixels = width as usize * height as usize;
    if rgba.len() != pixels * 4 || layers.iter().any(|l| l.rgba.len() != pixels * 4) {
        return Err(output_err(
            path,
            format!("layers of {width}x{height} pixels expected"),
        ));
    }
    let channel = |name: String, rgba: &[f32], c: usize| {
        let samples: Vec<f32> = rgba.chunks_exact(4).map(|p| p[c]).collect();
        AnyChannel::new(name.as_str(), FlatSamples::F32(samples))
    };
    let mut channels = Vec::new();
    for (c, n) in ["R", "G", "B"].iter().enumerate() {
        channels.push(channel(n.to_string(), rgba, c));
        for l in layers {
            channels.push(channel(format!("{}.{n}", l.layer), &l.rgba, c));
        }
    }
    let layer = exr::image::Layer::new(
        (width as usize, height as usize),
        LayerAttributes::named("ssbc"),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(channels.into()),
    );
    Image::from_layer(layer)
        .write()
        .to_file(path)
        .map_err(|e| output_err(path, e))
}

/// Linear to sRGB transfer function.
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.0031308 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// Writes linear RGBA radiance as an 8-bit sRGB PNG, scaled by `exposure`
/// and clamped (what the viewer shows).
pub fn write_png(path: &Path, width: u32, height: u32, rgba: &[f32], exposure: f32) -> Result<()> {
    let bytes: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| {
            let q = |v: f32| (srgb_encode((v * exposure).clamp(0.0, 1.0)) * 255.0 + 0.5) as u8;
            [q(p[0]), q(p[1]), q(p[2])]
        })
        .collect();
    image::save_buffer(path, &bytes, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| output_err(path, e))
}

/// The exposure that maps the log-average luminance of the pixels with
/// geometry (alpha > 0; all pixels if none) to the middle grey 0.18
/// (Reinhard et al. 2002's key value). Luminances count as at least a
/// hundredth of the 95th percentile's: near-black pixels (a dark visor
/// mirroring the empty background, grooves) pulled the log-average down
/// and a helmet-like asset came out white (exposure 25 instead of 2.8, a
/// third of its pixels past twice the white point); scenes without such
/// pixels (cornell, tori, the studio) keep their exposure.
pub fn auto_exposure(rgba: &[f32]) -> f32 {
    // Finite luminances of the pixels `keep` selects.
    let luminances = |keep: fn(&[f32]) -> bool| -> Vec<f32> {
        rgba.chunks_exact(4)
            .filter(|p| keep(p))
            .map(|p| (0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]).max(0.0))
            .filter(|l| l.is_finite())
            .collect()
    };
    let mut geometry = luminances(|p| p[3] > 0.0);
    if geometry.is_empty() {
        geometry = luminances(|_| true);
    }
    if geometry.is_empty() {
        return 1.0;
    }
    let k = (geometry.len() - 1) * 95 / 100;
    let p95 = *geometry.select_nth_unstable_by(k, f32::total_cmp).1;
    let floor = (0.01 * p95 as f64).max(1e-6);
    let log_sum: f64 = geometry.iter().map(|&l| (l as f64).max(floor).ln()).sum();
    let average = (log_sum / geometry.len() as f64).exp();
    if average > 1e-5 && average.is_finite() {
        (0.18 / average) as f32
    } else {
        1.0
    }
}

/// The filmic curve of the PNG output (Narkowicz's fit of ACES): maps
/// [0, inf) to [0, 1) with a toe and a soft shoulder, so highlights roll off
/// instead of clipping.
pub fn filmic(x: f32) -> f32 {
    let x = x.max(0.0);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

/// Writes linear RGBA radiance as an 8-bit sRGB PNG: scaled by `exposure`
/// (None: [`auto_exposure`]), then [`filmic`]. The EXR output stays linear.
pub fn write_png_tonemapped(
    path: &Path,
    width: u32,
    height: u32,
    rgba: &[f32],
    exposure: Option<f32>,
) -> Result<()> {
    let exposure = exposure.unwrap_or_else(|| auto_exposure(rgba));
    let bytes: Vec<u8> = rgba
        .chunks_exact(4)
        .flat_map(|p| {
            let q = |v: f32| (srgb_encode(filmic(v * exposure)) * 255.0 + 0.5) as u8;
            [q(p[0]), q(p[1]), q(p[2])]
        })
        .collect();
    image::save_buffer(path, &bytes, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| output_err(path, e))
}

/// Writes the timings JSON.
pub fn write_timings(frame: &Frame, path: &Path) -> Result<()> {
    let json = serde_json::to_string_pretty(&frame.timings).map_err(|e| output_err(path, e))?;
    std::fs::write(path, json + "\n").map_err(|e| Error::io(path, e))
}

/// The timings as a printable table.
pub fn timings_table(frame: &Frame) -> String {
    let t = &frame.timings;
    let mut s = format!("GPU timings on {} at {}x{}\n", t.device, t.width, t.height);
    match (&t.passes, t.frame_gpu_ms) {
        (Some(passes), Some(frame_ms)) => {
            for p in passes {
                s += &format!("  {:<24} {:>10.3} ms\n", p.name, p.gpu_ms);
            }
            s += &format!("  {:<24} {:>10.3} ms\n", "frame", frame_ms);
        }
        _ => s += "  (no GPU timestamps: passes were not timed)\n",
    }
    for (k, step) in t.ssbc_steps.iter().enumerate() {
        s += &format!(
            "  ssbc step {}: {:.1} samples/pixel on average, {:.0} at most (eval level {}, {:.1}% of pixels evaluated alone)\n",
            k + 1,
            step.samples_per_pixel_avg,
            step.samples_per_pixel_max,
            step.eval_level,
            step.fallback_fraction * 100.0
        );
    }
    s += &format!(
        "  CPU: BVH {:.1} ms, {} VPLs from {} light paths ({:.1} per path, at most {}) {:.1} ms, ISM points {:.1} ms, ISM rays {:.1} ms; bound b = {}\n",
        t.cpu_ms.bvh_build,
        t.vpl_count,
        t.light_paths,
        t.vpl_count as f64 / t.light_paths.max(1) as f64,
        t.max_vpls_per_light_path,
        t.cpu_ms.vpl_generation,
        t.cpu_ms.point_sampling,
        t.cpu_ms.ism_rays,
        t.bound
    );
    let pixels = t.width as u64 * t.height as u64;
    s += &format!(
        "  device memory: {:.1} MiB ({:.0} bytes per pixel) in all\n",
        t.device_memory_bytes as f64 / (1 << 20) as f64,
        t.device_memory_bytes as f64 / pixels.max(1) as f64
    );
    s += &format!(
        "  a frame slot: estimated {}\n  measured ({} slot{}): {}\n",
        t.memory.estimated.summary(pixels),
        t.memory.slots,
        if t.memory.slots == 1 { "" } else { "s" },
        t.memory.measured.summary(pixels)
    );
    if t.emission_w > 0.0 {
        s += &format!(
            "  emitters: {:.3} W emitted, of which {:.3} W ({:.1}%) into solids, left out of light tracing\n",
            t.emission_w,
            t.enclosed_emission_w,
            100.0 * t.enclosed_emission_w / t.emission_w
        );
    }
    s
}

/// Reads an EXR's R, G, B channels into RGBA (alpha 1) with its size.
pub fn read_exr_rgb(path: &Path) -> Result<(u32, u32, Vec<f32>)> {
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![0f32; res.width() * res.height() * 4]),
        |(w, buf), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            let i = (pos.y() * *w + pos.x()) * 4;
            buf[i..i + 4].copy_from_slice(&[r, g, b, 1.0]);
        },
    )
    .map_err(|e| Error::Scene {
        path: path.display().to_string(),
        message: format!("cannot read EXR: {e}"),
    })?;
    let size = image.layer_data.size;
    Ok((
        size.width() as u32,
        size.height() as u32,
        image.layer_data.channel_data.pixels.1,
    ))
}

/// Every channel of every layer of an EXR (`layer/channel`, or the
/// channel's name, `residual_1.R` say, in a layer without a name), as f32,
/// sorted by name.
pub fn read_exr_channels(path: &Path) -> Result<Vec<(String, Vec<f32>)>> {
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .from_file(path)
        .map_err(|e| Error::Scene {
            path: path.display().to_string(),
            message: format!("cannot read EXR: {e}"),
        })?;
    let mut out = Vec::new();
    for layer in &image.layer_data {
        let prefix = match &layer.attributes.layer_name {
            Some(name) => format!("{name}/"),
            None => String::new(),
        };
        for channel in &layer.channel_data.list {
            let name = format!("{prefix}{}", channel.name);
            out.push((name, channel.sample_data.values_as_f32().collect()));
        }
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::auto_exposure;

    fn image(luminances: &[f32]) -> Vec<f32> {
        luminances.iter().flat_map(|&l| [l, l, l, 1.0]).collect()
    }

    /// Middle grey at the log-average luminance; near-black pixels count as
    /// a hundredth of the 95th percentile, so that half an image of them
    /// does not overexpose the other half 18x (the old floor, 1e-6, gave
    /// 18; this gives 1.8).
    #[test]
    fn near_black_pixels_do_not_overexpose_the_rest() {
        let uniform = auto_exposure(&image(&[0.5; 16]));
        assert!((uniform - 0.36).abs() < 1e-4, "{uniform}");
        let half_black: Vec<f32> = (0..16)
            .map(|i| if i % 2 == 0 { 1e-4 } else { 1.0 })
            .collect();
        let e = auto_exposure(&image(&half_black));
        assert!((e - 1.8).abs() < 0.01, "{e}");
    }
}
