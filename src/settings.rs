//! What to render and how: the renderer's configuration, a frame's
//! settings, the clamping bound, light tracing and the SSBC parameters.
//! Plain data with the checks that need no device; errors name the
//! settings (`ssbc.steps`, `interleave`, ...).
//!
//! ```
//! use ssbc::settings::{Gather, Integration, RenderSettings};
//! let mut settings = RenderSettings::new(320, 240); // the defaults for that size
//! settings.gather = "full".parse().unwrap();
//! settings.ssbc.integration = Integration::Brute;
//! settings.ssbc.steps = 2;
//! assert_eq!(settings.gather, Gather::Full);
//! assert!(settings.validate().is_ok());
//! settings.interleave = 9;
//! settings.gather = Gather::Interleaved;
//! assert!(settings.validate().unwrap_err().to_string().contains("interleave"));
//! ```

use crate::error::{Error, Result};
use crate::vk::DeviceSelector;

/// Light-tracing parameters (VPL distribution).
#[derive(Clone, Debug, PartialEq)]
pub struct VplSettings {
    /// Number of VPLs wanted (paths are traced until there are this many).
    pub count: usize,
    /// Most diffuse hits per path (>= 1): a safety net, Russian roulette
    /// ends paths (an explicit lower limit biases the result).
    pub bounces: u32,
    /// Seed of the low-discrepancy sequence.
    pub seed: u64,
    /// Index of the first light path in the sequence: 0 for a frame of its
    /// own; for progressive refinement, the paths the frames before it
    /// traced, so that a frame continues the sequence with the next paths.
    pub first_path: u64,
}

impl Default for VplSettings {
    fn default() -> Self {
        Self {
            count: 256,
            bounces: DEFAULT_BOUNCES,
            seed: 0,
            first_path: 0,
        }
    }
}

/// The default limit on a light path's diffuse hits: high enough that
/// Russian roulette ends practically every path first (albedo 0.8 leaves
/// 0.8^64 = 6e-7 of the light beyond it).
pub const DEFAULT_BOUNCES: u32 = 64;

/// Enums of settings by name: the names [`NamedChoice::NAMES`] lists, as
/// `FromStr` parses them and `Display` writes them (for command lines and
/// configuration files).
pub trait NamedChoice: Sized + Copy + 'static {
    /// Every value, in the order of [`NamedChoice::NAMES`].
    const ALL: &'static [Self];
    /// Their names.
    const NAMES: &'static [&'static str];
    /// The name of this value.
    fn name(self) -> &'static str {
        let i = Self::ALL
            .iter()
            .position(|v| std::mem::discriminant(v) == std::mem::discriminant(&self))
            .expect("every value is listed");
        Self::NAMES[i]
    }
    /// The value called `name`.
    fn from_name(name: &str) -> Result<Self> {
        Self::NAMES
            .iter()
            .position(|n| *n == name)
            .map(|i| Self::ALL[i])
            .ok_or_else(|| {
                Error::InvalidParameter(format!(
                    "'{name}' is not one of {}",
                    Self::NAMES.join(", ")
                ))
            })
    }
}

/// `FromStr` and `Display` through [`NamedChoice`].
macro_rules! named_choice {
    ($ty:ty, [$($value:expr => $name:literal),+ $(,)?]) => {
        impl NamedChoice for $ty {
            const ALL: &'static [Self] = &[$($value),+];
            const NAMES: &'static [&'static str] = &[$($name),+];
        }
        impl std::str::FromStr for $ty {
            type Err = Error;
            fn from_str(s: &str) -> Result<Self> {
                <$ty as NamedChoice>::from_name(s)
            }
        }
        impl std::fmt::Display for $ty {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(NamedChoice::name(*self))
            }
        }
    };
}
pub(crate) use named_choice;

/// How to create the renderer.
#[derive(Clone, Debug, Default)]
pub struct RendererConfig {
    /// Enable the Khronos validation layer with synchronization validation.
    pub validation: bool,
    /// Enable it with GPU-assisted validation instead (out-of-bounds
    /// accesses in shaders; slow).
    pub gpu_assisted_validation: bool,
    /// Which device to use.
    pub device: DeviceSelector,
    /// Do not time passes with timestamp queries (timings are then absent,
    /// as on a queue without timestamps; labels and names stay).
    pub no_gpu_timestamps: bool,
    /// Do not count shader invocations per pass (pipeline-statistics
    /// queries, used by default where the device supports them; a driver
    /// may count at a cost, which this switch rules out of a measurement).
    pub no_pipeline_statistics: bool,
}

