//! The post-process's passes of its own around SSBC: the host's G-buffer
//! in the host's formats into SSBC's inputs (shaders/postprocess_convert.comp),
//! or, where SSBC reads a layer's RGBA32F images in place, its normal and
//! albedo packed as ssbc's G-buffer packs them (shaders/postprocess_pack.comp);
//! and the result into the host's image by a compute shader
//! (shaders/include/postprocess_write.glsl).

use std::sync::Arc;

use ash::vk;

use super::inputs::{Conversion, HostGeometry, OutputWrite, PostOutput, PostProcessInputs};
use crate::error::{Error, Result};
use crate::passes::gbuffer::GBUFFER_PACKED_FORMAT;
use crate::shaders::{
    postprocess_convert_comp, postprocess_pack_comp, postprocess_write_r11f_g11f_b10f_comp,
    postprocess_write_rgba16f_comp, postprocess_write_rgba32f_comp,
};
use crate::vk::{
    ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, GpuProfiler, Image, ImageDesc,
    Recorder, Sampler, Work,
};

/// The two images of a layer's normal and albedo packed
/// ([`GBUFFER_PACKED_FORMAT`], 16 bytes a pixel for both).
fn packed_descs(extent: (u32, u32)) -> [ImageDesc; 2] {
    let desc =
        crate::passes::storage_desc(GBUFFER_PACKED_FORMAT, extent, vk::ImageUsageFlags::empty());
    [desc; 2]
}

fn images_bytes(device: Option<&Device>, descs: &[ImageDesc]) -> u64 {
    descs.iter().map(|d| d.bytes(device)).sum()
}

/// A layer's normal and albedo packed, for a layer SSBC reads in place.
pub(crate) struct PackedInputs {
    pub normal: Image,
    pub albedo: Image,
}

impl PackedInputs {
    /// Bytes of device memory they take at `extent`.
    pub fn bytes(device: Option<&Device>, extent: (u32, u32)) -> u64 {
        images_bytes(device, &packed_descs(extent))
    }

    pub fn new(device: &Arc<Device>, extent: (u32, u32), name: &str) -> Result<Self> {
        let [desc, _] = packed_descs(extent);
        let image = |what: &str| Image::new(device, &format!("{name} {what} (packed)"), desc);
        Ok(Self {
            normal: image("normal")?,
            albedo: image("albedo")?,
        })
    }
}

/// ssbc's copies of the host's first layer, in one frame slot: position,
/// `S0` and the sources RGBA32F, normal and albedo packed.
pub(crate) struct ConvertedInputs {
    pub position: Image,
    pub normal: Image,
    pub albedo: Image,
    pub s0: Image,
    /// The host's sources, if it gives any.
    pub sources: Option<Image>,
}

impl ConvertedInputs {
    /// What [`ConvertedInputs::new`] makes for `conversion` at `extent`
    /// (the first layer's normal and albedo packed, whether converted or
    /// read in place: [`PackedInputs`]).
    pub fn descs(conversion: Conversion, extent: (u32, u32)) -> Vec<ImageDesc> {
        let desc = crate::passes::radiance_desc(extent);
        let full = conversion.images() as usize;
        let mut descs = vec![desc; full];
        descs.extend(packed_descs(extent));
        descs
    }

    /// Bytes of device memory the first layer's copies take (on `device` as
    /// its requirements say, else as asked for), packed normal and albedo
    /// included.
    pub fn bytes(device: Option<&Device>, conversion: Conversion, extent: (u32, u32)) -> u64 {
        images_bytes(device, &Self::descs(conversion, extent))
    }

    /// The copies `conversion` needs (None for [`Conversion::None`]).
    pub fn new(
        device: &Arc<Device>,
        conversion: Conversion,
        extent: (u32, u32),
        slot: usize,
    ) -> Result<Option<Self>> {
        if conversion == Conversion::None {
            return Ok(None);
        }
        let desc = crate::passes::radiance_desc(extent);
        let image = |what: &str| {
            Image::new(
                device,
                &format!("ssbc post-process slot {slot} {what}"),
                desc,
            )
        };
        let packed = PackedInputs::new(device, extent, &format!("ssbc post-process slot {slot}"))?;
        Ok(Some(Self {
            position: image("position")?,
            normal: packed.normal,
            albedo: packed.albedo,
            s0: image("s0")?,
            sources: match conversion {
                Conversion::InputsAndSources => Some(image("sources")?),
                _ => None,
            },
        }))
    }
}

