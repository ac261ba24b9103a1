//! Mipmaps of the scene's texture arrays, built on the CPU when a scene is
//! uploaded, so that a minified texture shows its mean over each pixel's
//! footprint (what a path tracer that averages over pixels sees) instead
//! of one texel that aliases (`sample_texture` in material.glsl).
//!
//! Each level is the box average of the one above, with fractional
//! weights where a side is odd, computed in floats from the level above
//! (not from its 8-bit rounding): colour in linear light (sRGB decoded,
//! averaged, encoded), linear data as is, and normal maps as unit vectors:
//! a texel stores the direction of the mean of the full-resolution normals
//! it covers. Textures shrunk to their array's size are averaged the same
//! way ([`resize`]), and an array is shrunk to fit [`ARRAY_BUDGET_BYTES`].

use std::sync::LazyLock;

use rayon::prelude::*;

use crate::cpu::shading::srgb_to_linear;

/// sRGB byte to linear, tabulated.
static SRGB_TO_LINEAR: LazyLock<[f32; 256]> =
    LazyLock::new(|| std::array::from_fn(|c| srgb_to_linear(c as u8)));

/// How an array's texels are encoded and averaged.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Texels {
    /// sRGB colour, linear alpha.
    Srgb,
    /// Linear data (metallic-roughness maps).
    Linear,
    /// Tangent-space normals (xyz * 0.5 + 0.5), alpha unused.
    Normals,
}

/// Number of levels of a `width` x `height` image down to 1 x 1.
pub fn level_count(width: u32, height: u32) -> u32 {
    32 - width.max(height).max(1).leading_zeros()
}

/// Size of level `level` of a `width` x `height` image.
pub fn level_extent(width: u32, height: u32, level: u32) -> (u32, u32) {
    ((width >> level).max(1), (height >> level).max(1))
}

/// Most bytes one texture array may take with its mipmaps: every layer has
/// the largest texture's size, so many small textures beside one large one
/// would otherwise multiply it (a hundred 2048x2048 layers: 2.1 GiB).
pub const ARRAY_BUDGET_BYTES: u64 = 1 << 30;

/// The size of an array of `layers` RGBA8 layers whose largest texture is
/// `largest`: halved (both sides) until the array and its mipmaps fit in
/// `budget` bytes. With footprint filtering a smaller top level only
/// blurs textures seen magnified.
pub fn array_extent(largest: (u32, u32), layers: u32, budget: u64) -> (u32, u32) {
    let (mut w, mut h) = largest;
    // Mipmaps add a third.
    let bytes = |w: u32, h: u32| w as u64 * h as u64 * 4 * layers as u64 * 4 / 3;
    while bytes(w, h) > budget && (w > 1 || h > 1) {
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
    }
    (w, h)
}

/// `rgba8` (`from` texels) resized to `to`: a box filter averaged as its
/// mipmaps are (linear light, unit normals) where both sides shrink, else
/// bilinear on the stored values.
pub fn resize(from: (u32, u32), rgba8: &[u8], to: (u32, u32), texels: Texels) -> Vec<u8> {
    if from == to {
        return rgba8.to_vec();
    }
    if to.0 <= from.0 && to.1 <= from.1 {
        let decoded: Vec<[f32; 4]> = rgba8
            .par_chunks_exact(4)
            .map(|c| decode(c, texels))
            .collect();
        return downsample(&decoded, from, to)
            .par_iter()
            .flat_map_iter(|t| encode(*t, texels))
            .collect();
    }
    let img = image::RgbaImage::from_raw(from.0, from.1, rgba8.to_vec())
        .expect("texture size matches its data");
    image::imageops::resize(&img, to.0, to.1, image::imageops::FilterType::Triangle).into_raw()
}

