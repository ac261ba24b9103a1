//! What the host hands the post-process each frame, and which formats each
//! image may have (the one table the docs list).

use ash::vk;

use super::camera::HostCamera;
use crate::error::{Error, Result};
use crate::settings::LayerResolution;
use crate::vk::HostImage;

/// What the host wants in its output image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PostOutput {
    /// `S0 + S_1 + ... + S_K` (with [`OutputWrite::Add`]: `S_1 + ... + S_K`
    /// added onto what the output holds).
    Compensated,
    /// One step's residual `S_k` (1-based).
    Residual(u32),
}

/// How the result reaches the host's output image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OutputWrite {
    /// A copy into an `R32G32B32A32_SFLOAT` image with `TRANSFER_DST`
    /// usage, left in `TRANSFER_DST_OPTIMAL`.
    #[default]
    Copy,
    /// Written by a compute shader into a float image with `STORAGE`
    /// usage (left in `GENERAL`).
    Store,
    /// Added by a compute shader onto what the image holds, e.g. the
    /// host's lighting image (which may be the `s0` image itself): the
    /// compensation `S_1 + ... + S_K`, or `S_k` for a residual.
    Add,
}

/// How SSBC reads the receivers' BRDF from the host's images.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ReceiverBrdf {
    /// Lambertian of the albedo image's rgb; the w channels of the albedo
    /// and normal images are not read (what every host got before there
    /// was a choice, bit for bit).
    #[default]
    Lambertian,
    /// glTF 2.0 metallic-roughness (ssbc's G-buffer encoding): the albedo
    /// image's rgb is the base colour and w the metallic, the normal image's
    /// w the perceptual roughness (negative: that pixel is Lambertian).
    /// Such receivers reflect the residual towards the camera with their
    /// BRDF, each evaluated alone.
    MetallicRoughnessInW,
}

/// Where the host's pixels are in the world.
#[derive(Clone, Copy, Debug)]
pub enum HostGeometry {
    /// World-space positions (xyz; w = 0 where there is no geometry).
    Position(HostImage),
    /// Hardware depth, turned into positions with the camera's matrices
    /// (needs [`HostCamera::Matrices`]).
    Depth {
        /// The depth image (a view of its depth aspect).
        image: HostImage,
        /// The depth where nothing was drawn (the clear value: 1.0, or 0.0
        /// with reversed Z).
        background: f32,
    },
}

impl HostGeometry {
    /// The image, whichever kind.
    pub fn image(&self) -> &HostImage {
        match self {
            HostGeometry::Position(image) | HostGeometry::Depth { image, .. } => image,
        }
    }
}

/// How the normal image holds unit normals (its w, in four-channel
/// formats, carries the roughness of [`ReceiverBrdf::MetallicRoughnessInW`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalEncoding {
    /// xyz as stored (float and SNORM formats).
    #[default]
    Signed,
    /// xyz mapped to [0, 1]: n = 2 t - 1 (UNORM formats such as RGB10A2).
    Unsigned,
    /// Two channels, the octahedral map onto [-1, 1]^2.
    Octahedral,
    /// Two channels, the octahedral map stored as (e + 1) / 2.
    OctahedralUnsigned,
}

impl NormalEncoding {
    fn two_channels(self) -> bool {
        matches!(
            self,
            NormalEncoding::Octahedral | NormalEncoding::OctahedralUnsigned
        )
    }

    /// `NORMAL_*` in shaders/postprocess_convert.comp.
    pub(crate) fn code(self) -> u32 {
        self as u32
    }
}

/// The host's inputs for one frame.
#[derive(Clone, Copy, Debug)]
pub struct PostProcessInputs {
    /// World positions or hardware depth.
    pub geometry: HostGeometry,
    /// Shading normal.
    pub normal: HostImage,
    /// How `normal` encodes it.
    pub normal_encoding: NormalEncoding,
    /// Diffuse albedo (rgb; sRGB formats are decoded by sampling).
    pub albedo: HostImage,
    /// The clamped lighting `S0` (rgb radiance towards the camera).
    pub s0: HostImage,
    /// What each pixel sends as a source of the first step, made
    /// view-independent (None: `s0` itself, right for Lambertian surfaces).
    /// ssbc's renderer sends each surface's reflected light spread evenly
    /// by its hemispherical albedo, specular lobe included
    /// (docs/ssbc-implementation.md); later steps do the same with
    /// `receivers`.
    pub sources: Option<HostImage>,
    /// How the receivers reflect.
    pub receivers: ReceiverBrdf,
    /// Where the result goes.
    pub output: HostImage,
    /// How it gets there.
    pub write: OutputWrite,
    /// The camera the G-buffer was drawn with.
    pub camera: HostCamera,
    /// The clamping bound b (1/m²) the host's `S0` was clamped with.
    pub bound: f32,
    /// Distance along the optical axis where most of the image lies (e.g.
    /// to the scene's centre): picks the coarsest evaluation level.
    pub typical_depth: f32,
    /// An optional second G-buffer layer of hidden surfaces (see the module
    /// documentation), whose surfaces SSBC gathers from as well.
    pub hidden: Option<PostProcessLayer>,
}