/// The clamping bound b of the geometry term (1/m²).
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub enum Bound {
    /// Derived from the scene: b = (10 / diagonal)², i.e. clamping starts at a
    /// tenth of the scene's bounding-box diagonal.
    #[default]
    Auto,
    /// A fixed value (`f32::INFINITY`: no clamping).
    Value(f32),
    /// [`Bound::Auto`] in a view that converges (an accumulation's, a still
    /// view's history frames) once it has averaged n sets of
    /// [`BOUND_VPLS`] VPLs: Auto's b x sqrt(n). The clamped light, which
    /// SSBC returns only in part (0.3% of the open box's mean), falls as
    /// the clamping radius 1/sqrt(b) shrinks, while the noise of the
    /// unclamped VPLs near a receiver, which grows with b, averages over the
    /// frames (docs/accuracy.md, "A clamping bound that grows as frames
    /// accumulate"). What `render_accumulated` and a still view take where
    /// the bound is `Auto`.
    Converging(u32),
}

/// The VPLs a frame needs for [`Bound::Auto`]'s clamping radius (the fewest
/// [`auto_vpl_count`] gives): a converging view clamps less once it has
/// averaged more of them ([`Bound::Converging`]).
pub const BOUND_VPLS: usize = 2048;

impl Bound {
    /// The value for a scene whose bounding-box diagonal is `diagonal`.
    pub fn resolve(self, diagonal: f32) -> f32 {
        match self {
            Bound::Auto => (10.0 / diagonal.max(1e-6)).powi(2),
            Bound::Value(b) => b,
            Bound::Converging(n) => Bound::Auto.resolve(diagonal) * (n.max(1) as f32).sqrt(),
        }
    }

    /// The bound of the k-th frame (1-based) of a view that converges with
    /// `vpls` VPLs a frame: [`Bound::Converging`] where this is `Auto` and
    /// the view has averaged at least two sets of [`BOUND_VPLS`] VPLs
    /// after its first frame (which stays a single frame's), else this.
    pub fn converging(self, k: u32, vpls: usize) -> Bound {
        let sets = (k as u64).saturating_mul(vpls as u64) / BOUND_VPLS as u64;
        match self {
            Bound::Auto | Bound::Converging(_) if k > 1 && sets > 1 => {
                Bound::Converging(sets.min(u32::MAX as u64) as u32)
            }
            Bound::Converging(_) => Bound::Auto,
            b => b,
        }
    }

    /// The widest clamping radius a converging view takes with this bound
    /// (its first frame's): `Auto` for [`Bound::Converging`].
    pub fn widest(self) -> Bound {
        match self {
            Bound::Converging(_) => Bound::Auto,
            b => b,
        }
    }
}

/// What to render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Camera index into `Scene::cameras` (None: the first, or a framing one).
    pub camera: Option<usize>,
    /// Shadow-map side in texels.
    pub shadow_map_size: u32,
    /// VPL distribution (count 0 switches indirect light off; see
    /// [`auto_vpl_count`] for the default's).
    pub vpl: VplSettings,
    /// ISM tile side in texels (power of two).
    pub ism_tile: u32,
    /// Scene points each VPL splats into its ISM.
    pub points_per_vpl: u32,
    /// Splatted ISMs also keep a back-face map per VPL: the nearest surface
    /// seen from behind, where a ray leaves a closed solid. A receiver
    /// beyond one is hidden whatever the front map's tolerance lets
    /// through, which cuts the light leaked through thin walls by 40% (two
    /// rooms sharing a 1 mm wall: 0.087 -> 0.052 of the occluded light),
    /// for twice the atlas's memory and about 1.1x the frame at 320x240
    /// (docs/accuracy.md, "A back-face map"). Off by default: a frame on
    /// its own stays within 1.3x the cost issue 61 allows;
    /// [`Renderer::render_accumulated`](crate::Renderer::render_accumulated)
    /// turns it on where [`Visibility::Auto`] stays ISMs (no ray queries).
    /// Ignored by traced ISMs and exact visibility.
    pub ism_back_faces: bool,
    /// How the bounded VPL lighting visits the VPLs.
    pub gather: Gather,
    /// How it tests whether a VPL sees a receiver.
    pub visibility: Visibility,
    /// Side N of the interleaved pattern: N x N subsets of the VPLs.
    pub interleave: u32,
    /// Clamping bound b.
    pub bound: Bound,
    /// Bias compensation.
    pub ssbc: SsbcSettings,
    /// Read back the component layers with the final image: direct, bounded
    /// indirect and each SSBC step's residual ([`Layer::outputs`](crate::Layer::outputs)).
    /// Off by default: each is 16 bytes per pixel of host-visible memory
    /// (the final image and the texels read per pixel are always read back).
    pub output_layers: bool,
    /// Also read back the G-buffer and the ISM atlas (for tests and tools;
    /// implies `output_layers`).
    pub debug_readback: bool,
    /// Keep the shadow maps and ISMs of the frame slot's previous frame
    /// when the lights, surfaces, VPLs and their settings did not change
    /// (resident scenes where only the camera moved; immediate-mode frames
    /// never match). Off: every frame redraws them (for comparisons).
    pub reuse_unchanged: bool,
    /// Temporal history of resident frames (see [`HistorySettings`]).
    pub history: HistorySettings,
}

