//! Where a frame goes: read back, kept on the GPU, or recorded into a
//! host's command buffer; each mode has its own way out of the frame.

use std::sync::Arc;

use ash::vk;

use super::guard_band::GuardBand;
use super::readback::{self, hand_off_to_host, FrameImages, FrameRecord, ReadbackBuffers};
use super::{Frame, Layer};
use crate::error::Result;
use crate::memory::FrameMemory;
use crate::passes::FrameView;
use crate::scene_cache::SceneCache;
use crate::settings::RenderSettings;
use crate::timings::{monotonic_ns, CpuSpan};
use crate::vk::{Device, GpuFrameTimes, GpuProfiler, HostImage, Recorder};

/// The image a frame handed over.
pub(super) struct FrameOutput {
    pub slot: usize,
    pub layer: Layer,
    pub done: u64,
    /// The guard band's margin around the image.
    pub margin: u32,
}

/// A frame submitted by [`Renderer::render_to_gpu`](super::Renderer::render_to_gpu).
#[derive(Clone, Debug)]
pub struct GpuSubmission {
    /// Timeline value that signals the frame is done (see [`Renderer::output_image`](super::Renderer::output_image)).
    pub value: u64,
    /// GPU times of the previous frame that used this frame slot, read
    /// without waiting (None for a slot's first frame or without timestamps).
    pub previous_timings: Option<GpuFrameTimes>,
}

/// Where a frame goes, and what it returns: read back ([`ReadBack`]),
/// kept on the GPU ([`KeepOnGpu`]), or recorded into a host's command
/// buffer ([`IntoHost`]). Each mode has its own way out of
/// [`Renderer::frame`].
pub(super) trait FrameSink {
    /// What the frame returns.
    type Output;
    /// Whether the frame is read back (its slot holds read-back buffers).
    const READS_BACK: bool = false;
    /// The host's command buffer to record into (None: ssbc's own, timed).
    fn host_command_buffer(&self) -> Option<vk::CommandBuffer> {
        None
    }
    /// The layer the frame hands over (None: read back).
    fn layer(&self) -> Option<Layer> {
        None
    }
    /// Sends the frame recorded in `rec` on.
    fn finish(self, rec: Recorder<'_>, frame: Finish<'_>) -> Result<Self::Output>;
}

/// Read back to the host; the frame is waited for.
pub(super) struct ReadBack;

/// Kept on the GPU as this layer; ssbc submits.
pub(super) struct KeepOnGpu(pub Layer);

/// Recorded into the host's command buffer; the layer is copied into the
/// host's image.
pub(super) struct IntoHost<'a> {
    pub cmd: vk::CommandBuffer,
    pub output: &'a HostImage,
    pub layer: Layer,
}

/// A recorded frame on its way out, with the renderer state it updates.
pub(super) struct Finish<'r> {
    pub images: FrameImages<'r>,
    pub device: &'r Arc<Device>,
    pub slot: usize,
    /// The image's settings, and the guard band's wider frame's.
    pub inner: &'r RenderSettings,
    pub settings: &'r RenderSettings,
    pub band: Option<GuardBand>,
    pub view: &'r FrameView,
    pub cache: &'r SceneCache,
    pub spans: Vec<CpuSpan>,
    /// Passes that kept the slot's previous output.
    pub reused: Vec<String>,
    pub record_start: u64,
    /// When the frame was submitted (ns, CLOCK_MONOTONIC; set by `submit`).
    pub submit_ns: u64,
    pub previous_timings: Option<GpuFrameTimes>,
    /// The slot's estimated device memory, and the slots that hold resources.
    pub memory: (FrameMemory, u32),
    pub readback: &'r mut Option<ReadbackBuffers>,
    pub profiler: &'r mut GpuProfiler,
    pub slot_done: &'r mut u64,
    pub output: &'r mut Option<FrameOutput>,
}

impl Finish<'_> {
    /// Submits the frame recorded in `rec`, keeping `layer` as the
    /// renderer's output image; returns the timeline value that signals it
    /// done.
    fn submit(&mut self, mut rec: Recorder<'_>, layer: Layer) -> Result<u64> {
        rec.flush_barriers();
        self.submit_ns = monotonic_ns();
        self.spans.push(CpuSpan::between(
            "record",
            self.record_start,
            self.submit_ns,
        ));
        let done = rec.submit()?;
        self.profiler.submitted(self.slot);
        *self.slot_done = done;
        *self.output = Some(FrameOutput {
            slot: self.slot,
            layer,
            done,
            margin: self.band.map_or(0, |b| b.margin),
        });
        Ok(done)
    }
}

impl FrameSink for ReadBack {
    type Output = Frame;
    const READS_BACK: bool = true;
    fn finish(self, rec: Recorder<'_>, mut f: Finish<'_>) -> Result<Frame> {
        let wanted = f.images.readback(f.settings);
        readback::ensure_buffers(f.device, f.readback, &wanted)?;
        let done = f.submit(rec, Layer::Final)?;
        let wait_start = monotonic_ns();
        f.device.wait(done)?;
        let read_start = monotonic_ns();
        f.spans
            .push(CpuSpan::between("wait_for_gpu", wait_start, read_start));
        let buffers = f.readback.as_mut().expect("made above");
        let read = readback::read_images(f.device, buffers, &wanted)?;
        f.spans
            .push(CpuSpan::between("read_back", read_start, monotonic_ns()));
        readback::read_frame(
            read,
            FrameRecord {
                device: f.device,
                settings: f.inner,
                band: f.band,
                view: f.view,
                images: f.images,
                cache: f.cache,
                gpu_times: f.profiler.resolve(f.slot)?,
                spans: f.spans,
                reused: f.reused,
                submit_ns: f.submit_ns,
                memory: f.memory,
            },
        )
    }
}

impl FrameSink for KeepOnGpu {
    type Output = GpuSubmission;
    fn layer(&self) -> Option<Layer> {
        Some(self.0)
    }
    fn finish(self, rec: Recorder<'_>, mut f: Finish<'_>) -> Result<GpuSubmission> {
        let value = f.submit(rec, self.0)?;
        Ok(GpuSubmission {
            value,
            previous_timings: f.previous_timings,
        })
    }
}

impl FrameSink for IntoHost<'_> {
    type Output = ();
    fn host_command_buffer(&self) -> Option<vk::CommandBuffer> {
        Some(self.cmd)
    }
    fn layer(&self) -> Option<Layer> {
        Some(self.layer)
    }
    fn finish(self, mut rec: Recorder<'_>, f: Finish<'_>) -> Result<()> {
        hand_off_to_host(&mut rec, &f.images, self.output, self.layer, f.band)?;
        // Its queries are read once the host says the frame is done
        // (`Renderer::host_timings`).
        f.profiler.submitted(f.slot);
        Ok(())
    }
}
