//! GPU timing with timestamp queries: one pair of timestamps around each
//! pass, resolved when the frame's slot comes round again (or when the
//! caller has waited for the frame). Each pass is also a debug-utils label
//! region with the same name, so captures (RenderDoc, Nsight) and the
//! timings use one set of pass names; and, where the device supports
//! pipeline statistics, top-level passes count their shader invocations.

use std::sync::Arc;

use ash::vk;
use serde::Serialize;

use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// GPU time of one pass.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PassTiming {
    /// Pass name (e.g. `gbuffer`, `direct_lighting`; `pass/part` for a part
    /// timed inside `pass`).
    pub name: String,
    /// Milliseconds between the pass's two timestamps.
    pub gpu_ms: f64,
    /// Milliseconds from the frame's first timestamp to the pass's first.
    pub start_ms: f64,
    /// Compute-shader invocations in the pass (top-level passes, where the
    /// device supports pipeline statistics queries).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub compute_invocations: Option<u64>,
    /// Fragment-shader invocations in the pass (as above).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fragment_invocations: Option<u64>,
}

/// One frame's GPU times.
#[derive(Clone, Debug, PartialEq)]
pub struct GpuFrameTimes {
    /// Per-pass times in recording order.
    pub passes: Vec<PassTiming>,
    /// First to last timestamp of the frame (ms).
    pub frame_ms: f64,
    /// The frame's first timestamp on CLOCK_MONOTONIC (ns), when the device
    /// calibrates its clock against it (VK_EXT_calibrated_timestamps).
    pub start_monotonic_ns: Option<u64>,
}

/// Per-slot bookkeeping.
#[derive(Clone, Default)]
struct SlotState {
    /// Pass names recorded, and each one's pipeline-statistics query.
    scopes: Vec<(String, Option<u32>)>,
    /// Pipeline-statistics queries begun.
    statistics_used: u32,
    /// Passes past the capacity (labelled, not timed).
    untimed: u32,
    /// The frame was submitted (its queries will be written).
    submitted: bool,
    /// (device timestamp, CLOCK_MONOTONIC ns) taken when the frame ended.
    calibration: Option<(u64, u64)>,
}

/// Query pools with room for `capacity` passes in each of several frame
/// slots, so a frame's timestamps can be read when its slot comes round
/// again, without waiting.
pub struct GpuProfiler {
    device: Arc<Device>,
    /// Timestamp queries (None: the queue has no timestamps or timing is off).
    timestamps: Option<vk::QueryPool>,
    /// Pipeline-statistics queries (None where unsupported).
    statistics: Option<vk::QueryPool>,
    capacity: u32,
    slots: Vec<SlotState>,
    /// The slot being recorded.
    current: usize,
    /// An open scope holds the statistics query (queries of one type cannot nest).
    statistics_open: bool,
    /// The frame being recorded writes timestamps (false: labels only).
    frame_timed: bool,
    period_ns: f64,
    valid_mask: u64,
    /// Query resets are recorded into the frame's command buffer (a host's,
    /// whose device need not have hostQueryReset) instead of done on the
    /// host at `begin_frame`.
    resets_recorded: bool,
    /// The same for the frames now being recorded only (`record_resets`).
    host_frames: bool,
}

/// An open pass scope; close it with [`GpuProfiler::end`]. `UNTIMED`: a
/// pass past the profiler's capacity, which only gets its label.
#[must_use]
pub struct PassScope(u32);

impl PassScope {
    const UNTIMED: u32 = u32::MAX;
}

/// Pipeline statistics ssbc reads, in the order Vulkan writes them (by bit).
const STATISTICS: vk::QueryPipelineStatisticFlags = vk::QueryPipelineStatisticFlags::from_raw(
    vk::QueryPipelineStatisticFlags::FRAGMENT_SHADER_INVOCATIONS.as_raw()
        | vk::QueryPipelineStatisticFlags::COMPUTE_SHADER_INVOCATIONS.as_raw(),
);