/// Levels 1.. of a `width` x `height` RGBA8 image (level 0 is `rgba8`
/// itself), each `level_extent` in size.
pub fn mip_chain(width: u32, height: u32, rgba8: &[u8], texels: Texels) -> Vec<Vec<u8>> {
    assert_eq!(rgba8.len(), (width * height * 4) as usize);
    let mut current: Vec<[f32; 4]> = rgba8
        .par_chunks_exact(4)
        .map(|c| decode(c, texels))
        .collect();
    let (mut w, mut h) = (width, height);
    let mut levels = Vec::new();
    for level in 1..level_count(width, height) {
        let (dw, dh) = level_extent(width, height, level);
        current = downsample(&current, (w, h), (dw, dh));
        (w, h) = (dw, dh);
        levels.push(
            current
                .par_iter()
                .flat_map_iter(|t| encode(*t, texels))
                .collect(),
        );
    }
    levels
}

fn decode(c: &[u8], texels: Texels) -> [f32; 4] {
    let unorm = |k: usize| c[k] as f32 / 255.0;
    match texels {
        Texels::Srgb => {
            let lut = &*SRGB_TO_LINEAR;
            [
                lut[c[0] as usize],
                lut[c[1] as usize],
                lut[c[2] as usize],
                unorm(3),
            ]
        }
        Texels::Linear => [unorm(0), unorm(1), unorm(2), unorm(3)],
        Texels::Normals => {
            let v = [0, 1, 2].map(|k| unorm(k) * 2.0 - 1.0);
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if len > 0.0 {
                [v[0] / len, v[1] / len, v[2] / len, 1.0]
            } else {
                [0.0, 0.0, 1.0, 1.0]
            }
        }
    }
}

fn encode(t: [f32; 4], texels: Texels) -> [u8; 4] {
    let unorm = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
    match texels {
        Texels::Srgb => [
            linear_to_srgb(t[0]),
            linear_to_srgb(t[1]),
            linear_to_srgb(t[2]),
            unorm(t[3]),
        ],
        Texels::Linear => t.map(unorm),
        Texels::Normals => {
            let len = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
            let d = if len > 0.0 {
                [t[0] / len, t[1] / len, t[2] / len]
            } else {
                [0.0, 0.0, 1.0]
            };
            [
                unorm(d[0] * 0.5 + 0.5),
                unorm(d[1] * 0.5 + 0.5),
                unorm(d[2] * 0.5 + 0.5),
                255,
            ]
        }
    }
}