/// The host's second G-buffer layer, at full or half resolution (rounded
/// up): the position image's size says which. All four are
/// `R32G32B32A32_SFLOAT` storage images.
#[derive(Clone, Copy, Debug)]
pub struct PostProcessLayer {
    /// World-space position (xyz; w = 0 where there is no hidden surface).
    pub position: HostImage,
    /// The normal of the surface's own (outward) side, unit length.
    pub normal: HostImage,
    /// Diffuse albedo (rgb).
    pub albedo: HostImage,
    /// Its clamped lighting `S0` (rgb radiance).
    pub s0: HostImage,
}

/// Whether the post-process reads the host's first layer as it is or
/// converts it into copies of its own first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Conversion {
    /// Every input is `R32G32B32A32_SFLOAT` (world positions, signed
    /// normals): position, `S0` and the sources read in place as storage
    /// images; normal and albedo packed into copies of 8 bytes a pixel
    /// each, as ssbc's own G-buffer holds them (16 bytes a pixel).
    #[default]
    None,
    /// Read through sampling into ssbc's own copies: position and `S0`
    /// `R32G32B32A32_SFLOAT`, normal and albedo packed (48 bytes a pixel).
    Inputs,
    /// The same, and of the sources (64 bytes a pixel).
    InputsAndSources,
}

impl Conversion {
    /// Images of its own the conversion needs (besides the packed normal
    /// and albedo that every conversion, [`Conversion::None`] too, makes).
    pub fn images(self) -> u32 {
        match self {
            Conversion::None => 0,
            Conversion::Inputs => 2,
            Conversion::InputsAndSources => 3,
        }
    }
}

const RGBA32F: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// The formats each input accepts (read through sampling where any input
/// is converted; docs/embedding.md lists them). A use, its formats, and
/// whether it must be sampled or written as storage.
pub const FORMATS: &[(&str, &[vk::Format])] = &[
    ("position", &[RGBA32F]),
    (
        "depth",
        &[
            vk::Format::D32_SFLOAT,
            vk::Format::D32_SFLOAT_S8_UINT,
            vk::Format::D24_UNORM_S8_UINT,
            vk::Format::X8_D24_UNORM_PACK32,
            vk::Format::D16_UNORM,
            vk::Format::R32_SFLOAT,
        ],
    ),
    (
        "normal (xyz)",
        &[
            RGBA32F,
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::R16G16B16A16_SNORM,
            vk::Format::R16G16B16A16_UNORM,
            vk::Format::R8G8B8A8_SNORM,
            vk::Format::R8G8B8A8_UNORM,
            vk::Format::A2B10G10R10_UNORM_PACK32,
            vk::Format::A2R10G10B10_UNORM_PACK32,
        ],
    ),
    (
        "normal (octahedral)",
        &[
            vk::Format::R32G32_SFLOAT,
            vk::Format::R16G16_SFLOAT,
            vk::Format::R16G16_SNORM,
            vk::Format::R16G16_UNORM,
            vk::Format::R8G8_SNORM,
            vk::Format::R8G8_UNORM,
        ],
    ),
    (
        "albedo",
        &[
            RGBA32F,
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::R8G8B8A8_UNORM,
            vk::Format::R8G8B8A8_SRGB,
            vk::Format::B8G8R8A8_UNORM,
            vk::Format::B8G8R8A8_SRGB,
            vk::Format::A2B10G10R10_UNORM_PACK32,
        ],
    ),
    (
        "radiance (s0, sources)",
        &[
            RGBA32F,
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::B10G11R11_UFLOAT_PACK32,
            vk::Format::E5B9G9R9_UFLOAT_PACK32,
        ],
    ),
    ("output (copy)", &[RGBA32F]),
    (
        "output (store, add)",
        &[
            RGBA32F,
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::B10G11R11_UFLOAT_PACK32,
        ],
    ),
    ("second layer (all four)", &[RGBA32F]),
];

