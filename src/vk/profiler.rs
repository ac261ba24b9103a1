//! GPU timing with timestamp queries: one pair of timestamps around each
//! pass, resolved after the frame's submission has finished.

use std::sync::Arc;

use ash::vk;
use serde::Serialize;

use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// GPU time of one pass.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct PassTiming {
    /// Pass name (e.g. `gbuffer`, `direct_lighting`).
    pub name: String,
    /// Milliseconds between the pass's two timestamps.
    pub gpu_ms: f64,
}

/// A query pool with room for `capacity` passes in each of several frame
/// slots, so a frame's timestamps can be read when its slot comes round
/// again, without waiting.
pub struct GpuProfiler {
    device: Arc<Device>,
    pool: vk::QueryPool,
    capacity: u32,
    /// Pass names recorded in each slot.
    names: Vec<Vec<String>>,
    /// The slot being recorded.
    current: usize,
    period_ns: f64,
    valid_mask: u64,
}

/// An open pass scope; close it with [`GpuProfiler::end`].
#[must_use]
pub struct PassScope(u32);

impl GpuProfiler {
    /// A pool for up to `capacity` passes per frame in each of `slots` slots.
    pub fn new(device: &Arc<Device>, capacity: u32, slots: usize) -> Result<Self> {
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count((capacity * 2 + 2) * slots as u32);
        // SAFETY: valid create info.
        let pool = unsafe { device.raw.create_query_pool(&info, None) }.vk("vkCreateQueryPool")?;
        // SAFETY: valid instance and physical device.
        let families = unsafe {
            device
                .instance
                .raw
                .get_physical_device_queue_family_properties(device.physical)
        };
        let bits = families[device.queue_family as usize].timestamp_valid_bits;
        let valid_mask = if bits >= 64 {
            u64::MAX
        } else {
            (1u64 << bits) - 1
        };
        Ok(Self {
            device: device.clone(),
            pool,
            capacity,
            names: vec![Vec::new(); slots],
            current: 0,
            period_ns: device.properties.limits.timestamp_period as f64,
            valid_mask,
        })
    }

    /// First query of `slot`.
    fn base(&self, slot: usize) -> u32 {
        slot as u32 * (self.capacity * 2 + 2)
    }

    /// Resets `slot`'s queries (host reset) and starts a frame in it: writes
    /// the frame's first timestamp. The slot's previous frame must be done.
    pub fn begin_frame(&mut self, cmd: vk::CommandBuffer, slot: usize) {
        self.current = slot;
        self.names[slot].clear();
        let base = self.base(slot);
        // SAFETY: hostQueryReset is enabled; the caller waited for the slot's
        // previous submission, so no pending work uses these queries.
        unsafe {
            self.device
                .raw
                .reset_query_pool(self.pool, base, self.capacity * 2 + 2);
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                base,
            );
        }
    }

    /// Writes the start timestamp of a pass.
    pub fn begin(&mut self, cmd: vk::CommandBuffer, name: &str) -> PassScope {
        let index = self.names[self.current].len() as u32;
        assert!(
            index < self.capacity,
            "GpuProfiler capacity {} exceeded",
            self.capacity
        );
        self.names[self.current].push(name.to_string());
        // SAFETY: query index inside the pool, reset this frame.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                self.base(self.current) + 2 + index * 2,
            )
        };
        PassScope(index)
    }

    /// Writes the end timestamp of a pass.
    pub fn end(&mut self, cmd: vk::CommandBuffer, scope: PassScope) {
        // SAFETY: as in begin.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                self.base(self.current) + 3 + scope.0 * 2,
            )
        };
    }

    /// Writes the frame's last timestamp.
    pub fn end_frame(&mut self, cmd: vk::CommandBuffer) {
        let query = self.base(self.current) + 1;
        // SAFETY: the slot's second query is reserved for the frame end.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                cmd,
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                query,
            )
        };
    }

    /// Whether `slot` holds a recorded frame.
    pub fn has_frame(&self, slot: usize) -> bool {
        !self.names[slot].is_empty()
    }

    /// Reads `slot`'s timestamps and returns the per-pass times and the whole
    /// frame's time in milliseconds. Waits if the frame has not finished;
    /// once its submission is known done this returns at once.
    pub fn resolve(&self, slot: usize) -> Result<(Vec<PassTiming>, f64)> {
        let count = 2 + self.names[slot].len() * 2;
        let mut raw = vec![0u64; count];
        // SAFETY: the queries 0..count were written by the submitted frame.
        unsafe {
            self.device.raw.get_query_pool_results(
                self.pool,
                self.base(slot),
                &mut raw,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .vk("vkGetQueryPoolResults")?;
        let to_ms = |a: u64, b: u64| {
            let delta = b.wrapping_sub(a) & self.valid_mask;
            delta as f64 * self.period_ns * 1e-6
        };
        let passes = self.names[slot]
            .iter()
            .enumerate()
            .map(|(i, name)| PassTiming {
                name: name.clone(),
                gpu_ms: to_ms(raw[2 + 2 * i], raw[3 + 2 * i]),
            })
            .collect();
        if raw[1] < raw[0] && self.valid_mask == u64::MAX {
            return Err(Error::Vulkan {
                call: "timestamps went backwards",
                result: vk::Result::ERROR_UNKNOWN,
            });
        }
        Ok((passes, to_ms(raw[0], raw[1])))
    }
}

impl Drop for GpuProfiler {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::QueryPool(self.pool));
    }
}