/// Temporal history: what a [`ResidentScene`](crate::resident::ResidentScene)
/// frame keeps of the frames before it. The indirect light (bounded +
/// SSBC's residual: the final image minus the direct light) is a running
/// mean per pixel over the frames whose surfaces, lights and view it can
/// still use:
///
/// | since the last frame | the frame | history |
/// |---|---|---|
/// | nothing changed | traces the next light paths (new VPLs, ISMs) | running mean, up to `max_frames` |
/// | the camera moved | keeps the VPLs (and ISMs; new ones with `new_vpls_while_moving`) | reprojected; pixels whose surface was not seen (depth, normal) start anew; at most `moving_frames` |
/// | lights changed, objects moved | the same light paths in the changed scene | kept where the surface is the same and the indirect light changed little (4x4-block means), at most `light_frames`; dropped where it changed by `light_change` or more |
/// | meshes, materials, settings, objects added or removed | everything | dropped |
///
/// Setting a camera or lights equal to the last frame's is no change (an
/// engine may set them every frame).
///
/// Immediate-mode frames ([`Renderer::render`](crate::Renderer::render))
/// have none. Frames recorded into a host's command buffer
/// ([`Renderer::record_resident`](crate::Renderer::record_resident)) keep
/// it while the host alternates the frame slots.
#[derive(Clone, Debug, PartialEq)]
pub struct HistorySettings {
    /// Keep history (off: every resident frame stands alone).
    pub enabled: bool,
    /// Most frames a still view's running mean averages (beyond, an
    /// exponential mean with weight 1 / `max_frames`).
    pub max_frames: u32,
    /// Most frames of history a moving camera keeps (each reprojection
    /// resamples the history bilinearly, which blurs it a little).
    pub moving_frames: u32,
    /// A moving camera's frames trace new light paths too (their own VPLs
    /// and ISMs, as still frames do): the history keeps converging while
    /// the camera moves, at the cost of VPL tracing and ISMs each frame.
    /// Off (the default), they keep the last VPL set and its ISMs, and the
    /// history drifts towards that one set's noise (measured in
    /// docs/performance.md).
    pub new_vpls_while_moving: bool,
    /// Where visibility cannot be exact ([`Visibility::Auto`] without ray
    /// queries, or with alpha-masked materials), a still view's frames
    /// after its first take the ISMs an accumulation takes there (back-face
    /// maps, at least [`CONVERGING_ISM_TILE`] texels and
    /// [`CONVERGING_POINTS_PER_VPL`] points), so that the view converges
    /// where [`Renderer::render_accumulated`](crate::Renderer::render_accumulated)
    /// does, for 2.1-2.3x the frame and a larger atlas and point set when
    /// the view stops (counted by
    /// [`frame_memory_of`](crate::renderer::frame_memory_of)). Off (the
    /// library's default: a host's resident slot keeps the memory it
    /// budgeted), they keep the host's ISMs and converge to their bias.
    /// The viewer turns it on.
    pub converging_isms: bool,
    /// Most frames of history kept when the lights changed.
    pub light_frames: u32,
    /// Relative change of a 4x4 block's mean indirect light at which the
    /// history is dropped when lights changed (the weight of history falls
    /// linearly from `light_frames` at no change to none at this change).
    pub light_change: f32,
}

