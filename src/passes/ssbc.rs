//! Screen-space bias compensation: K steps of residual transport
//! `S_k = T_r S_{k-1}` over the screen, hierarchically (Nichols et al. 2009
//! style top-down integration over mip chains) or by brute force.
//!
//! Per frame: the geometry pyramid (area-weighted position and normal, summed
//! area `A_y`, discontinuity flag) is built once; each step builds the
//! radiance pyramid of the previous term, integrates the residual, and adds it
//! to the final image.

use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::gbuffer::GBuffer;
use crate::error::{Error, Result};
use crate::shaders;
use crate::vk::{
    Access, Binding, Buffer, ComputeKernel, DescriptorPool, DescriptorSetLayout, Device,
    GpuProfiler, Image, ImageDesc, Recorder, Sampler,
};

/// How each residual step integrates over the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integration {
    /// Top-down over the mip chains (the paper's method).
    #[default]
    Hierarchical,
    /// Every full-resolution pixel within the bounding radius (the reference).
    Brute,
}

/// SSBC parameters.
#[derive(Clone, Debug)]
pub struct SsbcSettings {
    /// Number of residual steps K (0 = no compensation).
    pub steps: u32,
    /// Integration method.
    pub integration: Integration,
    /// Lower clamp of cos(theta_view) in A_y (conservative grazing-angle compensation).
    pub min_cos_view: f32,
    /// Refine a texel whose extent exceeds this fraction of its distance to x.
    pub refine_ratio: f32,
    /// Children whose normal has a cosine below this to the mean are discontinuous.
    pub max_normal_spread: f32,
    /// A texel whose bounding slab is thicker than this x its bounding radius
    /// is discontinuous (a depth step).
    pub max_thickness: f32,
}

impl Default for SsbcSettings {
    fn default() -> Self {
        Self {
            steps: 2,
            integration: Integration::Hierarchical,
            min_cos_view: 0.2,
            refine_ratio: 0.2,
            max_normal_spread: 0.9,
            max_thickness: 0.25,
        }
    }
}

impl SsbcSettings {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        if self.steps > 16 {
            return bad(format!("--steps {} (at most 16)", self.steps));
        }
        if !(self.min_cos_view > 0.0 && self.min_cos_view <= 1.0) {
            return bad(format!(
                "min cos view {} must be in (0, 1]",
                self.min_cos_view
            ));
        }
        if !(self.refine_ratio > 0.0 && self.refine_ratio.is_finite()) {
            return bad(format!(
                "refine ratio {} must be positive",
                self.refine_ratio
            ));
        }
        Ok(())
    }
}

/// Camera quantities the SSBC shaders need.
#[derive(Clone, Copy, Debug)]
pub struct SsbcCamera {
    /// Eye position.
    pub position: glam::Vec3,
    /// Unit optical axis.
    pub forward: glam::Vec3,
    /// Pixel side on the image plane at distance 1: 2 tan(fov/2) / height.
    pub pixel_side: f32,
}

/// The SSBC pipelines.
pub struct SsbcPass {
    geometry: ComputeKernel,
    radiance: ComputeKernel,
    residual: ComputeKernel,
    accumulate: ComputeKernel,
    nearest: Sampler,
}

