//! The images a frame can hand out ([`Layer`]): their names, and which are
//! outputs and which debug views. Which pass writes each is the pass's own
//! declaration (`Pass::layers`).

use crate::error::{Error, Result};

/// An image of a frame.
///
/// ```
/// use ssbc::Layer;
/// assert_eq!("residual_2".parse::<Layer>().unwrap(), Layer::Residual(2));
/// assert_eq!(Layer::IndirectBounded.to_string(), "indirect_bounded");
/// assert_eq!(
///     Layer::outputs(1),
///     [Layer::Final, Layer::Direct, Layer::IndirectBounded, Layer::Residual(1), Layer::Indirect]
/// );
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Layer {
    /// `S0 + S_1 + ... + S_K` (`S0` without steps): the image.
    Final,
    /// Direct light `T Le`, with the emitters' own radiance.
    Direct,
    /// Bounded (clamped) VPL lighting `T_b L^` (`S0` less `Direct`). Made
    /// only in frames that hand out every output, as `Indirect` is.
    IndirectBounded,
    /// The residual `S_k` of SSBC step k (1 to K). Kept only in frames
    /// that hand out every output, as `Indirect` is (otherwise each step
    /// only adds it to the final image).
    Residual(u32),
    /// All indirect light, `Final` less `Direct` (`T_b L^ + S_1 + ... +
    /// S_K`, averaged by the history as `Final` is): what a host that
    /// lights directly itself adds. Made only in frames that hand out
    /// every output ([`RenderSettings::output_layers`](crate::RenderSettings::output_layers),
    /// or a GPU frame that asks for it).
    Indirect,
    /// G-buffer world position (w = 1 on geometry; debug read-back).
    GBufferPosition,
    /// G-buffer shading normal (debug read-back).
    GBufferNormal,
    /// G-buffer albedo (debug read-back).
    GBufferAlbedo,
    /// G-buffer emitted radiance (debug read-back).
    GBufferEmission,
    /// What each pixel sends as a source of SSBC's first step: its
    /// reflected light made view-independent (`S0` itself on Lambertian
    /// surfaces; debug read-back). Its w: 1, or where a normal map turned
    /// the shading normal the geometric normal's code
    /// (shaders/include/geometric_normal.glsl), which SSBC reads there.
    Sources,
    /// The deep G-buffer's second layer: position, at its resolution (debug
    /// read-back with `ssbc.layers` 2).
    Layer1Position,
    /// Its normal.
    Layer1Normal,
    /// Its albedo.
    Layer1Albedo,
    /// What it sends as SSBC sources.
    Layer1Sources,
}

impl Layer {
    /// The layers a frame with `steps` SSBC steps can hand over on the GPU
    /// or into a host's image, and reads back: `Final`, `Direct`,
    /// `IndirectBounded`, `Residual(1..=steps)`, `Indirect`.
    pub fn outputs(steps: u32) -> Vec<Layer> {
        [Layer::Final, Layer::Direct, Layer::IndirectBounded]
            .into_iter()
            .chain((1..=steps).map(Layer::Residual))
            .chain([Layer::Indirect])
            .collect()
    }

    /// Whether a frame makes this layer only when it hands out every
    /// output ([`RenderSettings::output_layers`](crate::RenderSettings::output_layers)),
    /// or a GPU frame asks for it (which then makes them all). The direct
    /// light and the G-buffer's emission are: without, their images may
    /// share memory with SSBC's pyramids (`passes::transient`).
    pub fn on_request(self) -> bool {
        matches!(
            self,
            Layer::Direct
                | Layer::GBufferEmission
                | Layer::IndirectBounded
                | Layer::Residual(_)
                | Layer::Indirect
        )
    }

    /// Whether a frame reads this layer back only with
    /// [`RenderSettings::debug_readback`](crate::RenderSettings::debug_readback)
    /// (the G-buffers and sources), not with
    /// [`RenderSettings::output_layers`](crate::RenderSettings::output_layers).
    pub fn is_debug(self) -> bool {
        !matches!(
            self,
            Layer::Final
                | Layer::Direct
                | Layer::IndirectBounded
                | Layer::Residual(_)
                | Layer::Indirect
        )
    }
}

/// Every layer but the residuals, with its name.
const NAMED: [(Layer, &str); 13] = [
    (Layer::Final, "final"),
    (Layer::Direct, "direct"),
    (Layer::IndirectBounded, "indirect_bounded"),
    (Layer::Indirect, "indirect"),
    (Layer::GBufferPosition, "gbuffer_position"),
    (Layer::GBufferNormal, "gbuffer_normal"),
    (Layer::GBufferAlbedo, "gbuffer_albedo"),
    (Layer::GBufferEmission, "gbuffer_emission"),
    (Layer::Sources, "sources"),
    (Layer::Layer1Position, "layer1_position"),
    (Layer::Layer1Normal, "layer1_normal"),
    (Layer::Layer1Albedo, "layer1_albedo"),
    (Layer::Layer1Sources, "layer1_sources"),
];

impl std::fmt::Display for Layer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Layer::Residual(k) = self {
            return write!(f, "residual_{k}");
        }
        let name = NAMED.iter().find(|(l, _)| l == self).map_or("", |(_, n)| n);
        f.write_str(name)
    }
}

impl std::str::FromStr for Layer {
    type Err = Error;
    fn from_str(s: &str) -> Result<Layer> {
        if let Some((layer, _)) = NAMED.iter().find(|(_, n)| *n == s) {
            return Ok(*layer);
        }
        match s.strip_prefix("residual_").map(str::parse::<u32>) {
            Some(Ok(k)) if k >= 1 => Ok(Layer::Residual(k)),
            _ => Err(Error::InvalidParameter(format!(
                "no layer '{s}' (final, direct, indirect_bounded, residual_K, indirect, or a debug layer)"
            ))),
        }
    }
}
