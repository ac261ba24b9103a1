//! The interleaved bounded gather against the full one with the same VPLs:
//! relative RMSE and mean ratio of `indirect_bounded`, over every geometry
//! pixel and separately over discontinuity pixels (whose filter window
//! holds a pixel of another surface) and the rest. Shared by
//! `tests/interleaved.rs` and `examples/gather_accuracy.rs` (by path).

#![allow(dead_code)]

use glam::Vec3;
use ssbc::passes::indirect_bounded::{FILTER_NORMAL_COS, FILTER_PLANE_SLOPE};
use ssbc::renderer::{Frame, RenderSettings, Renderer};
use ssbc::settings::Gather;
use ssbc::Scene;

/// Error figures of one set of pixels.
#[derive(Clone, Copy, Debug, Default)]
pub struct Figures {
    /// Pixels in the set.
    pub pixels: usize,
    /// RMSE over the set (RGB) / mean radiance of the full gather over it.
    pub relative_rmse: f64,
    /// Mean radiance, interleaved / full.
    pub mean_ratio: f64,
}

/// One comparison.
pub struct GatherComparison {
    pub all: Figures,
    pub discontinuity: Figures,
    pub continuous: Figures,
    /// GPU ms of `indirect_bounded`: full, then interleaved (gather, filter).
    pub full_ms: f64,
    pub interleaved_ms: (f64, f64, f64),
    pub full: Frame,
    pub interleaved: Frame,
}

fn figures(a: &[f32], b: &[f32], pixels: impl Iterator<Item = usize>) -> Figures {
    let (mut n, mut se, mut sa, mut sb) = (0usize, 0f64, 0f64, 0f64);
    for p in pixels {
        for c in 0..3 {
            let (x, y) = (a[p * 4 + c] as f64, b[p * 4 + c] as f64);
            se += (x - y).powi(2);
            sa += x;
            sb += y;
        }
        n += 1;
    }
    let mean = sb / (3 * n.max(1)) as f64;
    Figures {
        pixels: n,
        relative_rmse: (se / (3 * n.max(1)) as f64).sqrt() / mean.max(1e-30),
        mean_ratio: sa / sb.max(1e-30),
    }
}

/// Whether pixel `q` lies on pixel `p`'s surface (the filter's test).
fn same_surface(position: &[f32], normal: &[f32], p: usize, q: usize) -> bool {
    let v = |img: &[f32], i: usize| Vec3::new(img[i * 4], img[i * 4 + 1], img[i * 4 + 2]);
    if position[q * 4 + 3] == 0.0 {
        return false;
    }
    let n = v(normal, p);
    let d = v(position, q) - v(position, p);
    d.dot(n).abs() <= FILTER_PLANE_SLOPE * d.length() && n.dot(v(normal, q)) >= FILTER_NORMAL_COS
}

/// Geometry pixels whose window of `reach` pixels holds a pixel of another
/// surface (or the image's edge).
pub fn discontinuity_mask(frame: &Frame, reach: i32) -> Vec<bool> {
    let position = &frame
        .layer(ssbc::Layer::GBufferPosition)
        .expect("debug readback")
        .rgba;
    let normal = &frame
        .layer(ssbc::Layer::GBufferNormal)
        .expect("debug readback")
        .rgba;
    let (w, h) = (frame.width as i32, frame.height as i32);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if position[i as usize * 4 + 3] == 0.0 {
                return false;
            }
            (-reach..=reach).any(|dy| {
                (-reach..=reach).any(|dx| {
                    let (qx, qy) = (x + dx, y + dy);
                    if qx < 0 || qy < 0 || qx >= w || qy >= h {
                        return true;
                    }
                    !same_surface(position, normal, i as usize, (qy * w + qx) as usize)
                })
            })
        })
        .collect()
}