/// The host's first-layer images, wrapped for sampling.
pub(crate) struct SampledInputs<'a> {
    pub geometry: &'a Image,
    pub normal: &'a Image,
    pub albedo: &'a Image,
    pub s0: &'a Image,
    pub sources: Option<&'a Image>,
}

/// The conversion and output kernels.
pub(crate) struct HostIo {
    convert: ComputeKernel<postprocess_convert_comp::Interface>,
    pack: ComputeKernel<postprocess_pack_comp::Interface>,
    write_rgba32f: ComputeKernel<postprocess_write_rgba32f_comp::Interface>,
    write_rgba16f: ComputeKernel<postprocess_write_rgba16f_comp::Interface>,
    write_r11g11b10f: ComputeKernel<postprocess_write_r11f_g11f_b10f_comp::Interface>,
    /// Nearest, for texelFetch (which ignores it, but a combined image
    /// sampler needs one).
    sampler: Sampler,
}

impl HostIo {
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            convert: ComputeKernel::new(device)?.named("ssbc_postprocess_convert"),
            pack: ComputeKernel::new(device)?.named("ssbc_postprocess_pack"),
            write_rgba32f: ComputeKernel::new(device)?.named("ssbc_postprocess_write"),
            write_rgba16f: ComputeKernel::new(device)?.named("ssbc_postprocess_write"),
            write_r11g11b10f: ComputeKernel::new(device)?.named("ssbc_postprocess_write"),
            sampler: Sampler::new(
                device,
                vk::Filter::NEAREST,
                vk::SamplerAddressMode::CLAMP_TO_EDGE,
            )?
            .named("ssbc post-process input sampler"),
        })
    }

    /// The sets one frame allocates (a conversion, two packings and a
    /// write; the three write kernels' layouts are alike).
    pub fn set_layouts(&self) -> Vec<&DescriptorSetLayout> {
        let pack = self.pack.set_layout();
        vec![
            self.convert.set_layout(),
            pack,
            pack,
            self.write_rgba32f.set_layout(),
        ]
    }

    /// Packs a layer's RGBA32F `normal` and `albedo`, read in place, into
    /// `packed`.
    pub fn record_pack(
        &self,
        (rec, profiler, pool): (&mut Recorder<'_>, &mut GpuProfiler, &DescriptorPool),
        normal: &Image,
        albedo: &Image,
        packed: &PackedInputs,
    ) -> Result<()> {
        let (w, h) = (normal.desc.width, normal.desc.height);
        let scope = profiler.begin(rec.cmd, "ssbc_postprocess_pack");
        let bindings = postprocess_pack_comp::Bindings {
            host_normal: normal,
            host_albedo: albedo,
            g_normal: &packed.normal,
            g_albedo: &packed.albedo,
        };
        let push = postprocess_pack_comp::Push { size: [w, h] };
        self.pack
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }

    /// Fails, naming the image, format and missing feature, where this
    /// device cannot sample an input or store into the output.
    pub fn check_device(
        device: &Device,
        inputs: &PostProcessInputs,
        conversion: Conversion,
    ) -> Result<()> {
        let sampled = vk::FormatFeatureFlags::SAMPLED_IMAGE;
        let storage = vk::FormatFeatureFlags::STORAGE_IMAGE;
        let mut needs = vec![];
        if conversion != Conversion::None {
            needs.extend([
                ("geometry", inputs.geometry.image().format, sampled),
                ("normal", inputs.normal.format, sampled),
                ("albedo", inputs.albedo.format, sampled),
                ("s0", inputs.s0.format, sampled),
            ]);
            if let Some(s) = &inputs.sources {
                needs.push(("sources", s.format, sampled));
            }
        }
        if inputs.write != OutputWrite::Copy {
            needs.push(("output", inputs.output.format, storage));
        }
        for (name, format, feature) in needs {
            if !device.format_features(format).contains(feature) {
                return Err(Error::InvalidParameter(format!(
                    "SSBC post-process: this device cannot use the {name} image's format {format:?} as {feature:?}"
                )));
            }
        }
        Ok(())
    }

    /// Converts the host's images into `copies`.
    pub fn record_convert(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        inputs: &PostProcessInputs,
        host: SampledInputs<'_>,
        copies: &ConvertedInputs,
    ) -> Result<()> {
        let (w, h) = inputs.geometry.image().extent;
        let scope = profiler.begin(rec.cmd, "ssbc_postprocess_convert");
        let (geometry, background_depth) = match inputs.geometry {
            HostGeometry::Position(_) => (0, 0.0),
            HostGeometry::Depth { background, .. } => (1, background),
        };
        let push = postprocess_convert_comp::Push {
            inverse_view_projection: inputs
                .camera
                .inverse_view_projection((w, h))
                .unwrap_or_default()
                .to_cols_array_2d(),
            size: [w, h],
            geometry,
            normals: inputs.normal_encoding.code(),
            background_depth,
            sources: u32::from(copies.sources.is_some()),
        };
        let sampled = |image| (image, &self.sampler);
        let bindings = postprocess_convert_comp::Bindings {
            host_geometry: sampled(host.geometry),
            host_normal: sampled(host.normal),
            host_albedo: sampled(host.albedo),
            host_s0: sampled(host.s0),
            host_sources: sampled(host.sources.unwrap_or(host.s0)),
            g_position: &copies.position,
            g_normal: &copies.normal,
            g_albedo: &copies.albedo,
            s0: &copies.s0,
            sources: copies.sources.as_ref().unwrap_or(&copies.s0),
        };
        self.convert
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }

    /// Writes `result` (less `s0` where `subtract_s0`) into or onto the
    /// host's `output`, by its format's kernel.
    #[allow(clippy::too_many_arguments)]
    pub fn record_write(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        result: &Image,
        subtract_s0: Option<&Image>,
        output: &Image,
        add: bool,
    ) -> Result<()> {
        let (w, h) = (output.desc.width, output.desc.height);
        let scope = profiler.begin(rec.cmd, "ssbc_postprocess_write");
        // The three kernels differ only in the output's format qualifier:
        // the same bindings and push block.
        let (size, add, subtract_flag) = ([w, h], u32::from(add), u32::from(subtract_s0.is_some()));
        let subtract = subtract_s0.unwrap_or(result);
        let work = Work::pixels((w, h));
        macro_rules! write_with {
            ($kernel:expr, $module:ident) => {
                $kernel.dispatch(
                    rec,
                    pool,
                    &$module::Bindings {
                        result,
                        subtract,
                        host_output: output,
                    },
                    &$module::Push {
                        size,
                        add,
                        subtract: subtract_flag,
                    },
                    work,
                )
            };
        }
        match output.desc.format {
            vk::Format::R16G16B16A16_SFLOAT => {
                write_with!(self.write_rgba16f, postprocess_write_rgba16f_comp)
            }
            vk::Format::B10G11R11_UFLOAT_PACK32 => {
                write_with!(self.write_r11g11b10f, postprocess_write_r11f_g11f_b10f_comp)
            }
            _ => write_with!(self.write_rgba32f, postprocess_write_rgba32f_comp),
        }?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}

/// What the output write does for `output` and `write`, when the output
/// image may be the host's s0 (`output_is_s0`): (add onto it, subtract S0
/// from the compensated image).
pub(crate) fn write_mode(
    write: OutputWrite,
    output: PostOutput,
    output_is_s0: bool,
) -> (bool, bool) {
    match (write, output) {
        // The image holds S0: S0 + sum S_k is the compensated image itself.
        (OutputWrite::Add, PostOutput::Compensated) if output_is_s0 => (false, false),
        (OutputWrite::Add, PostOutput::Compensated) => (true, true),
        (OutputWrite::Add, PostOutput::Residual(_)) => (true, false),
        _ => (false, false),
    }
}