impl GpuProfiler {
    /// Pools for up to `capacity` passes per frame in each of `slots` slots.
    /// With `timestamps` false (or a queue without timestamps) passes are
    /// still labelled, but not timed. `statistics` adds pipeline-statistics
    /// queries where the device supports them.
    pub fn new(
        device: &Arc<Device>,
        capacity: u32,
        slots: usize,
        timestamps: bool,
        statistics: bool,
    ) -> Result<Self> {
        let support = device.profiling();
        let per_slot = capacity * 2 + 2;
        let timestamps = if timestamps && support.timestamp_valid_bits > 0 {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::TIMESTAMP)
                .query_count(per_slot * slots as u32);
            // SAFETY: valid create info.
            let pool =
                unsafe { device.raw.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
            device.set_name(pool, "ssbc.profiler.timestamps");
            Some(pool)
        } else {
            None
        };
        let statistics = if statistics && support.pipeline_statistics && timestamps.is_some() {
            let info = vk::QueryPoolCreateInfo::default()
                .query_type(vk::QueryType::PIPELINE_STATISTICS)
                .pipeline_statistics(STATISTICS)
                .query_count(capacity * slots as u32);
            // SAFETY: valid create info; pipelineStatisticsQuery is enabled.
            let pool = unsafe { device.raw.create_query_pool(&info, None) };
            match pool.vk("vkCreateQueryPool") {
                Ok(pool) => {
                    device.set_name(pool, "ssbc.profiler.pipeline_statistics");
                    Some(pool)
                }
                Err(e) => {
                    if let Some(t) = timestamps {
                        device.defer_destroy(Garbage::QueryPool(t));
                    }
                    return Err(e);
                }
            }
        } else {
            None
        };
        let bits = support.timestamp_valid_bits;
        let valid_mask = if bits >= 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        Ok(Self {
            device: device.clone(),
            timestamps,
            statistics,
            capacity,
            slots: vec![SlotState::default(); slots],
            current: 0,
            statistics_open: false,
            frame_timed: true,
            period_ns: support.timestamp_period_ns as f64,
            valid_mask,
            resets_recorded: false,
            host_frames: false,
        })
    }

    /// Records each frame's query resets into its command buffer (which must
    /// then be outside a render pass at `begin_frame`) instead of resetting
    /// on the host: for frames recorded into a host's command buffer.
    pub fn with_recorded_resets(mut self) -> Self {
        self.resets_recorded = true;
        self
    }

    /// Whether the next frames' query resets are recorded into their
    /// command buffer (a host's) or done on the host (ssbc's own); a
    /// profiler made [`with_recorded_resets`](Self::with_recorded_resets)
    /// records them whatever this says.
    pub fn record_resets(&mut self, recorded: bool) {
        self.host_frames = recorded;
    }

    /// Resets `count` queries of `pool` from `first`, on the host or in `cmd`.
    fn reset(&self, cmd: vk::CommandBuffer, pool: vk::QueryPool, first: u32, count: u32) {
        if self.resets_recorded || self.host_frames {
            // SAFETY: `cmd` is recording outside a render pass (the caller's
            // contract); the range lies inside the pool.
            unsafe { self.device.raw.cmd_reset_query_pool(cmd, pool, first, count) };
        } else {
            // SAFETY: hostQueryReset is enabled; the caller waited for the
            // slot's previous submission, so no pending work uses these queries.
            unsafe { self.device.raw.reset_query_pool(pool, first, count) };
        }
    }

    /// Whether passes are timed (false: timings are absent).
    pub fn timed(&self) -> bool {
        self.timestamps.is_some()
    }

    /// Writes timestamp `query` when this frame is timed.
    fn timestamp(&self, cmd: vk::CommandBuffer, query: u32) {
        if let Some(pool) = self.timestamps.filter(|_| self.frame_timed) {
            // SAFETY: the query is inside the pool and was reset this frame.
            unsafe {
                self.device.raw.cmd_write_timestamp2(
                    cmd,
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    pool,
                    query,
                )
            };
        }
    }