impl Default for HistorySettings {
    fn default() -> Self {
        Self {
            enabled: true,
            max_frames: 1024,
            moving_frames: 32,
            new_vpls_while_moving: false,
            converging_isms: false,
            light_frames: 4,
            light_change: 0.25,
        }
    }
}

impl HistorySettings {
    fn validate(&self) -> Result<()> {
        let frames = [self.max_frames, self.moving_frames, self.light_frames];
        if frames.iter().any(|&n| n == 0 || n > 1 << 20) {
            return Err(Error::InvalidParameter(format!(
                "history.max_frames, moving_frames and light_frames must be in 1..=1048576 (are {frames:?})"
            )));
        }
        if !(self.light_change.is_finite() && self.light_change > 0.0) {
            return Err(Error::InvalidParameter(format!(
                "history.light_change must be positive (is {})",
                self.light_change
            )));
        }
        Ok(())
    }
}

/// The default number of VPLs for a `width` x `height` image: one per 150
/// pixels (rounded down to a multiple of 256), at least 2048 and at most
/// 8192. The interleaved gather's cost grows with pixels x VPLs, the ISMs'
/// with VPLs alone: at 320x240 2048 VPLs (ISMs are a third of the frame)
/// cost what 256 used to with the full gather, at 1024x768 5120 keep one
/// SSBC step within about a third of the rest of the frame (measurements
/// in docs/performance.md).
pub fn auto_vpl_count(width: u32, height: u32) -> usize {
    let per_pixels = (width as u64 * height as u64 / 150) as usize / 256 * 256;
    per_pixels.clamp(2048, 8192)
}

impl RenderSettings {
    /// The defaults for a `width` x `height` image (with the VPL count
    /// [`auto_vpl_count`] chooses for it).
    pub fn new(width: u32, height: u32) -> Self {
        let mut s = Self {
            width,
            height,
            ..Default::default()
        };
        s.vpl.count = auto_vpl_count(width, height);
        s
    }

    /// Whether the frame makes every output layer, those made on request
    /// too ([`Layer::on_request`](crate::Layer::on_request)).
    pub(crate) fn every_output(&self) -> bool {
        self.output_layers || self.debug_readback
    }
}

impl Default for RenderSettings {
    /// 1024x768, and what [`RenderSettings::new`] gives for that size.
    fn default() -> Self {
        Self {
            width: 1024,
            height: 768,
            camera: None,
            shadow_map_size: 1024,
            vpl: VplSettings {
                count: auto_vpl_count(1024, 768),
                ..Default::default()
            },
            ism_tile: 32,
            // 1280 points fill more of the discs' holes (open box 64 frames,
            // relMSE 4x4 0.00114 -> 0.00102), filling one-texel holes does
            // more (0.00093) without the 1.4 bytes a pixel at 1920x1080 and
            // the darker curved shadows (docs/accuracy.md, "Holes filled
            // between two texels of one plane").
            points_per_vpl: 1024,
            ism_back_faces: false,
            gather: Gather::Interleaved,
            visibility: Visibility::Auto,
            interleave: 4,
            bound: Bound::Auto,
            ssbc: SsbcSettings::default(),
            output_layers: false,
            debug_readback: false,
            reuse_unchanged: true,
            history: HistorySettings::default(),
        }
    }
}

impl RenderSettings {
    /// The side of the interleaved pattern: 1 for the full gather.
    pub fn pattern_side(&self) -> u32 {
        match self.gather {
            Gather::Full => 1,
            Gather::Interleaved => self.interleave,
        }
    }

    /// Checks what needs no device.
    pub fn validate(&self) -> Result<()> {
        if self.gather == Gather::Interleaved && !(2..=4).contains(&self.interleave) {
            return Err(Error::InvalidParameter(format!(
                "interleave {} must be in 2..=4 (or gather full)",
                self.interleave
            )));
        }
        self.history.validate()?;
        self.ssbc.validate()
    }
}

/// How the bounded VPL lighting `T_b L^` visits the VPLs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Gather {
    /// Interleaved sampling (Keller & Heidrich 2001; Segovia et al. 2006):
    /// the VPLs are split into N x N random subsets, each pixel of an N x N
    /// block evaluates one of them, and a depth- and normal-aware filter
    /// over each pixel's N x N neighbourhood sums the subsets back on each
    /// surface.
    #[default]
    Interleaved,
    /// Every VPL at every pixel (the reference).
    Full,
}