/// Linear value to 8-bit sRGB.
fn linear_to_srgb(v: f32) -> u8 {
    let v = v.clamp(0.0, 1.0);
    let s = if v <= 0.003_130_8 {
        v * 12.92
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// Box filter of `src` (`from` texels) to `to` texels: each target texel
/// averages the source area it covers, texels cut by its edges weighted by
/// the part inside.
fn downsample(src: &[[f32; 4]], from: (u32, u32), to: (u32, u32)) -> Vec<[f32; 4]> {
    let (xs, ys) = (weights(from.0, to.0), weights(from.1, to.1));
    let mut out = vec![[0.0; 4]; (to.0 * to.1) as usize];
    out.par_chunks_mut(to.0 as usize)
        .zip(&ys)
        .for_each(|(row, wy)| {
            for (texel, wx) in row.iter_mut().zip(&xs) {
                let mut sum = [0.0f32; 4];
                for &(sy, fy) in wy {
                    for &(sx, fx) in wx {
                        let t = src[(sy * from.0 + sx) as usize];
                        for k in 0..4 {
                            sum[k] += fy * fx * t[k];
                        }
                    }
                }
                *texel = sum;
            }
        });
    out
}

/// Per target texel along an axis of `from` -> `to` texels: the source
/// texels it covers and their weights (summing to 1).
fn weights(from: u32, to: u32) -> Vec<Vec<(u32, f32)>> {
    let scale = from as f64 / to as f64;
    (0..to)
        .map(|i| {
            let (a, b) = (i as f64 * scale, (i + 1) as f64 * scale);
            (a.floor() as u32..(b.ceil() as u32).min(from))
                .map(|s| {
                    let inside = (b.min(s as f64 + 1.0) - a.max(s as f64)).max(0.0);
                    (s, (inside / scale) as f32)
                })
                .filter(|&(_, w)| w > 0.0)
                .collect()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_down_to_one_texel() {
        assert_eq!(level_count(1, 1), 1);
        assert_eq!(level_count(2048, 2048), 12);
        assert_eq!(level_count(5, 3), 3);
        assert_eq!(level_extent(5, 3, 1), (2, 1));
        assert_eq!(level_extent(5, 3, 2), (1, 1));
        let chain = mip_chain(5, 3, &[7; 60], Texels::Linear);
        assert_eq!(chain.iter().map(Vec::len).collect::<Vec<_>>(), [8, 4]);
        assert!(chain.iter().flatten().all(|&t| t == 7));
    }

    #[test]
    fn arrays_shrink_to_their_budget() {
        // 100 layers of 2048^2 with mipmaps: 2.2 GB; 1024^2: 559 MB.
        assert_eq!(
            array_extent((2048, 2048), 100, ARRAY_BUDGET_BYTES),
            (1024, 1024)
        );
        assert_eq!(
            array_extent((2048, 1024), 3, ARRAY_BUDGET_BYTES),
            (2048, 1024)
        );
        assert_eq!(array_extent((2048, 2), 1, 1), (1, 1));
    }

    #[test]
    fn shrinking_averages_like_the_mipmaps() {
        let texels = [0, 0, 0, 255, 255, 255, 255, 255, 0, 0, 0, 255];
        // 3 texels to 2: (2/3 black + 1/3 white), (1/3 white + 2/3 black) in linear light.
        let out = resize((3, 1), &texels, (2, 1), Texels::Srgb);
        assert_eq!(out, [156, 156, 156, 255, 156, 156, 156, 255]);
        assert_eq!(resize((3, 1), &texels, (3, 1), Texels::Srgb), texels);
        assert_eq!(
            resize((1, 1), &[9, 9, 9, 9], (2, 2), Texels::Linear).len(),
            16
        );
    }

    #[test]
    fn odd_sides_weigh_every_texel_by_its_coverage() {
        // 3 texels to 1: each a third; 3 to 2: 2/3 + 1/3 and 1/3 + 2/3.
        let w = weights(3, 2);
        assert_eq!(w[0].len(), 2);
        assert!((w[0][0].1 - 2.0 / 3.0).abs() < 1e-6 && (w[0][1].1 - 1.0 / 3.0).abs() < 1e-6);
        assert!((w[1][0].1 - 1.0 / 3.0).abs() < 1e-6 && w[1][0].0 == 1);
        for (from, to) in [(3, 1), (5, 2), (2048, 1024), (7, 3)] {
            for texel in weights(from, to) {
                let sum: f32 = texel.iter().map(|w| w.1).sum();
                assert!((sum - 1.0).abs() < 1e-5, "{from} -> {to}: {sum}");
            }
        }
    }

    #[test]
    fn colour_is_averaged_in_linear_light() {
        // Black and white texels average to half the light: sRGB 188, not 128.
        let chain = mip_chain(2, 1, &[0, 0, 0, 0, 255, 255, 255, 255], Texels::Srgb);
        assert_eq!(chain[0], [188, 188, 188, 128]);
    }

    #[test]
    fn normals_average_as_unit_vectors() {
        // Normals tilted 60 degrees either way along x, one stored short:
        // their mean points straight up.
        let encode = |v: [f32; 3]| v.map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8);
        let (a, b) = (encode([0.866, 0.0, 0.5]), encode([-0.433, 0.0, 0.25]));
        let texels = [a[0], a[1], a[2], 9, b[0], b[1], b[2], 9];
        let chain = mip_chain(2, 1, &texels, Texels::Normals);
        let t = &chain[0];
        assert!(
            (t[0] as i32 - 128).abs() <= 1 && (t[1] as i32 - 128).abs() <= 1,
            "{t:?}"
        );
        assert_eq!((t[2], t[3]), (255, 255));
    }
}
