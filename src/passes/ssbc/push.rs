//! The SSBC kernels' push blocks, one per kernel, each the twin of the
//! block its shader declares (sizes checked against the SPIR-V when the
//! kernel is made). Every block starts with the frame ([`FrameBlock`],
//! `SsbcFrame` in shaders/include/ssbc_types.glsl); the kernels that
//! integrate add [`ResidualParams`].

use bytemuck::{Pod, Zeroable};

use super::{SsbcCamera, SsbcFrame, SsbcInputs};
use crate::settings::Integration;

/// `SsbcFrame.layers` bit: the receivers' BRDF is in the G-buffer's w
/// channels (albedo.w metallic, normal.w roughness, < 0 Lambertian), as
/// ssbc's own G-buffer writes it; without it every receiver is Lambertian.
pub const GLOSSY_RECEIVERS: u32 = 256;

/// `SsbcFrame.layers` bit: the evaluation points and fallback pixels at
/// glossy receivers and at the others run in one dispatch (ONE_DISPATCH in
/// shaders/include/ssbc_eval.glsl; [`super::SsbcPass`] sets it on GPUs).
pub(crate) const ONE_DISPATCH: u32 = 512;

/// What every SSBC kernel reads of the frame (`SsbcFrame`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct FrameBlock {
    /// xyz eye; w pixel side on the image plane at distance 1.
    camera_position: [f32; 4],
    /// xyz unit optical axis; w focal length in pixels.
    camera_forward: [f32; 4],
    /// xyz unit up direction of the image.
    camera_up: [f32; 4],
    /// Image size.
    size: [u32; 2],
    /// Level 0 of the pyramids (padded).
    pyramid_size: [u32; 2],
    /// Pyramid levels.
    levels: u32,
    /// Bits 0..3: pyramids gathered from; bits 4..7: log2 of layer 1's pixel
    /// side; bit 8: [`GLOSSY_RECEIVERS`].
    layers: u32,
    /// b (1/m²).
    bound: f32,
    /// Lower clamp of cos(theta_view) in A_y.
    min_cos_view: f32,
}

impl FrameBlock {
    /// The frame of `frame`'s pyramids for an image of `extent`, gathering
    /// from the second layer's pyramid too if `two_layers`.
    pub fn new(
        inputs: &SsbcInputs<'_>,
        extent: (u32, u32),
        frame: &SsbcFrame,
        two_layers: bool,
    ) -> Self {
        let camera: &SsbcCamera = inputs.camera;
        let layers = match frame.layer1() {
            Some(r) if two_layers => 2 | r.shift() << 4,
            _ => 1,
        } | if inputs.glossy_receivers {
            GLOSSY_RECEIVERS
        } else {
            0
        };
        Self {
            camera_position: camera.position.extend(camera.pixel_side).into(),
            camera_forward: camera.forward.extend(1.0 / camera.pixel_side).into(),
            camera_up: camera.up.extend(0.0).into(),
            size: [extent.0, extent.1],
            pyramid_size: [frame.pyramid_size.0, frame.pyramid_size.1],
            levels: frame.levels(),
            layers,
            bound: inputs.bound,
            min_cos_view: inputs.settings.min_cos_view,
        }
    }

    /// Whether receivers may be glossy ([`GLOSSY_RECEIVERS`]).
    pub fn glossy_receivers(&self) -> bool {
        self.layers & GLOSSY_RECEIVERS != 0
    }

    /// Whether both kinds of receiver run in one dispatch ([`ONE_DISPATCH`]).
    pub fn one_dispatch(&self) -> bool {
        self.layers & ONE_DISPATCH != 0
    }

    /// The same frame, with both kinds of receiver in one dispatch if
    /// `one` and receivers may be glossy.
    pub fn with_one_dispatch(mut self, one: bool) -> Self {
        if one && self.glossy_receivers() {
            self.layers |= ONE_DISPATCH;
        }
        self
    }
}

/// How the residual integral refines and integrates (`ResidualParams`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ResidualParams {
    refine_ratio: f32,
    refine_excess: f32,
    /// 0 hierarchical, 1 brute force (`INTEGRATION_*`).
    integration: u32,
    pad: u32,
}

impl ResidualParams {
    pub fn new(inputs: &SsbcInputs<'_>) -> Self {
        let s = inputs.settings;
        Self {
            refine_ratio: s.refine_ratio,
            refine_excess: s.refine_excess,
            integration: (s.integration == Integration::Brute) as u32,
            pad: 0,
        }
    }
}

/// `ssbc_geometry_base.comp`: level 0 of `layer`'s geometry pyramid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct GeometryBasePush {
    pub frame: FrameBlock,
    pub layer: u32,
    /// 1: `g_geometric`'s w holds geometric normals (SsbcGBuffer::geometric).
    pub geometric: u32,
}

/// `ssbc_geometry_mips.comp`: one level >= 1 of `layer`'s geometry pyramid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct GeometryMipsPush {
    pub frame: FrameBlock,
    pub layer: u32,
    pub level: u32,
    pub max_normal_spread: f32,
    pub max_thickness: f32,
}

/// `ssbc_list_points.comp`: the evaluation points of the coarsest level.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ListPointsPush {
    pub frame: FrameBlock,
    pub level: u32,
}

/// `ssbc_radiance_mips.comp`: one level of `layer`'s radiance pyramid.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct RadiancePush {
    pub frame: FrameBlock,
    pub layer: u32,
    pub level: u32,
}

/// `ssbc_eval.comp`: the evaluation points of `level`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct EvalPush {
    pub frame: FrameBlock,
    pub residual: ResidualParams,
    pub level: u32,
    /// 1: the requested texels; 0: every texel of the level.
    pub from_list: u32,
    pub generation: u32,
    pub texels_per_radius: f32,
}

/// `ssbc_resolve.comp`: pixels interpolate the points of `level`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct ResolvePush {
    pub frame: FrameBlock,
    pub level: u32,
    /// 1: the pending pixels; 0: every pixel.
    pub from_list: u32,
    pub generation: u32,
    pub texels_per_radius: f32,
    pub scale_fraction: f32,
}

/// `ssbc_fallback.comp` and `ssbc_layer_residual.comp`: the integral alone.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct IntegralPush {
    pub frame: FrameBlock,
    pub residual: ResidualParams,
}

/// `ssbc_samples.comp`: texels read per pixel of a step.
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub(crate) struct SamplesPush {
    pub frame: FrameBlock,
    pub eval_level: u32,
    pub generation: u32,
}
