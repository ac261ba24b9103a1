//! The recording of the SSBC pyramids: the geometry pyramid (once per
//! frame) and the radiance pyramid (once per step) of each G-buffer layer.

use super::push::{FrameBlock, GeometryBasePush, GeometryMipsPush, RadiancePush};
use super::{SsbcFrame, SsbcGBuffer, SsbcPass};
use crate::error::Result;
use crate::shaders::{ssbc_geometry_base_comp, ssbc_geometry_mips_comp, ssbc_radiance_mips_comp};
use crate::vk::{DescriptorPool, Image, Recorder, Work};

impl SsbcPass {
    /// The geometry pyramid of layer `mips.layer` from its G-buffer (with
    /// both layers' positions, which level 0's texels read); `mips`
    /// holds the frame and thresholds (its level is set here), `principal`
    /// the camera's [`super::SsbcCamera::principal`].
    pub(super) fn record_geometry(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        (gbuffer, level0): (SsbcGBuffer<'_>, [&Image; 2]),
        mips: GeometryMipsPush,
        principal: glam::Vec2,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let layer = mips.layer;
        for level in 0..frame.levels - Self::layer_shift(frame, layer) {
            let texels = Work::pixels(Self::level_extent(frame, layer, level));
            if level == 0 {
                let bindings = ssbc_geometry_base_comp::Bindings {
                    geo_words: &frame.geo,
                    g_position: gbuffer.position,
                    g_normal: gbuffer.normal,
                    g_albedo: gbuffer.albedo,
                    // Bound but not read without geometric normals (an
                    // RGBA32F image, as the shader declares it).
                    g_geometric: gbuffer.geometric.unwrap_or(gbuffer.position),
                };
                let push = GeometryBasePush {
                    frame: mips.frame,
                    layer,
                    geometric: u32::from(gbuffer.geometric.is_some()),
                    principal: principal.into(),
                };
                self.geometry_base
                    .dispatch(rec, pool, &bindings, &push, texels)?;
            } else {
                let bindings = ssbc_geometry_mips_comp::Bindings {
                    geo_words: &frame.geo,
                    aux_words: &frame.aux,
                    level0_position0: level0[0],
                    level0_position1: level0[1],
                };
                let push = GeometryMipsPush { level, ..mips };
                self.geometry.dispatch(rec, pool, &bindings, &push, texels)?;
            }
        }
        Ok(())
    }

    /// The radiance pyramid of the term `term` (`S_{k-1}` at layer
    /// `layer`'s pixels).
    pub(super) fn record_radiance_mips(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        term: &Image,
        layer: u32,
        frame_block: FrameBlock,
        frame: &SsbcFrame,
    ) -> Result<()> {
        for level in 0..frame.levels - Self::layer_shift(frame, layer) {
            let bindings = ssbc_radiance_mips_comp::Bindings {
                geo_words: &frame.geo,
                aux_words: &frame.aux,
                radiance_sums: &frame.radiance,
                term,
            };
            let push = RadiancePush {
                frame: frame_block,
                layer,
                level,
            };
            let (w, h) = Self::level_extent(frame, layer, level);
            // Level 0: an invocation for two pixels (ssbc_radiance_mips.comp).
            let texels = match level {
                0 => Work::pixels((w.div_ceil(2), h)),
                _ => Work::pixels((w, h)),
            };
            self.radiance.dispatch(rec, pool, &bindings, &push, texels)?;
        }
        Ok(())
    }

    /// log2 of layer `layer`'s pixel side in image pixels.
    pub(super) fn layer_shift(frame: &SsbcFrame, layer: u32) -> u32 {
        match (layer, frame.layer1) {
            (1, Some(r)) => r.shift(),
            _ => 0,
        }
    }

    /// Texels of level `level` of layer `layer`'s pyramid (at half
    /// resolution half the size).
    pub(super) fn level_extent(frame: &SsbcFrame, layer: u32, level: u32) -> (u32, u32) {
        super::layout::level_size(frame.pyramid_size, level + Self::layer_shift(frame, layer))
    }
}
