//! What a frame's timing figures are: clocks and CPU spans, per-pass GPU
//! times with the figures that explain them ([`Timings`]), and their
//! statistics over several frames ([`FrameStats`]). Measuring frames (warm
//! frames, traces) is the `profile` module's job.

use serde::Serialize;

use crate::settings::{Integration, Visibility};
use crate::vk::PassTiming;

/// Nanoseconds on CLOCK_MONOTONIC (on other systems: since the first call).
pub fn monotonic_ns() -> u64 {
    #[cfg(unix)]
    {
        let mut ts = libc::timespec {
            tv_sec: 0,
            tv_nsec: 0,
        };
        // SAFETY: `ts` is a valid out-pointer; CLOCK_MONOTONIC always exists.
        unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
        ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
    }
    #[cfg(not(unix))]
    {
        static EPOCH: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
        EPOCH
            .get_or_init(std::time::Instant::now)
            .elapsed()
            .as_nanos() as u64
    }
}

/// A CPU stage of a frame, on [`monotonic_ns`].
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct CpuSpan {
    /// Stage name (`bvh_build`, `vpl_generation`, ...).
    pub name: String,
    /// Start (ns, CLOCK_MONOTONIC).
    pub start_ns: u64,
    /// Duration (ns).
    pub duration_ns: u64,
}

impl CpuSpan {
    /// Times `f` as the stage `name`, appending the span to `spans`.
    pub fn time<T>(spans: &mut Vec<CpuSpan>, name: &str, f: impl FnOnce() -> T) -> T {
        let start_ns = monotonic_ns();
        let value = f();
        spans.push(CpuSpan::between(name, start_ns, monotonic_ns()));
        value
    }

    /// The stage `name` from `start_ns` to `end_ns`.
    pub fn between(name: &str, start_ns: u64, end_ns: u64) -> CpuSpan {
        CpuSpan {
            name: name.into(),
            start_ns,
            duration_ns: end_ns.saturating_sub(start_ns),
        }
    }

    /// Duration in milliseconds.
    pub fn ms(&self) -> f64 {
        self.duration_ns as f64 * 1e-6
    }
}

/// Minimum, median and maximum of one quantity over the measured frames.
#[derive(Clone, Copy, Debug, Serialize, PartialEq)]
pub struct Spread {
    /// Smallest value.
    pub min: f64,
    /// Median (the mean of the two middle values for an even count).
    pub median: f64,
    /// Largest value.
    pub max: f64,
}

impl Spread {
    /// The spread of `values` (None when empty).
    pub fn of(values: &[f64]) -> Option<Spread> {
        if values.is_empty() {
            return None;
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Some(Spread {
            min: v[0],
            median,
            max: v[n - 1],
        })
    }
}

/// One pass's (or CPU stage's) milliseconds over the measured frames.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PassStats {
    /// Pass name (as in [`crate::vk::PassTiming`]) or CPU stage name.
    pub name: String,
    /// Milliseconds (GPU for passes, CPU for stages).
    pub ms: Spread,
}

/// Statistics over N warm frames (the warm-up frame excluded).
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct FrameStats {
    /// Frames measured.
    pub frames: usize,
    /// Whole-frame GPU milliseconds (None without timestamps).
    pub frame_gpu_ms: Option<Spread>,
    /// Per-pass GPU milliseconds, in recording order (empty without timestamps).
    pub passes: Vec<PassStats>,
    /// CPU stages' milliseconds, in order.
    pub cpu_ms: Vec<PassStats>,
}

impl FrameStats {
    /// Statistics of `frames` (all rendered with the same settings).
    pub fn of(frames: &[Timings]) -> FrameStats {
        let frame_ms: Vec<f64> = frames.iter().filter_map(|t| t.frame_gpu_ms).collect();
        let per_name = |names: Vec<String>, value: &dyn Fn(&Timings, &str) -> Option<f64>| {
            names
                .into_iter()
                .filter_map(|name| {
                    let values: Vec<f64> = frames.iter().filter_map(|t| value(t, &name)).collect();
                    Spread::of(&values).map(|ms| PassStats { name, ms })
                })
                .collect::<Vec<_>>()
        };
        let first = frames.first();
        let pass_names = first
            .and_then(|t| t.passes.as_ref())
            .map(|p| p.iter().map(|p| p.name.clone()).collect())
            .unwrap_or_default();
        let cpu_names = first
            .map(|t| t.cpu_spans.iter().map(|s| s.name.clone()).collect())
            .unwrap_or_default();
        FrameStats {
            frames: frames.len(),
            frame_gpu_ms: Spread::of(&frame_ms),
            passes: per_name(pass_names, &|t, name| {
                t.passes
                    .as_ref()?
                    .iter()
                    .find(|p| p.name == name)
                    .map(|p| p.gpu_ms)
            }),
            cpu_ms: per_name(cpu_names, &|t, name| {
                t.cpu_spans.iter().find(|s| s.name == name).map(CpuSpan::ms)
            }),
        }
    }