/// How the bounded VPL lighting tests whether a VPL sees a receiver.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Visibility {
    /// Imperfect shadow maps for a frame on its own; for the frames that
    /// converge (those of an accumulation,
    /// [`Renderer::render_accumulated`](crate::Renderer::render_accumulated),
    /// and a still view's history frames after its first), exact where the
    /// device has ray queries and the scene no alpha-masked materials,
    /// else finer ISMs with back-face maps ([`CONVERGING_ISM_TILE`]; for a
    /// still view's frames, with [`HistorySettings::converging_isms`]).
    #[default]
    Auto,
    /// Imperfect shadow maps (every device).
    Ism,
    /// Imperfect shadow maps whose texels are traced instead of splatted:
    /// each holds where its own centre ray meets the scene, and that
    /// triangle's plane (VK_KHR_ray_query; opaque materials; an error where
    /// unavailable). No holes and no splats past a surface's edge, at one
    /// ray a texel (docs/accuracy.md, "ISM texels traced" and "ISM tiles
    /// by projected solid angle").
    Traced,
    /// Ray queries against the scene's acceleration structures
    /// (VK_KHR_ray_query; opaque materials): exact, and an error where
    /// unavailable.
    Exact,
}

impl Visibility {
    /// Whether a frame's ISMs are splatted from points over a ray-cast
    /// layer (the CPU samples the points and casts the layer's corner
    /// rays only for such frames).
    pub fn splats_points(self) -> bool {
        matches!(self, Visibility::Auto | Visibility::Ism)
    }
}

/// The least ISM tile side of frames that converge with ISMs
/// ([`Visibility::Auto`] without exact visibility): a still view ends at
/// its visibility's bias, which finer ISMs cut once noise no longer hides
/// it. The open box's 64 frames at 320x240 with back-face maps, against a
/// 16384-spp path tracer: relMSE on 4x4 blocks 0.00048 -> 0.00031, mean
/// 0.993 -> 0.995, for 2.1-2.3x the frame on lavapipe (docs/accuracy.md, "Finer ISMs for frames that
/// converge").
pub const CONVERGING_ISM_TILE: u32 = 64;

/// The least points per VPL of frames that converge with ISMs: as many a
/// texel as the default's (four times [`CONVERGING_ISM_TILE`]'s texels).
pub const CONVERGING_POINTS_PER_VPL: u32 = 4096;

/// The widest interleaved pattern of frames that converge: N x N subsets
/// of the VPLs, each pixel one. The filter that sums the subsets back
/// averages a pixel's neighbours on its own surface, and what it blurs
/// across (a sub-pixel wall, a crease's edge) is a bias that averaging
/// frames does not remove; a 2 x 2 window blurs a quarter of the 4 x 4's.
/// The open box's 64 frames at 320x240 against a 16384-spp path tracer
/// (relMSE on 4x4 blocks; mean): exact visibility 0.00024, 0.9989 ->
/// 0.00019, 0.9994 (2x the frame on lavapipe); converging ISMs 0.00028,
/// 0.9970 -> 0.00023, 0.9975 (1.3x). Two rooms sharing a 1 mm wall, 4
/// converging ISM frames: 0.76% -> 0.24% of the image's mean in the unlit
/// room (docs/accuracy.md, "A finer interleaving for frames that
/// converge").
pub const CONVERGING_INTERLEAVE: u32 = 2;

impl RenderSettings {
    /// Whether the frame's ISM atlas holds back-face maps: asked for, and
    /// its ISMs splatted.
    pub fn ism_back_face_maps(&self) -> bool {
        self.ism_back_faces && self.visibility.splats_points()
    }

    /// [`Visibility::Auto`] for frames that converge (an accumulation, a
    /// still view's history frames): independent VPL sets average their noise
    /// away but not ISM visibility's bias, so exact visibility where the
    /// device and the scene allow it (`exact`), else ISMs with back-face
    /// maps (their leaks through thin walls halved) and, where the device
    /// takes their atlas (`finer_fits`), at least [`CONVERGING_ISM_TILE`]
    /// texels and [`CONVERGING_POINTS_PER_VPL`] points; either way an
    /// interleaved pattern of at most [`CONVERGING_INTERLEAVE`].
    pub(crate) fn resolve_auto_for_convergence(&mut self, exact: bool, finer_fits: bool) {
        self.interleave = self.interleave.min(CONVERGING_INTERLEAVE);
        if exact {
            self.visibility = Visibility::Exact;
            return;
        }
        self.visibility = Visibility::Ism;
        self.ism_back_faces = true;
        if finer_fits {
            self.ism_tile = self.ism_tile.max(CONVERGING_ISM_TILE);
            self.points_per_vpl = self.points_per_vpl.max(CONVERGING_POINTS_PER_VPL);
        }
    }
}

