//! The SSBC kernels' push blocks, generated from their shaders (build.rs);
//! here, how they are filled. Every block starts with the frame
//! ([`FrameBlock`], `SsbcFrame` in shaders/include/ssbc_types.glsl); the
//! kernels that integrate add [`ResidualParams`].

use super::{SsbcCamera, SsbcFrame, SsbcInputs};

/// `SsbcFrame.layers` bit: the receivers' BRDF is in the G-buffer's w
/// channels (albedo.w metallic, normal.w roughness, < 0 Lambertian), as
/// ssbc's own G-buffer writes it; without it every receiver is Lambertian.
pub const GLOSSY_RECEIVERS: u32 = 256;

/// `SsbcFrame.layers` bit: the evaluation points and fallback pixels at
/// glossy receivers and at the others run in one dispatch (ONE_DISPATCH in
/// shaders/include/ssbc_eval.glsl; [`super::SsbcPass`] sets it on GPUs).
pub(crate) const ONE_DISPATCH: u32 = 512;

/// `SsbcFrame.layers` bit: the step is the last, so what its residual sends
/// is never read: `residual_sources` is not written (the step binds its
/// residual there; LAST_STEP in shaders/include/ssbc_types.glsl).
pub(crate) const LAST_STEP: u32 = 1024;

/// `SsbcFrame.layers` bit: the step's residual is not kept in an image of
/// its own (no output asks for it): the step binds its final image in its
/// place and only adds the residual to it (NO_RESIDUAL in
/// shaders/include/ssbc_types.glsl).
pub(crate) const NO_RESIDUAL: u32 = 2048;

/// What every SSBC kernel reads of the frame (`SsbcFrame` in the shaders).
pub(crate) use crate::shaders::blocks::SsbcFrame as FrameBlock;
pub(crate) use crate::shaders::blocks::{
    EvalPush, GeometryBasePush, GeometryMipsPush, IntegralPush, ListPointsPush, RadiancePush,
    ResidualParams, ResolvePush, SamplesPush,
};

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

    /// Whether both kinds of receiver run in one dispatch (`ONE_DISPATCH`).
    pub fn one_dispatch(&self) -> bool {
        self.layers & ONE_DISPATCH != 0
    }

    /// The same frame, marked as keeping no residual image unless `kept`
    /// (`NO_RESIDUAL`).
    pub fn with_residual_kept(mut self, kept: bool) -> Self {
        if !kept {
            self.layers |= NO_RESIDUAL;
        }
        self
    }

    /// The same frame, marked as its last step's if `last` (`LAST_STEP`).
    pub fn with_last_step(mut self, last: bool) -> Self {
        if last {
            self.layers |= LAST_STEP;
        }
        self
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

impl ResidualParams {
    /// How the residual integral refines and integrates at `inputs`.
    pub fn new(inputs: &SsbcInputs<'_>) -> Self {
        let s = inputs.settings;
        Self {
            refine_ratio: s.refine_ratio,
            refine_excess: s.refine_excess,
            ..Default::default()
        }
    }
}