    /// A printable table (ms).
    pub fn table(&self) -> String {
        let mut s = format!(
            "GPU ms over {} frames after one warm-up frame (min / median / max)\n",
            self.frames
        );
        let row = |s: &mut String, name: &str, v: &Spread| {
            s.push_str(&format!(
                "  {name:<32} {:>10.3} {:>10.3} {:>10.3}\n",
                v.min, v.median, v.max
            ));
        };
        for p in &self.passes {
            row(&mut s, &p.name, &p.ms);
        }
        match &self.frame_gpu_ms {
            Some(f) => row(&mut s, "frame", f),
            None => s.push_str("  (no GPU timestamps on this device)\n"),
        }
        s.push_str("CPU ms\n");
        for p in &self.cpu_ms {
            row(&mut s, &p.name, &p.ms);
        }
        s
    }
}

/// CPU time of the frame's CPU stages.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CpuTimings {
    /// BVH build.
    pub bvh_build: f64,
    /// VPL generation by light tracing.
    pub vpl_generation: f64,
    /// ISM point sampling.
    pub point_sampling: f64,
    /// The ISMs' coarse ray-cast layer (81 rays per VPL).
    pub ism_rays: f64,
}

/// Per-step SSBC figures.
#[derive(Clone, Debug, Serialize)]
pub struct SsbcStepTiming {
    /// GPU time of the step (radiance mips, residual, accumulation; None
    /// without timestamps).
    pub gpu_ms: Option<f64>,
    /// Texels read per geometry pixel, on average: every texel read by an
    /// evaluation point (shared among the pixels under it) or by a pixel
    /// evaluated alone, divided by the geometry pixels.
    pub samples_per_pixel_avg: f64,
    /// The most texels any one pixel accounts for.
    pub samples_per_pixel_max: f64,
    /// Level of the pyramid whose texels were the evaluation points (0: every
    /// pixel was evaluated alone).
    pub eval_level: u32,
    /// Fraction of geometry pixels evaluated alone rather than interpolated.
    pub fallback_fraction: f64,
}

/// GPU timings of one frame, and the figures that explain them.
#[derive(Clone, Debug, Serialize)]
pub struct Timings {
    /// Device name.
    pub device: String,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Pixels the guard band added on each side (0: none; the passes ran
    /// on width + 2 x this by height + 2 x this).
    pub guard_band: u32,
    /// Per-pass GPU time, in recording order. A name `pass/part` is a part of
    /// the pass `pass` (timed inside it; not to be added to it). None (JSON
    /// `null`) when the device's queue has no timestamps.
    pub passes: Option<Vec<PassTiming>>,
    /// Passes not recorded because what they depend on did not change since
    /// the frame slot's previous frame, whose output they kept (shadow maps
    /// and ISMs in a frame where only the camera moved).
    pub reused_passes: Vec<String>,
    /// First to last timestamp of the frame (None without timestamps).
    pub frame_gpu_ms: Option<f64>,
    /// Statistics over several frames (`profile::render_frames`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub stats: Option<FrameStats>,
    /// CPU stages (ms).
    pub cpu_ms: CpuTimings,
    /// CPU stages of the frame on CLOCK_MONOTONIC (for traces).
    #[serde(skip)]
    pub cpu_spans: Vec<CpuSpan>,
    /// When the frame was submitted (ns, CLOCK_MONOTONIC).
    #[serde(skip)]
    pub submit_ns: u64,
    /// The frame's first GPU timestamp on CLOCK_MONOTONIC, when calibrated.
    #[serde(skip)]
    pub gpu_start_ns: Option<u64>,
    /// VPLs used.
    pub vpl_count: usize,
    /// Light paths traced to make them.
    pub light_paths: u64,
    /// Most VPLs a single light path deposited (a handful of paths trapped
    /// somewhere would show here).
    pub max_vpls_per_light_path: u32,
    /// Power (W, luminance) the scene's emissive triangles emit.
    pub emission_w: f32,
    /// The part of `emission_w` that light tracing left out because it goes
    /// into solids (the inside of a thin emissive box); never more
    /// than `emission_w`.
    pub enclosed_emission_w: f32,
    /// Bytes of device memory ssbc's resources took when the frame was
    /// read back (all frame slots, the scene and the read-back buffers).
    pub device_memory_bytes: u64,
    /// One frame slot's device memory by part, estimated before it was
    /// allocated, and measured from the allocator over the slots that hold
    /// resources.
    pub memory: crate::memory::MemoryReport,
    /// How the frame tested VPL visibility ([`Visibility::Auto`] resolved:
    /// a still view's history frames take an accumulation's).
    pub visibility: Visibility,
    /// Whether its ISM atlas held back-face maps
    /// ([`RenderSettings::ism_back_face_maps`](crate::RenderSettings::ism_back_face_maps)).
    pub ism_back_faces: bool,
    /// ISM tile side.
    pub ism_tile: u32,
    /// Points per VPL.
    pub points_per_vpl: u32,
    /// Clamping bound b (1/m²) (a number, or the string "inf").
    pub bound: serde_json::Value,
    /// SSBC integration method.
    pub integration: Integration,
    /// Per-step SSBC figures.
    pub ssbc_steps: Vec<SsbcStepTiming>,
}

impl Timings {
    /// The timed passes (empty without timestamps).
    pub fn timed_passes(&self) -> &[PassTiming] {
        self.passes.as_deref().unwrap_or(&[])
    }

    /// GPU milliseconds of the pass `name`, if it ran and was timed.
    pub fn pass_ms(&self, name: &str) -> Option<f64> {
        self.timed_passes()
            .iter()
            .find(|p| p.name == name)
            .map(|p| p.gpu_ms)
    }
}