/// How each residual step integrates over the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Integration {
    /// Top-down over the mip chains (the paper's method).
    #[default]
    Hierarchical,
    /// Every full-resolution pixel within the bounding radius (the reference).
    Brute,
}

/// How SSBC runs the evaluation points and fallback pixels at glossy
/// receivers and at the others, in frames with glossy receivers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ReceiverDispatch {
    /// One dispatch on GPUs, two kernels on CPU devices (lavapipe).
    #[default]
    Auto,
    /// One dispatch for both kinds (the glossy kernels): a GPU's level
    /// takes as long as its slowest walk, so a second kernel adds its whole
    /// time.
    One,
    /// The kernel without the glossy code for the others, then the glossy
    /// kernel: a CPU device runs every side of a branch, so Lambertian
    /// receivers are cheaper without the glossy code.
    Two,
}

/// The resolution of the deep G-buffer's second layer (`ssbc.layers` 2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LayerResolution {
    /// One layer-1 pixel per image pixel: its pixels are split at creases
    /// like layer 0's, and it gives back most (see docs/ssbc-implementation.md).
    #[default]
    Full,
    /// One per 2 x 2 image pixels (a quarter of its G-buffer, lighting and
    /// pyramid cost).
    Half,
}

named_choice!(Gather, [Gather::Interleaved => "interleaved", Gather::Full => "full"]);
named_choice!(Integration, [Integration::Hierarchical => "hierarchical", Integration::Brute => "brute"]);
named_choice!(Visibility, [Visibility::Auto => "auto", Visibility::Ism => "ism", Visibility::Traced => "traced", Visibility::Exact => "exact"]);
named_choice!(LayerResolution, [LayerResolution::Full => "full", LayerResolution::Half => "half"]);

impl LayerResolution {
    /// log2 of a pixel's side in image pixels.
    pub fn shift(self) -> u32 {
        match self {
            Self::Full => 0,
            Self::Half => 1,
        }
    }

    /// The layer's extent for an image of `extent` (rounded up).
    pub fn extent(self, extent: (u32, u32)) -> (u32, u32) {
        let side = 1 << self.shift();
        (extent.0.div_ceil(side), extent.1.div_ceil(side))
    }
}

/// SSBC parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct SsbcSettings {
    /// Number of residual steps K (0 = no compensation). One by default: a
    /// second gains little against a path-traced reference for its cost
    /// (docs/accuracy.md, "Tuned constants").
    pub steps: u32,
    /// Integration method.
    pub integration: Integration,
    /// Lower clamp of cos(theta_view) in A_y (conservative grazing-angle compensation).
    pub min_cos_view: f32,
    /// Refine a texel whose bounding sphere's radius exceeds this fraction of
    /// its distance to x... 0.16: the coarsest that keeps the hierarchical
    /// residual within 2% of brute force (tests/ssbc.rs) (docs/accuracy.md, "Tuned constants").
    pub refine_ratio: f32,
    /// ...but only if G can exceed (1 + refine_excess) b somewhere in it: a
    /// cluster where max(G - b, 0) <= refine_excess b adds at most that per
    /// unit of A_y S(y), error included, however large it is (docs/accuracy.md, "Tuned constants").
    pub refine_excess: f32,
    /// A texel is one smooth surface ("continuous", usable as an evaluation
    /// point) if the mean of its unit normals is at least this long...
    pub max_normal_spread: f32,
    /// ...and its bounding slab is at most this x its bounding radius thick.
    pub max_thickness: f32,
    /// The residual is evaluated at the texels of the coarsest pyramid level
    /// (up to `max_eval_level`) that still puts this many texels across the
    /// bounding radius 1/sqrt(b) on screen, and interpolated to the pixels
    /// that lie on the same smooth surface; other pixels are evaluated alone.
    pub texels_per_radius: f32,
    /// Coarsest evaluation level (0: every pixel is evaluated alone).
    pub max_eval_level: u32,
    /// A pixel interpolates only from points closer to it than this fraction
    /// of their variation scale: the length over which I(x) changes there,
    /// estimated as the contribution-weighted harmonic mean of the distances
    /// to what they gather from (short near corners and contacts)
    /// (docs/accuracy.md, "Tuned constants").
    pub scale_fraction: f32,
    /// G-buffer layers SSBC gathers from: 1 (the visible surfaces), or 2: a
    /// deep G-buffer's second layer (at `layer1_resolution`), the nearest surfaces
    /// at least `layer_separation` behind the visible ones, back faces
    /// included, with their own direct and bounded VPL lighting (Mara et
    /// al., HPG 2016). Surfaces hidden from the camera then give back the
    /// light they send to visible ones.
    pub layers: u32,
    /// The second layer's resolution.
    pub layer1_resolution: LayerResolution,
    /// Minimum separation of layer 1 behind layer 0, as a fraction of the
    /// scene's bounding-box diagonal.
    pub layer_separation: f32,
    /// Render a guard band: the view widened on every side by 1/sqrt(b)
    /// seen at the nearest visible depth (at most half the image's shorter
    /// side), so that surfaces just outside the image are sources too; the
    /// image is cropped back. Off by default: little of the true residual
    /// comes from there, for up to 4x the pixels
    /// (docs/ssbc-implementation.md). Not in the viewer.
    pub guard_band: bool,
    /// How receivers of both kinds are dispatched (the same image either way).
    pub receiver_dispatch: ReceiverDispatch,
}

