//! Image comparison: RMSE, relative MSE, mean-radiance ratio, per channel,
//! and a false-colour error heat map.
//!
//! ```
//! // Two 1x2 RGBA images; the second is the reference.
//! let a = [1.0, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5, 1.0];
//! let b = [1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0];
//! let c = ssbc::compare::compare(&a, &b)?;
//! assert!((c.mean_ratio - 0.75).abs() < 1e-9);
//! assert!((c.rmse - 0.125f64.sqrt()).abs() < 1e-9);
//! # Ok::<(), ssbc::Error>(())
//! ```

use std::path::Path;

use serde::Serialize;

use crate::error::{Error, Result};

/// ε in relMSE = mean((a - b)² / (b² + ε)), as in Rousselle et al.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Error figures of A against reference B.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Comparison {
    /// Root mean squared error over RGB.
    pub rmse: f64,
    /// Mean of (a - b)² / (b² + ε) over RGB.
    pub rel_mse: f64,
    /// Mean radiance of A divided by that of B.
    pub mean_ratio: f64,
    /// RMSE divided by the mean radiance of B (over RGB).
    pub relative_rmse: f64,
    /// Per channel R, G, B: (rmse, rel_mse, mean_ratio).
    pub channels: [ChannelComparison; 3],
}

/// Figures of one channel.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct ChannelComparison {
    /// Root mean squared error.
    pub rmse: f64,
    /// Relative MSE.
    pub rel_mse: f64,
    /// Mean of A / mean of B.
    pub mean_ratio: f64,
}

/// Compares RGBA images `a` and `b` (alpha ignored) of equal size.
pub fn compare(a: &[f32], b: &[f32]) -> Result<Comparison> {
    if a.len() != b.len() || a.is_empty() {
        return Err(Error::InvalidParameter(format!(
            "images differ in size ({} vs {} values)",
            a.len(),
            b.len()
        )));
    }
    let n = (a.len() / 4) as f64;
    let mut ch = Vec::new();
    for c in 0..3 {
        let (mut se, mut rel, mut sa, mut sb) = (0f64, 0f64, 0f64, 0f64);
        for (pa, pb) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
            let (x, y) = (pa[c] as f64, pb[c] as f64);
            se += (x - y).powi(2);
            rel += (x - y).powi(2) / (y * y + REL_MSE_EPSILON);
            sa += x;
            sb += y;
        }
        ch.push(ChannelComparison {
            rmse: (se / n).sqrt(),
            rel_mse: rel / n,
            mean_ratio: sa / sb.max(1e-30),
        });
    }
    let mean = |f: fn(&ChannelComparison) -> f64| ch.iter().map(f).sum::<f64>() / 3.0;
    let sum_a: f64 = a.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum();
    let sum_b: f64 = b.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum();
    let rmse = mean(|c| c.rmse * c.rmse).sqrt();
    Ok(Comparison {
        rmse,
        rel_mse: mean(|c| c.rel_mse),
        mean_ratio: sum_a / sum_b.max(1e-30),
        relative_rmse: rmse / (sum_b / (3.0 * n)).max(1e-30),
        channels: [ch[0].clone(), ch[1].clone(), ch[2].clone()],
    })
}

/// The mean of each `block` x `block` block of an RGBA image (alpha: the
/// mean too); partial blocks at the right and bottom edges average what
/// they hold. Comparing block means measures the error that remains once
/// pixel noise is blurred away.
pub fn block_average(rgba: &[f32], width: u32, height: u32, block: u32) -> Vec<f32> {
    let block = block.max(1);
    let (bw, bh) = (width.div_ceil(block), height.div_ceil(block));
    let mut out = vec![0.0f32; (bw * bh * 4) as usize];
    let mut counts = vec![0u32; (bw * bh) as usize];
    for y in 0..height {
        for x in 0..width {
            let b = ((y / block) * bw + x / block) as usize;
            let p = ((y * width + x) * 4) as usize;
            for c in 0..4 {
                out[b * 4 + c] += rgba[p + c];
            }
            counts[b] += 1;
        }
    }
    for (b, &n) in counts.iter().enumerate() {
        for c in 0..4 {
            out[b * 4 + c] /= n.max(1) as f32;
        }
    }
    out
}

/// Writes a false-colour map of |a - b| / (b + 0.01) (blue 0, red >= 1).
pub fn write_heatmap(a: &[f32], b: &[f32], width: u32, height: u32, path: &Path) -> Result<()> {
    let bytes: Vec<u8> = a
        .chunks_exact(4)
        .zip(b.chunks_exact(4))
        .flat_map(|(pa, pb)| {
            let la = pa[0] + pa[1] + pa[2];
            let lb = pb[0] + pb[1] + pb[2];
            let e = ((la - lb).abs() / (lb + 0.01)).clamp(0.0, 1.0);
            // Blue -> green -> red.
            let (r, g, bl) = if e < 0.5 {
                (0.0, 2.0 * e, 1.0 - 2.0 * e)
            } else {
                (2.0 * e - 1.0, 2.0 - 2.0 * e, 0.0)
            };
            [(r * 255.0) as u8, (g * 255.0) as u8, (bl * 255.0) as u8]
        })
        .collect();
    image::save_buffer(path, &bytes, width, height, image::ExtendedColorType::Rgb8).map_err(|e| {
        Error::Output {
            path: path.display().to_string(),
            message: e.to_string(),
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn block_means_and_relative_rmse() {
        // 3x2 image, blocks of 2: the right column is a partial block.
        let px = |v: f32| [v, v, v, 1.0];
        let img: Vec<f32> = [1.0, 3.0, 5.0, 3.0, 1.0, 7.0]
            .iter()
            .flat_map(|&v| px(v))
            .collect();
        let blocks = block_average(&img, 3, 2, 2);
        assert_eq!(blocks, [2.0, 2.0, 2.0, 1.0, 6.0, 6.0, 6.0, 1.0]);
        let b = vec![1.0f32; 8];
        let a: Vec<f32> = [1.1, 1.1, 1.1, 1.0, 0.9, 0.9, 0.9, 1.0].to_vec();
        let c = compare(&a, &b).unwrap();
        assert!((c.relative_rmse - 0.1).abs() < 1e-6);
        assert!((c.mean_ratio - 1.0).abs() < 1e-6);
    }
}