/// Renders `scene` with the full and the interleaved gather (same VPLs, no
/// SSBC steps) and compares `indirect_bounded`.
pub fn compare_gathers(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
) -> GatherComparison {
    let mut s = settings.clone();
    s.ssbc.steps = 0;
    s.debug_readback = true;
    s.gather = Gather::Full;
    let full = renderer.render(scene, &s).expect("full gather");
    s.gather = Gather::Interleaved;
    let interleaved = renderer.render(scene, &s).expect("interleaved gather");
    let a = &interleaved
        .layer(ssbc::Layer::IndirectBounded)
        .expect("layer")
        .rgba;
    let b = &full
        .layer(ssbc::Layer::IndirectBounded)
        .expect("layer")
        .rgba;
    let edge = discontinuity_mask(&full, settings.interleave as i32 - 1);
    let geometry: Vec<usize> = (0..edge.len())
        .filter(|&p| full.image.rgba[p * 4 + 3] != 0.0)
        .collect();
    let ms = |f: &Frame, name: &str| f.timings.pass_ms(name).unwrap_or(f64::NAN);
    GatherComparison {
        all: figures(a, b, geometry.iter().copied()),
        discontinuity: figures(a, b, geometry.iter().copied().filter(|&p| edge[p])),
        continuous: figures(a, b, geometry.iter().copied().filter(|&p| !edge[p])),
        full_ms: ms(&full, "indirect_bounded"),
        interleaved_ms: (
            ms(&interleaved, "indirect_bounded"),
            ms(&interleaved, "indirect_bounded/gather"),
            ms(&interleaved, "indirect_bounded/filter"),
        ),
        full,
        interleaved,
    }
}

/// Emulation for tuning: the interleaved image with the pixels of `mask`
/// taken from the full gather.
pub fn with_full_where(c: &GatherComparison, mask: &[bool]) -> (Figures, usize) {
    let mut a = c
        .interleaved
        .layer(ssbc::Layer::IndirectBounded)
        .expect("layer")
        .rgba
        .clone();
    let b = &c
        .full
        .layer(ssbc::Layer::IndirectBounded)
        .expect("layer")
        .rgba;
    let mut count = 0;
    for (p, &m) in mask.iter().enumerate() {
        if m {
            a[p * 4..p * 4 + 4].copy_from_slice(&b[p * 4..p * 4 + 4]);
            count += 1;
        }
    }
    let geometry = (0..mask.len()).filter(|&p| b[p * 4 + 3] != 0.0);
    (figures(&a, b, geometry), count)
}

/// Geometry pixels with a pixel of another surface within `reach` pixels
/// that is also near in space (within `footprints` x the pixel's footprint,
/// the distance to its nearest neighbour on its own surface): creases and
/// contacts, not silhouettes against something far behind.
pub fn crease_mask(frame: &Frame, reach: i32, footprints: f32) -> Vec<bool> {
    let position = &frame
        .layer(ssbc::Layer::GBufferPosition)
        .expect("debug readback")
        .rgba;
    let normal = &frame
        .layer(ssbc::Layer::GBufferNormal)
        .expect("debug readback")
        .rgba;
    let (w, h) = (frame.width as i32, frame.height as i32);
    let v = |i: usize| Vec3::new(position[i * 4], position[i * 4 + 1], position[i * 4 + 2]);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let p = i as usize;
            if position[p * 4 + 3] == 0.0 {
                return false;
            }
            let mut footprint = f32::INFINITY;
            let mut near_other = f32::INFINITY;
            for dy in -reach..=reach {
                for dx in -reach..=reach {
                    let (qx, qy) = (x + dx, y + dy);
                    if (dx, dy) == (0, 0) || qx < 0 || qy < 0 || qx >= w || qy >= h {
                        continue;
                    }
                    let q = (qy * w + qx) as usize;
                    if position[q * 4 + 3] == 0.0 {
                        continue;
                    }
                    let d = (v(q) - v(p)).length() / ((dx * dx + dy * dy) as f32).sqrt();
                    if same_surface(position, normal, p, q) {
                        footprint = footprint.min(d);
                    } else {
                        near_other = near_other.min(d);
                    }
                }
            }
            near_other <= footprints * footprint
        })
        .collect()
}