impl Default for SsbcSettings {
    fn default() -> Self {
        Self {
            steps: 1,
            integration: Integration::Hierarchical,
            min_cos_view: 0.2,
            refine_ratio: 0.16,
            refine_excess: 1.5,
            max_normal_spread: 0.9,
            max_thickness: 0.25,
            texels_per_radius: 8.0,
            max_eval_level: 4,
            scale_fraction: 0.2,
            layers: 1,
            layer1_resolution: LayerResolution::Full,
            layer_separation: 0.002,
            guard_band: false,
            receiver_dispatch: ReceiverDispatch::Auto,
        }
    }
}

impl SsbcSettings {
    /// The second layer's resolution with `layers` 2, else None.
    pub fn second_layer(&self) -> Option<LayerResolution> {
        (self.layers >= 2).then_some(self.layer1_resolution)
    }

    /// The cheaper second layer to suggest when a frame does not fit.
    pub(crate) fn lighter_second_layer(layer1: Option<LayerResolution>) -> &'static str {
        match layer1 {
            Some(LayerResolution::Full) => ", with ssbc.layer1_resolution half",
            Some(LayerResolution::Half) => ", with ssbc.layers 1",
            None => "",
        }
    }

    /// Checks the parameters.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::InvalidParameter(m));
        if self.steps > 16 {
            return bad(format!("ssbc.steps {} (at most 16)", self.steps));
        }
        if !(1..=2).contains(&self.layers) {
            return bad(format!("ssbc.layers {} must be 1 or 2", self.layers));
        }
        if !(self.layer_separation >= 0.0 && self.layer_separation <= 1.0) {
            return bad(format!(
                "ssbc.layer_separation {} must be in [0, 1] (of the scene's diagonal)",
                self.layer_separation
            ));
        }
        if !(self.min_cos_view > 0.0 && self.min_cos_view <= 1.0) {
            return bad(format!(
                "ssbc.min_cos_view {} must be in (0, 1]",
                self.min_cos_view
            ));
        }
        if !(self.refine_ratio > 0.0 && self.refine_ratio.is_finite()) {
            return bad(format!(
                "ssbc.refine_ratio {} must be positive",
                self.refine_ratio
            ));
        }
        if !(self.refine_excess >= 0.0 && self.refine_excess.is_finite()) {
            return bad(format!(
                "ssbc.refine_excess {} must be at least 0",
                self.refine_excess
            ));
        }
        if !(self.texels_per_radius >= 1.0 && self.texels_per_radius.is_finite()) {
            return bad(format!(
                "ssbc.texels_per_radius {} must be at least 1",
                self.texels_per_radius
            ));
        }
        if !(self.scale_fraction > 0.0 && self.scale_fraction.is_finite()) {
            return bad(format!(
                "ssbc.scale_fraction {} must be positive",
                self.scale_fraction
            ));
        }
        if self.max_eval_level > 8 {
            return bad(format!(
                "ssbc.max_eval_level {} (at most 8)",
                self.max_eval_level
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_reject_absurd_refinement() {
        assert!(SsbcSettings::default().validate().is_ok());
        for refine_excess in [-0.5, f32::NAN, f32::INFINITY] {
            let s = SsbcSettings {
                refine_excess,
                ..Default::default()
            };
            assert!(s.validate().is_err(), "refine_excess {refine_excess}");
        }
        for refine_ratio in [0.0, -1.0, f32::NAN] {
            let s = SsbcSettings {
                refine_ratio,
                ..Default::default()
            };
            assert!(s.validate().is_err(), "refine_ratio {refine_ratio}");
        }
        // 0: refine every cluster larger than the ratio (the former rule).
        let s = SsbcSettings {
            refine_excess: 0.0,
            ..Default::default()
        };
        assert!(s.validate().is_ok());
    }

    #[test]
    fn converging_frames_without_ray_queries_keep_finer_back_face_maps() {
        let mut settings = RenderSettings::new(64, 48);
        assert!(!settings.ism_back_face_maps(), "a single frame's default");
        settings.resolve_auto_for_convergence(false, true);
        assert_eq!(settings.visibility, Visibility::Ism);
        assert!(settings.ism_back_face_maps());
        assert_eq!(settings.ism_tile, CONVERGING_ISM_TILE);
        assert_eq!(settings.points_per_vpl, CONVERGING_POINTS_PER_VPL);
        // Finer than that already: kept.
        let mut settings = RenderSettings::new(64, 48);
        settings.ism_tile = 128;
        settings.resolve_auto_for_convergence(false, true);
        assert_eq!(settings.ism_tile, 128);
        // An atlas the device would not take: the host's ISMs.
        let mut settings = RenderSettings::new(64, 48);
        settings.resolve_auto_for_convergence(false, false);
        assert!(settings.ism_back_face_maps());
        assert_eq!(settings.ism_tile, RenderSettings::new(64, 48).ism_tile);
        let mut settings = RenderSettings::new(64, 48);
        settings.resolve_auto_for_convergence(true, true);
        assert_eq!(settings.visibility, Visibility::Exact);
        assert!(
            !settings.ism_back_face_maps(),
            "exact visibility draws no atlas"
        );
    }

    #[test]
    fn converging_frames_interleave_finer() {
        for (exact, fits) in [(true, true), (false, true), (false, false)] {
            let mut settings = RenderSettings::new(64, 48);
            assert_eq!(settings.interleave, 4, "a single frame's default");
            settings.resolve_auto_for_convergence(exact, fits);
            assert_eq!(settings.interleave, CONVERGING_INTERLEAVE);
            assert!(settings.validate().is_ok());
        }
        // Finer than that already: kept.
        let mut settings = RenderSettings::new(64, 48);
        settings.interleave = 2;
        settings.resolve_auto_for_convergence(true, true);
        assert_eq!(settings.interleave, 2);
    }

    #[test]
    fn a_converging_view_clamps_less_as_it_averages_vpls() {
        let auto = Bound::Auto.resolve(2.0);
        let at = |b: Bound, k, vpls| b.converging(k, vpls).resolve(2.0) / auto;
        // The first frame is a single frame's; 2048-VPL frames grow as sqrt(k).
        assert_eq!(at(Bound::Auto, 1, 8192), 1.0);
        assert_eq!(at(Bound::Auto, 4, BOUND_VPLS), 2.0);
        assert_eq!(at(Bound::Auto, 2, 8192), 8f32.sqrt());
        // Few VPLs a frame: not before the view has averaged 2048 of them.
        assert_eq!(at(Bound::Auto, 32, 64), 1.0);
        assert_eq!(at(Bound::Auto, 128, 64), 2.0);
        // A bound the host chose stays.
        assert_eq!(Bound::Value(3.0).converging(64, 4096), Bound::Value(3.0));
        // A converging bound, reset by the first frame; its widest is Auto's.
        assert_eq!(Bound::Converging(9).converging(1, 2048), Bound::Auto);
        assert_eq!(Bound::Converging(9).widest(), Bound::Auto);
        assert_eq!(
            Bound::Auto.converging(u32::MAX, usize::MAX),
            Bound::Converging(u32::MAX)
        );
    }
}