fn formats(role: &str) -> &'static [vk::Format] {
    FORMATS
        .iter()
        .find(|(r, _)| *r == role)
        .map(|(_, f)| *f)
        .expect("a role of FORMATS")
}

/// Formats whose alpha has too few bits to carry a roughness or metallic.
fn narrow_alpha(format: vk::Format) -> bool {
    matches!(
        format,
        vk::Format::A2B10G10R10_UNORM_PACK32 | vk::Format::A2R10G10B10_UNORM_PACK32
    )
}

/// What checking a frame's inputs found.
pub(crate) struct Checked {
    pub extent: (u32, u32),
    /// The camera as SSBC's kernels see it.
    pub camera: crate::passes::ssbc::SsbcCamera,
    pub layer1: Option<LayerResolution>,
    pub conversion: Conversion,
}

impl PostProcessInputs {
    /// Whether the first layer can be read in place.
    fn conversion(&self) -> Conversion {
        let direct = matches!(self.geometry, HostGeometry::Position(_))
            && self.normal_encoding == NormalEncoding::Signed
            && [self.geometry.image(), &self.normal, &self.albedo, &self.s0]
                .iter()
                .chain(self.sources.as_ref().map(|s| s as &HostImage).as_ref())
                .all(|i| i.format == RGBA32F);
        match (direct, self.sources) {
            (true, _) => Conversion::None,
            (false, None) => Conversion::Inputs,
            (false, Some(_)) => Conversion::InputsAndSources,
        }
    }

    /// Checks sizes, formats and parameters (not what the device supports:
    /// [`super::SsbcPostProcess`] does that).
    pub(crate) fn check(&self) -> Result<Checked> {
        let (named, layer1) = self.named_images();
        for image in named {
            image.check()?;
        }
        self.check_semantics()?;
        let extent = self.geometry.image().extent;
        Ok(Checked {
            extent,
            camera: self.camera.ssbc(extent)?,
            layer1,
            conversion: self.conversion(),
        })
    }

    /// Every image with its name, its use in [`FORMATS`] and the size it
    /// must have; and the second layer's resolution, which its position
    /// image's size says.
    fn named_images(&self) -> (Vec<NamedImage<'_>>, Option<LayerResolution>) {
        let geometry = self.geometry.image();
        let extent = geometry.extent;
        let same = format!("the size of the geometry image, {extent:?}");
        let normal_role = if self.normal_encoding.two_channels() {
            "normal (octahedral)"
        } else {
            "normal (xyz)"
        };
        let geometry_role = match self.geometry {
            HostGeometry::Position(_) => "position",
            HostGeometry::Depth { .. } => "depth",
        };
        let output_role = match self.write {
            OutputWrite::Copy => "output (copy)",
            _ => "output (store, add)",
        };
        let radiance = "radiance (s0, sources)";
        let first = |name, role, image| NamedImage::new(name, role, image, extent, &same);
        let mut named = vec![
            first(geometry_role, geometry_role, geometry),
            first("normal", normal_role, &self.normal),
            first("albedo", "albedo", &self.albedo),
            first("s0", radiance, &self.s0),
            first("output", output_role, &self.output),
        ];
        named.extend(self.sources.as_ref().map(|s| first("sources", radiance, s)));
        let Some(hidden) = &self.hidden else {
            return (named, None);
        };
        let half = LayerResolution::Half.extent(extent);
        let r = if hidden.position.extent == half && half != extent {
            LayerResolution::Half
        } else {
            LayerResolution::Full
        };
        let layer1_extent = r.extent(extent);
        let either = format!(
            "the size of the geometry image ({extent:?}) or half of it, rounded up ({half:?})"
        );
        let like = format!("{layer1_extent:?}, the size of the second layer's position image");
        let second = |name, image, what: &String| {
            NamedImage::new(name, "second layer (all four)", image, layer1_extent, what)
        };
        named.extend([
            second("second layer's position", &hidden.position, &either),
            second("second layer's normal", &hidden.normal, &like),
            second("second layer's albedo", &hidden.albedo, &like),
            second("second layer's s0", &hidden.s0, &like),
        ]);
        (named, Some(r))
    }