    /// First timestamp query of `slot`.
    fn base(&self, slot: usize) -> u32 {
        slot as u32 * (self.capacity * 2 + 2)
    }

    /// Resets `slot`'s queries (on the host, or in `cmd`: `record_resets`)
    /// and starts a frame in it: writes
    /// the frame's first timestamp. The slot's previous frame must be done.
    /// An untimed frame (`timed` false) only gets labels.
    pub fn begin_frame(&mut self, cmd: vk::CommandBuffer, slot: usize, timed: bool) {
        self.current = slot;
        self.slots[slot] = SlotState::default();
        self.statistics_open = false;
        self.frame_timed = timed;
        let base = self.base(slot);
        if let Some(pool) = self.timestamps.filter(|_| timed) {
            self.reset(cmd, pool, base, self.capacity * 2 + 2);
        }
        if let Some(pool) = self.statistics.filter(|_| timed) {
            self.reset(cmd, pool, slot as u32 * self.capacity, self.capacity);
        }
        self.timestamp(cmd, base);
    }

    /// Opens a pass: a label region and its start timestamp (and, for an
    /// outermost pass, a pipeline-statistics query).
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) -> PassScope {
        self.device.begin_label(cmd, name);
        let state = &mut self.slots[self.current];
        let index = state.scopes.len() as u32;
        if index >= self.capacity {
            // More passes than there are queries: the frame still records,
            // its later passes untimed (said once per frame).
            if state.untimed == 0 {
                log::warn!(
                    "GpuProfiler: more than {} passes in a frame; \"{name}\" and later ones are not timed",
                    self.capacity
                );
            }
            state.untimed += 1;
            return PassScope(PassScope::UNTIMED);
        }
        let mut statistics_query = None;
        if let Some(pool) = self
            .statistics
            .filter(|_| self.frame_timed && !self.statistics_open)
        {
            let query = self.current as u32 * self.capacity + state.statistics_used;
            state.statistics_used += 1;
            self.statistics_open = true;
            statistics_query = Some(query);
            // SAFETY: the query was reset this frame; no other statistics
            // query is active in this command buffer.
            unsafe {
                self.device
                    .raw
                    .cmd_begin_query(cmd, pool, query, vk::QueryControlFlags::empty())
            };
        }
        state.scopes.push((name.to_string(), statistics_query));
        self.timestamp(cmd, self.base(self.current) + 2 + index * 2);
        PassScope(index)
    }

    /// Closes a pass: its end timestamp, statistics query and label region.
    pub fn end(&mut self, cmd: vk::CommandBuffer, scope: PassScope) {
        if scope.0 == PassScope::UNTIMED {
            self.device.end_label(cmd);
            return;
        }
        self.timestamp(cmd, self.base(self.current) + 3 + scope.0 * 2);
        let query = self.slots[self.current].scopes[scope.0 as usize].1;
        if let (Some(pool), Some(query)) = (self.statistics, query) {
            // SAFETY: the query was begun in this command buffer by `begin`.
            unsafe { self.device.raw.cmd_end_query(cmd, pool, query) };
            self.statistics_open = false;
        }
        self.device.end_label(cmd);
    }

    /// Writes the frame's last timestamp and pairs the device clock with
    /// the CPU's (where calibrated timestamps are supported).
    pub fn end_frame(&mut self, cmd: vk::CommandBuffer) {
        // The slot's second query is reserved for the frame end.
        self.timestamp(cmd, self.base(self.current) + 1);
        self.slots[self.current].calibration = self.device.calibrated_timestamps();
    }

    /// Marks the slot's frame as submitted: only then are its queries read
    /// (a frame abandoned by an error before submission leaves none).
    pub fn submitted(&mut self, slot: usize) {
        self.slots[slot].submitted = true;
    }

    /// Whether `slot` holds a submitted frame.
    pub fn has_frame(&self, slot: usize) -> bool {
        self.slots[slot].submitted && !self.slots[slot].scopes.is_empty()
    }

    /// Reads `slot`'s queries: per-pass times and the frame's time, or None
    /// when passes are not timed. Waits if the frame has not finished; once
    /// its submission is known done this returns at once.
    pub fn resolve(&self, slot: usize) -> Result<Option<GpuFrameTimes>> {
        self.read(slot, true)
    }

    /// Reads `slot`'s queries if the frame has finished, never waiting: None
    /// when passes are not timed or its results are not all available yet.
    /// (A frame recorded but not yet run still shows the slot's previous
    /// frame: call it once the frame is known done.)
    pub fn try_resolve(&self, slot: usize) -> Result<Option<GpuFrameTimes>> {
        self.read(slot, false)
    }

    fn read(&self, slot: usize, wait: bool) -> Result<Option<GpuFrameTimes>> {
        let Some(pool) = self.timestamps else {
            return Ok(None);
        };
        let flags = if wait {
            vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT
        } else {
            vk::QueryResultFlags::TYPE_64
        };
        let state = &self.slots[slot];
        if !state.submitted {
            return Err(Error::InvalidParameter(
                "GpuProfiler::resolve on a frame that was not submitted".into(),
            ));
        }
        let count = 2 + state.scopes.len() * 2;
        let mut raw = vec![0u64; count];
        // SAFETY: the queries 0..count were written by the submitted frame
        // (or, not waiting, are reported not ready).
        let results =
            unsafe { self.device.raw.get_query_pool_results(pool, self.base(slot), &mut raw, flags) };
        if results == Err(vk::Result::NOT_READY) && !wait {
            return Ok(None);
        }
        results.vk("vkGetQueryPoolResults")?;
        let mut statistics = vec![[0u64; 2]; state.statistics_used as usize];
        if let (Some(stats_pool), false) = (self.statistics, statistics.is_empty()) {
            // SAFETY: the first `statistics_used` queries of the slot were
            // begun and ended by the submitted frame (before its last
            // timestamp, so not waiting long once that is available).
            unsafe {
                self.device.raw.get_query_pool_results(
                    stats_pool,
                    slot as u32 * self.capacity,
                    &mut statistics,
                    vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
                )
            }
            .vk("vkGetQueryPoolResults")?;
        }
        let ticks = |a: u64, b: u64| b.wrapping_sub(a) & self.valid_mask;
        let to_ms = |a: u64, b: u64| ticks(a, b) as f64 * self.period_ns * 1e-6;
        let base = slot as u32 * self.capacity;
        let passes = state
            .scopes
            .iter()
            .enumerate()
            .map(|(i, (name, query))| {
                let counts = query.map(|q| statistics[(q - base) as usize]);
                PassTiming {
                    name: name.clone(),
                    gpu_ms: to_ms(raw[2 + 2 * i], raw[3 + 2 * i]),
                    start_ms: to_ms(raw[0], raw[2 + 2 * i]),
                    // Results come in bit order: fragment, then compute.
                    fragment_invocations: counts.map(|c| c[0]),
                    compute_invocations: counts.map(|c| c[1]),
                }
            })
            .collect();
        if raw[1] < raw[0] && self.valid_mask == u64::MAX {
            return Err(Error::Vulkan {
                call: "timestamps went backwards",
                result: vk::Result::ERROR_UNKNOWN,
            });
        }
        // The frame's start on CLOCK_MONOTONIC: the calibration pair was
        // taken after recording, so the start is normally later than the
        // pair's device tick; both directions are handled.
        let start_monotonic_ns = state.calibration.map(|(gpu, cpu)| {
            let ahead = ticks(gpu, raw[0]);
            if ahead <= self.valid_mask / 2 {
                cpu + (ahead as f64 * self.period_ns) as u64
            } else {
                cpu.saturating_sub((ticks(raw[0], gpu) as f64 * self.period_ns) as u64)
            }
        });
        Ok(Some(GpuFrameTimes {
            passes,
            frame_ms: to_ms(raw[0], raw[1]),
            start_monotonic_ns,
        }))
    }
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        for pool in [self.timestamps, self.statistics].into_iter().flatten() {
            self.device.defer_destroy(Garbage::QueryPool(pool));
        }
    }
}
