//! Measuring frames: warm-frame statistics (min / median / max per pass over
//! N frames after a warm-up frame) and a Chrome trace-event file with one
//! track for the GPU passes and one for the CPU stages.
//!
//! Trace times are on CLOCK_MONOTONIC, the clock VK_EXT_calibrated_timestamps
//! pairs the device's timestamps with; without calibration a frame's GPU
//! track starts at its submission, and the file says so in its metadata.

use std::path::Path;

use serde_json::{json, Value};

use crate::error::{Error, Result};
use crate::renderer::{Frame, RenderSettings, Renderer};
use crate::scene::Scene;
use crate::timings::Timings;
pub use crate::timings::{monotonic_ns, CpuSpan, FrameStats, PassStats, Spread};

/// A Chrome trace-event file (opens in Perfetto and chrome://tracing): a
/// GPU track of passes and a CPU track of stages, frame after frame.
#[derive(Default)]
pub struct ChromeTrace {
    events: Vec<Value>,
    /// Frames whose GPU track was placed by calibrated timestamps.
    calibrated: usize,
    frames: usize,
    /// Earliest time in the trace (ns), subtracted from every event.
    origin: Option<u64>,
}

const PID: u32 = 1;
const GPU_TID: u32 = 1;
const CPU_TID: u32 = 2;

impl ChromeTrace {
    /// An empty trace.
    pub fn new() -> Self {
        Self::default()
    }

    /// Adds one frame's CPU stages and GPU passes.
    pub fn add_frame(&mut self, timings: &Timings) {
        let frame = self.frames;
        self.frames += 1;
        let span = |name: &str, tid: u32, start_ns: u64, dur_ns: f64, args: Value| {
            json!({
                "name": name, "cat": if tid == GPU_TID { "gpu" } else { "cpu" },
                "ph": "X", "pid": PID, "tid": tid,
                "ts": start_ns as f64 * 1e-3, "dur": dur_ns * 1e-3, "args": args,
            })
        };
        for s in &timings.cpu_spans {
            self.note_time(s.start_ns);
            self.events.push(span(
                &s.name,
                CPU_TID,
                s.start_ns,
                s.duration_ns as f64,
                json!({ "frame": frame }),
            ));
        }
        let (Some(passes), Some(frame_ms)) = (&timings.passes, timings.frame_gpu_ms) else {
            return;
        };
        let start = match timings.gpu_start_ns {
            Some(ns) => {
                self.calibrated += 1;
                ns
            }
            None => timings.submit_ns,
        };
        self.note_time(start);
        self.events.push(span(
            &format!("frame {frame}"),
            GPU_TID,
            start,
            frame_ms * 1e6,
            json!({ "frame": frame }),
        ));
        for p in passes {
            let mut args = json!({ "frame": frame, "gpu_ms": p.gpu_ms });
            if let Some(n) = p.compute_invocations {
                args["compute_invocations"] = json!(n);
            }
            if let Some(n) = p.fragment_invocations {
                args["fragment_invocations"] = json!(n);
            }
            self.events.push(span(
                &p.name,
                GPU_TID,
                start + (p.start_ms * 1e6) as u64,
                p.gpu_ms * 1e6,
                args,
            ));
        }
    }

    fn note_time(&mut self, ns: u64) {
        self.origin = Some(self.origin.map_or(ns, |o| o.min(ns)));
    }

    /// The trace as JSON (times in µs from the earliest event).
    pub fn to_json(&self) -> Value {
        let origin_us = self.origin.unwrap_or(0) as f64 * 1e-3;
        let mut events: Vec<Value> = self
            .events
            .iter()
            .cloned()
            .map(|mut e| {
                let ts = e["ts"].as_f64().unwrap_or(0.0) - origin_us;
                e["ts"] = json!(ts);
                e
            })
            .collect();
        for (tid, name) in [(GPU_TID, "GPU passes"), (CPU_TID, "CPU stages")] {
            events.push(json!({
                "name": "thread_name", "ph": "M", "pid": PID, "tid": tid,
                "args": { "name": name },
            }));
        }
        events.push(json!({
            "name": "process_name", "ph": "M", "pid": PID, "args": { "name": "ssbc" },
        }));
        let alignment = if self.frames > 0 && self.calibrated == self.frames {
            "calibrated: GPU timestamps placed on CLOCK_MONOTONIC with VK_EXT_calibrated_timestamps"
        } else if self.calibrated == 0 {
            "submission: no calibrated timestamps; each frame's GPU track starts when it was submitted"
        } else {
            "mixed: some frames calibrated, the others aligned at submission"
        };
        json!({
            "traceEvents": events,
            "displayTimeUnit": "ms",
            "metadata": { "ssbc.clock_alignment": alignment, "ssbc.frames": self.frames },
        })
    }

    /// Writes the trace to `path`.
    pub fn write(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(&self.to_json()).map_err(|e| Error::Output {
            path: path.display().to_string(),
            message: e.to_string(),
        })?;
        std::fs::write(path, text).map_err(|e| Error::io(path, e))
    }
}

/// Renders one warm-up frame, then `frames` more of the same scene and
/// settings; returns the last frame with [`Timings::stats`] filled in over
/// the `frames` measured ones. Every frame (warm-up included, marked as
/// frame 0) goes into `trace` when given.
///
/// ```no_run
/// # fn main() -> ssbc::Result<()> {
/// use ssbc::profile::{render_frames, ChromeTrace};
/// let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig::default())?;
/// let mut scene = ssbc::scene::load("cornell")?;
/// scene.ensure_light();
/// let settings = ssbc::RenderSettings::new(640, 480);
/// let mut trace = ChromeTrace::new();
/// let frame = render_frames(&mut renderer, &scene, &settings, 10, Some(&mut trace))?;
/// println!("{}", frame.timings.stats.as_ref().expect("filled in").table());
/// trace.write("trace.json".as_ref())?; // chrome://tracing or Perfetto
/// # Ok(()) }
/// ```
pub fn render_frames(
    renderer: &mut Renderer,
    scene: &Scene,
    settings: &RenderSettings,
    frames: u32,
    mut trace: Option<&mut ChromeTrace>,
) -> Result<Frame> {
    if frames == 0 {
        return Err(Error::InvalidParameter("frames must be at least 1".into()));
    }
    let mut measured = Vec::with_capacity(frames as usize);
    let mut last = None;
    for i in 0..=frames {
        let frame = renderer.render(scene, settings)?;
        if let Some(trace) = trace.as_deref_mut() {
            trace.add_frame(&frame.timings);
        }
        if i > 0 {
            measured.push(frame.timings.clone());
        }
        last = Some(frame);
    }
    let mut frame = last.expect("at least one frame");
    frame.timings.stats = Some(FrameStats::of(&measured));
    Ok(frame)
}