    /// What formats and sizes alone do not say: channels the receivers'
    /// BRDF needs, depth without matrices, an output that is an input,
    /// non-finite parameters.
    fn check_semantics(&self) -> Result<()> {
        let bad = |what: String| {
            Err(Error::InvalidParameter(format!(
                "SSBC post-process: {what}"
            )))
        };
        if self.receivers == ReceiverBrdf::MetallicRoughnessInW {
            if self.normal_encoding.two_channels() || narrow_alpha(self.normal.format) {
                return bad(format!(
                    "MetallicRoughnessInW reads the roughness from the normal image's w: a {:?} {:?} normal has none",
                    self.normal_encoding, self.normal.format
                ));
            }
            if narrow_alpha(self.albedo.format) {
                return bad(format!(
                    "MetallicRoughnessInW reads the metallic from the albedo image's w: {:?} has 2 bits there",
                    self.albedo.format
                ));
            }
        }
        if let HostGeometry::Depth { background, .. } = self.geometry {
            if !matches!(self.camera, HostCamera::Matrices { .. }) {
                return bad(
                    "a depth image needs the camera as matrices (HostCamera::Matrices)".into(),
                );
            }
            if !background.is_finite() {
                return bad(format!("the background depth {background} is not finite"));
            }
        }
        let inputs = [
            Some(self.geometry.image()),
            Some(&self.normal),
            Some(&self.albedo),
            self.sources.as_ref(),
        ];
        let hidden = self
            .hidden
            .iter()
            .flat_map(|l| [&l.position, &l.normal, &l.albedo, &l.s0]);
        if inputs
            .into_iter()
            .flatten()
            .chain(hidden)
            .any(|i| i.image == self.output.image)
        {
            return bad(
                "the output image is one of the inputs (only the s0 image may be the output)"
                    .into(),
            );
        }
        if !self.typical_depth.is_finite() || self.bound.is_nan() || self.bound <= 0.0 {
            return bad("depth and bound must be finite and positive".into());
        }
        Ok(())
    }
}

/// One of the host's images as checked: its name in messages, its use in
/// [`FORMATS`], the size it must have and how to say it.
struct NamedImage<'a> {
    name: &'static str,
    role: &'static str,
    image: &'a HostImage,
    extent: (u32, u32),
    size_rule: String,
}

impl<'a> NamedImage<'a> {
    fn new(
        name: &'static str,
        role: &'static str,
        image: &'a HostImage,
        extent: (u32, u32),
        size_rule: &str,
    ) -> Self {
        Self {
            name,
            role,
            image,
            extent,
            size_rule: size_rule.to_string(),
        }
    }

    /// An error naming the image if its format is not one its use accepts
    /// or its size is not the one it must have.
    fn check(&self) -> Result<()> {
        let (name, role, image) = (self.name, self.role, self.image);
        let accepted = formats(role);
        let what = if !accepted.contains(&image.format) {
            format!(
                "{:?}; as {role} it must be one of {accepted:?}",
                image.format
            )
        } else if image.extent != self.extent {
            format!("{:?}; it must be {}", image.extent, self.size_rule)
        } else {
            return Ok(());
        };
        Err(Error::InvalidParameter(format!(
            "SSBC post-process: the {name} image is {what}"
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::FORMATS;

    /// The module documentation's table lists every accepted format, in
    /// the row of its use.
    #[test]
    fn the_documented_table_is_the_accepted_formats() {
        let docs = include_str!("mod.rs");
        let rows: Vec<&str> = docs.lines().filter(|l| l.starts_with("//! | ")).collect();
        let row_of = |role: &str| {
            let key = match role {
                "position" => "geometry: position",
                "depth" => "geometry: depth",
                "normal (xyz)" => "`Signed` / `Unsigned`",
                "normal (octahedral)" => "`Octahedral` / `OctahedralUnsigned`",
                "albedo" => "| albedo",
                "radiance (s0, sources)" => "S0 and sources",
                "output (copy)" => "[`OutputWrite::Copy`]",
                "output (store, add)" => "[`OutputWrite::Store`]",
                _ => "optional second layer",
            };
            rows.iter()
                .find(|r| r.contains(key))
                .copied()
                .unwrap_or_else(|| panic!("no row for {role}"))
        };
        for (role, formats) in FORMATS {
            let row = row_of(role);
            let formats_cell = row.split(" | ").nth(2).unwrap_or("");
            let listed = formats_cell.matches('`').count() / 2;
            assert_eq!(listed, formats.len(), "{role}: {formats_cell}");
            for format in formats.iter() {
                assert!(
                    formats_cell.contains(&format!("`{format:?}`")),
                    "{role}: {format:?} not in {formats_cell}"
                );
            }
        }
    }
}