/// One frame's SSBC images.
pub struct SsbcFrame {
    /// xyz mean position, w summed area A (mip chain).
    pub geo_position: Image,
    /// xyz mean normal, w discontinuity (mip chain).
    pub geo_normal: Image,
    /// x radius of a sphere around the mean position bounding the texel's surface (mip chain).
    pub geo_extent: Image,
    /// Mean of the term being compensated (mip chain).
    pub radiance: Image,
    /// `residual_k` for k = 1..=K.
    pub residuals: Vec<Image>,
    /// Texel evaluations per pixel of each step (r32ui).
    pub samples: Vec<Image>,
    /// `S0 + residual_1 + ... + residual_K`.
    pub final_image: Image,
    /// One u32: how often a refinement stack was full (texel added unrefined).
    pub stats: Buffer,
    levels: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct GeometryPush {
    camera_position: [f32; 4],
    camera_forward: [f32; 4],
    dst_size: [u32; 2],
    gbuffer_size: [u32; 2],
    mode: u32,
    min_cos_view: f32,
    max_normal_spread: f32,
    max_thickness: f32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct RadiancePush {
    dst_size: [u32; 2],
    term_size: [u32; 2],
    mode: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ResidualPush {
    camera_position: [f32; 4],
    camera_forward: [f32; 4],
    size: [u32; 2],
    pyramid_size: [u32; 2],
    levels: u32,
    mode: u32,
    bound: f32,
    refine_ratio: f32,
}

/// Pyramid levels for an image: down to about 2 texels on the short side.
pub fn pyramid_levels(width: u32, height: u32) -> u32 {
    (31 - width.min(height).max(1).leading_zeros()).clamp(1, 12)
}

impl SsbcPass {
    /// Creates the pipelines.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        use vk::DescriptorType as T;
        let samplers = [T::COMBINED_IMAGE_SAMPLER; 4];
        Ok(Self {
            // G-buffer position and normal; source position, normal, extent; destination ditto.
            geometry: ComputeKernel::new(
                device,
                shaders::SSBC_GEOMETRY_MIPS_COMP,
                &[T::STORAGE_IMAGE; 8],
                std::mem::size_of::<GeometryPush>(),
            )?,
            // Term, source area, source radiance, destination radiance.
            radiance: ComputeKernel::new(
                device,
                shaders::SSBC_RADIANCE_MIPS_COMP,
                &[T::STORAGE_IMAGE; 4],
                std::mem::size_of::<RadiancePush>(),
            )?,
            // G-buffer (3), pyramids (position, normal, radiance, extent), residual, samples, stats.
            residual: ComputeKernel::new(
                device,
                shaders::SSBC_RESIDUAL_COMP,
                &[
                    &[T::STORAGE_IMAGE; 3][..],
                    &samplers,
                    &[T::STORAGE_IMAGE, T::STORAGE_IMAGE, T::STORAGE_BUFFER],
                ]
                .concat(),
                std::mem::size_of::<ResidualPush>(),
            )?,
            // a, b, a + b.
            accumulate: ComputeKernel::new(
                device,
                shaders::ACCUMULATE_COMP,
                &[T::STORAGE_IMAGE; 3],
                8,
            )?,
            nearest: Sampler::new(
                device,
                vk::Filter::NEAREST,
                vk::SamplerAddressMode::CLAMP_TO_EDGE,
            )?,
        })
    }

    /// Layouts of every set one frame allocates.
    pub fn set_layouts(&self, extent: (u32, u32), steps: u32) -> Vec<&DescriptorSetLayout> {
        let levels = pyramid_levels(extent.0, extent.1) as usize;
        let mut v = vec![self.geometry.set_layout(); levels];
        for _ in 0..steps {
            v.extend(std::iter::repeat_n(self.radiance.set_layout(), levels));
            v.push(self.residual.set_layout());
            v.push(self.accumulate.set_layout());
        }
        v
    }

    /// Allocates one frame's images for `steps` steps.
    pub fn prepare(
        &self,
        device: &Arc<Device>,
        extent: (u32, u32),
        steps: u32,
    ) -> Result<SsbcFrame> {
        let levels = pyramid_levels(extent.0, extent.1);
        // Pad level 0 so every level halves exactly (padding has zero area).
        let align = 1u32 << (levels - 1);
        let (pw, ph) = (
            extent.0.div_ceil(align) * align,
            extent.1.div_ceil(align) * align,
        );
        let pyramid = |name, format| {
            Image::new(
                device,
                name,
                ImageDesc {
                    format,
                    width: pw,
                    height: ph,
                    layers: 1,
                    mip_levels: levels,
                    usage: vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::SAMPLED,
                    array: false,
                },
            )
        };
        let rgba = |name: String| {
            super::storage_image(
                device,
                &name,
                vk::Format::R32G32B32A32_SFLOAT,
                extent,
                vk::ImageUsageFlags::empty(),
            )
        };
        let residuals = (1..=steps)
            .map(|k| rgba(format!("residual_{k}")))
            .collect::<Result<_>>()?;
        let samples = (1..=steps)
            .map(|k| {
                super::storage_image(
                    device,
                    &format!("samples_{k}"),
                    vk::Format::R32_UINT,
                    extent,
                    vk::ImageUsageFlags::empty(),
                )
            })
            .collect::<Result<_>>()?;
        Ok(SsbcFrame {
            geo_position: pyramid("ssbc_geo_position", vk::Format::R32G32B32A32_SFLOAT)?,
            geo_normal: pyramid("ssbc_geo_normal", vk::Format::R32G32B32A32_SFLOAT)?,
            geo_extent: pyramid("ssbc_geo_extent", vk::Format::R32G32_SFLOAT)?,
            radiance: pyramid("ssbc_radiance", vk::Format::R32G32B32A32_SFLOAT)?,
            residuals,
            samples,
            final_image: rgba("final".into())?,
            stats: Buffer::new(
                device,
                "ssbc_stats",
                4,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?,
            levels,
        })
    }

    /// Records the geometry pyramid and every step; `s0` is `T Le + T_b L^`.
    #[allow(clippy::too_many_arguments)]
    pub fn record(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        gbuffer: &GBuffer,
        s0: &Image,
        camera: &SsbcCamera,
        bound: f32,
        settings: &SsbcSettings,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let extent = gbuffer.extent();
        rec.fill_buffer(&frame.stats, 0);
        rec.use_buffer(&frame.stats, Access::ComputeWrite);

        let scope = profiler.begin(rec.cmd, "ssbc_geometry_mips");
        for level in 0..frame.levels {
            let src = level.saturating_sub(1) as usize;
            let bindings = [
                Binding::storage(&gbuffer.position),
                Binding::storage(&gbuffer.normal),
                Binding::StorageImage(frame.geo_position.mip_views[src]),
                Binding::StorageImage(frame.geo_normal.mip_views[src]),
                Binding::StorageImage(frame.geo_extent.mip_views[src]),
                Binding::StorageImage(frame.geo_position.mip_views[level as usize]),
                Binding::StorageImage(frame.geo_normal.mip_views[level as usize]),
                Binding::StorageImage(frame.geo_extent.mip_views[level as usize]),
            ];
            rec.use_image(&gbuffer.position, Access::ComputeRead);
            rec.use_image(&gbuffer.normal, Access::ComputeRead);
            for pyramid in [&frame.geo_position, &frame.geo_normal, &frame.geo_extent] {
                rec.use_image(pyramid, Access::ComputeWrite);
            }
            rec.flush_barriers();
            let (w, h) = frame.geo_position.mip_extent(level);
            let push = GeometryPush {
                camera_position: camera.position.extend(1.0).into(),
                camera_forward: camera.forward.extend(camera.pixel_side).into(),
                dst_size: [w, h],
                gbuffer_size: [extent.0, extent.1],
                mode: (level > 0) as u32,
                min_cos_view: settings.min_cos_view,
                max_normal_spread: settings.max_normal_spread,
                max_thickness: settings.max_thickness,
            };
            self.geometry.dispatch_2d(
                rec.cmd,
                pool,
                &bindings,
                bytemuck::bytes_of(&push),
                (w, h),
            )?;
        }
        profiler.end(rec.cmd, scope);

        for step in 0..settings.steps as usize {
            let term = if step == 0 {
                s0
            } else {
                &frame.residuals[step - 1]
            };
            let scope = profiler.begin(rec.cmd, &format!("ssbc_step_{}", step + 1));
            self.record_radiance_mips(rec, pool, term, extent, frame)?;
            self.record_residual(rec, pool, gbuffer, camera, bound, settings, frame, step)?;
            let accumulated = if step == 0 { s0 } else { &frame.final_image };
            self.record_accumulate(
                rec,
                pool,
                accumulated,
                &frame.residuals[step],
                &frame.final_image,
                extent,
            )?;
            profiler.end(rec.cmd, scope);
        }
        Ok(())
    }

    fn record_radiance_mips(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        term: &Image,
        extent: (u32, u32),
        frame: &SsbcFrame,
    ) -> Result<()> {
        for level in 0..frame.levels {
            let src = level.saturating_sub(1) as usize;
            let bindings = [
                Binding::storage(term),
                Binding::StorageImage(frame.geo_position.mip_views[src]),
                Binding::StorageImage(frame.radiance.mip_views[src]),
                Binding::StorageImage(frame.radiance.mip_views[level as usize]),
            ];
            rec.use_image(term, Access::ComputeRead);
            rec.use_image(&frame.geo_position, Access::ComputeRead);
            rec.use_image(&frame.radiance, Access::ComputeWrite);
            rec.flush_barriers();
            let (w, h) = frame.radiance.mip_extent(level);
            let push = RadiancePush {
                dst_size: [w, h],
                term_size: [extent.0, extent.1],
                mode: (level > 0) as u32,
            };
            self.radiance.dispatch_2d(
                rec.cmd,
                pool,
                &bindings,
                bytemuck::bytes_of(&push),
                (w, h),
            )?;
        }
        Ok(())
    }

    #[allow(clippy::too_many_arguments)]
    fn record_residual(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        gbuffer: &GBuffer,
        camera: &SsbcCamera,
        bound: f32,
        settings: &SsbcSettings,
        frame: &SsbcFrame,
        step: usize,
    ) -> Result<()> {
        let [position, normal, albedo] = gbuffer.storage_bindings();
        let bindings = [
            position,
            normal,
            albedo,
            Binding::sampled(&frame.geo_position, &self.nearest),
            Binding::sampled(&frame.geo_normal, &self.nearest),
            Binding::sampled(&frame.radiance, &self.nearest),
            Binding::sampled(&frame.geo_extent, &self.nearest),
            Binding::storage(&frame.residuals[step]),
            Binding::storage(&frame.samples[step]),
            Binding::StorageBuffer(&frame.stats),
        ];
        gbuffer.read_in_compute(rec);
        for pyramid in [
            &frame.geo_position,
            &frame.geo_normal,
            &frame.radiance,
            &frame.geo_extent,
        ] {
            rec.use_image(pyramid, Access::ComputeSampled);
        }
        rec.use_image(&frame.residuals[step], Access::ComputeWrite);
        rec.use_image(&frame.samples[step], Access::ComputeWrite);
        rec.use_buffer(&frame.stats, Access::ComputeWrite);
        rec.flush_barriers();
        let (w, h) = gbuffer.extent();
        let push = ResidualPush {
            camera_position: camera.position.extend(1.0).into(),
            camera_forward: camera.forward.extend(1.0 / camera.pixel_side).into(),
            size: [w, h],
            pyramid_size: [
                frame.geo_position.desc.width,
                frame.geo_position.desc.height,
            ],
            levels: frame.levels,
            mode: (settings.integration == Integration::Brute) as u32,
            bound,
            refine_ratio: settings.refine_ratio,
        };
        self.residual
            .dispatch_2d(rec.cmd, pool, &bindings, bytemuck::bytes_of(&push), (w, h))?;
        Ok(())
    }

    fn record_accumulate(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        a: &Image,
        b: &Image,
        dst: &Image,
        extent: (u32, u32),
    ) -> Result<()> {
        let bindings = [
            Binding::storage(a),
            Binding::storage(b),
            Binding::storage(dst),
        ];
        if !std::ptr::eq(a, dst) {
            rec.use_image(a, Access::ComputeRead);
        }
        rec.use_image(b, Access::ComputeRead);
        rec.use_image(dst, Access::ComputeWrite);
        rec.flush_barriers();
        self.accumulate.dispatch_2d(
            rec.cmd,
            pool,
            &bindings,
            bytemuck::bytes_of(&[extent.0, extent.1]),
            (extent.0, extent.1),
        )?;
        Ok(())
    }
}
