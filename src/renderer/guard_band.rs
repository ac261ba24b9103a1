//! The guard band (`ssbc.guard_band`): SSBC's sources just outside the
//! image. G > b needs d < 1/sqrt(b), so a surface outside the view can
//! only light a visible one if it lies within that distance of it; seen at
//! the nearest visible depth, 1/sqrt(b) spans `margin` pixels. The frame is
//! rendered over a view widened by that margin on every side (the same
//! pixels, more of them; every pass sees the wider image) and cropped back
//! to the image asked for: the band's pixels are sources, and the
//! receivers there are computed and dropped.

use crate::error::{Error, Result};
use crate::scene::Scene;
use crate::scene_cache::SceneCache;
use crate::settings::RenderSettings;
use crate::vk::Device;

/// Rays across the image (per side, at most) that find the nearest visible
/// depth: fewer would miss what a very wide image shows in a few columns
/// (measured: docs/accuracy.md, "Tuned constants").
const DEPTH_PROBES: u32 = 128;

/// A frame rendered `margin` pixels wider on every side than the image it
/// hands back.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct GuardBand {
    /// Pixels added on each side (a multiple of 16, see `size`).
    pub margin: u32,
}

impl GuardBand {
    /// The band for `settings` (None when it is off, SSBC does not run or
    /// nothing is in view): 1/sqrt(b) at the nearest depth the camera sees
    /// (probed on a grid of up to 128 x 128 rays through the CPU BVH), at most half the
    /// image's shorter side (at most 4x the pixels; a camera against a wall
    /// would otherwise ask for thousands).
    pub fn size(
        scene: &Scene,
        settings: &RenderSettings,
        cache: &SceneCache,
    ) -> Result<Option<Self>> {
        if !settings.ssbc.guard_band || settings.ssbc.steps == 0 {
            return Ok(None);
        }
        // The widest band a converging view takes, so that its frames keep
        // one size.
        let b = settings.bound.widest().resolve(cache.diagonal());
        let reach = b.sqrt().recip();
        if reach.is_nan() || reach <= 0.0 {
            return Ok(None); // b = inf: nothing is clamped
        }
        let camera = scene.camera(settings.camera)?;
        let (w, h) = (settings.width, settings.height);
        let probes = |n: u32, side: u32| {
            (0..n).map(move |k| (k as f32 + 0.5) * side as f32 / n as f32 - 0.5)
        };
        let mut nearest = f32::INFINITY;
        for y in probes(DEPTH_PROBES.min(h), h) {
            for x in probes(DEPTH_PROBES.min(w), w) {
                let dir = camera.pixel_ray(x, y, w, h);
                if let Some(hit) = cache.bvh.intersect_camera(scene, camera.position, dir) {
                    nearest = nearest.min(hit.t * dir.dot(camera.forward));
                }
            }
        }
        if !nearest.is_finite() {
            return Ok(None);
        }
        let pixel_side = 2.0 * (camera.yfov * 0.5).tan() / h as f32;
        let cap = w.min(h) / 2;
        let wanted = reach / (nearest.max(1e-6) * pixel_side);
        let margin = if wanted >= cap as f32 {
            cap
        } else {
            wanted.ceil() as u32
        };
        // A multiple of 16: the evaluation points (at most level 4) stay on
        // the same image pixels, and a half-resolution second layer's pixels
        // on the same pairs.
        let margin = margin.div_ceil(16) * 16;
        log::info!(
            "guard band: {margin} pixels each side (1/sqrt(b) = {reach:.3} at the nearest visible depth {nearest:.3}{})",
            if wanted > cap as f32 { ", capped at half the shorter side" } else { "" }
        );
        Ok((margin > 0).then_some(Self { margin }))
    }

    /// The band `settings` ask for, and the settings every pass of the frame
    /// renders with then (the wider frame's, checked against the device).
    pub fn widen_frame(
        device: &Device,
        scene: &Scene,
        settings: &RenderSettings,
        cache: &SceneCache,
        uses: super::limits::FrameUse,
    ) -> Result<(Option<Self>, Option<RenderSettings>)> {
        let Some(band) = Self::size(scene, settings, cache)? else {
            return Ok((None, None));
        };
        let wide = band.widen(settings);
        super::limits::check_settings(device, &wide, scene.lights.len(), uses).map_err(|e| {
            let why = match e {
                Error::InvalidParameter(why) => why,
                other => other.to_string(),
            };
            Error::InvalidParameter(format!(
                "the guard band ({} pixels each side) makes the frame {}x{}: {why}; or render without the guard band",
                band.margin, wide.width, wide.height
            ))
        })?;
        Ok((Some(band), Some(wide)))
    }

    /// The settings of the wider frame.
    pub fn widen(self, settings: &RenderSettings) -> RenderSettings {
        let mut wide = settings.clone();
        wide.width += 2 * self.margin;
        wide.height += 2 * self.margin;
        wide
    }

    /// The vertical field of view of the wider frame whose image (of
    /// `height` pixels) is seen with `yfov`: the same pixel size.
    pub fn widen_yfov(self, yfov: f32, height: u32) -> f32 {
        let grow = (height + 2 * self.margin) as f32 / height as f32;
        2.0 * ((yfov * 0.5).tan() * grow).atan()
    }

    /// Crops `data` (`channels` floats per pixel) of the wider frame, or of
    /// its half-resolution second layer, to the image's `extent` (the
    /// resolution is told by the length).
    pub fn crop(self, data: &[f32], channels: usize, extent: (u32, u32)) -> Vec<f32> {
        let wide = (extent.0 + 2 * self.margin, extent.1 + 2 * self.margin);
        let half = |n: u32| n.div_ceil(2);
        let (src_w, origin, (w, h)) = if data.len() == (wide.0 * wide.1) as usize * channels {
            (wide.0, self.margin, extent)
        } else {
            (
                half(wide.0),
                self.margin / 2,
                (half(extent.0), half(extent.1)),
            )
        };
        let (src_w, origin) = (src_w as usize, origin as usize);
        let mut out = Vec::with_capacity((w * h) as usize * channels);
        for y in 0..h as usize {
            let start = ((y + origin) * src_w + origin) * channels;
            out.extend_from_slice(&data[start..start + w as usize * channels]);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;
    use glam::Vec3;

    /// The wider frame's pixel at (m + x, m + y) looks where the image's
    /// pixel (x, y) does.
    #[test]
    fn the_wider_view_keeps_every_pixel_direction() {
        let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.3, 0.1, -1.0), 0.7);
        let band = GuardBand { margin: 40 };
        let (w, h) = (160, 120);
        let mut wide = camera.clone();
        wide.yfov = band.widen_yfov(camera.yfov, h);
        for (x, y) in [(0.0, 0.0), (159.0, 0.0), (80.0, 60.0), (13.5, 119.0)] {
            let a = camera.pixel_ray(x, y, w, h);
            let b = wide.pixel_ray(x + 40.0, y + 40.0, w + 80, h + 80);
            assert!((a - b).length() < 1e-5, "{a} vs {b} at ({x}, {y})");
        }
    }

    #[test]
    fn crop_takes_the_image_out_of_the_wider_frame() {
        let band = GuardBand { margin: 2 };
        let (w, h) = (3u32, 2u32);
        // Full resolution: 7 x 6, one channel holding y * 10 + x.
        let full: Vec<f32> = (0..6)
            .flat_map(|y| (0..7).map(move |x| (y * 10 + x) as f32))
            .collect();
        assert_eq!(
            band.crop(&full, 1, (w, h)),
            vec![22.0, 23.0, 24.0, 32.0, 33.0, 34.0]
        );
        // Half resolution: 4 x 3 holds the image's 2 x 1 at (1, 1).
        let half: Vec<f32> = (0..3)
            .flat_map(|y| (0..4).map(move |x| (y * 10 + x) as f32))
            .collect();
        assert_eq!(band.crop(&half, 1, (w, h)), vec![11.0, 12.0]);
    }
}
