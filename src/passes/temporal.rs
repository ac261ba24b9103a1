//! Temporal history: this frame's indirect light (the final image minus the
//! direct light) folded into a per-pixel running mean of earlier frames',
//! reprojected from the previous frame's view with depth, normal and
//! material rejection, and the image made of the direct light and that
//! mean. The
//! renderer decides per frame how many frames the mean may hold
//! ([`HistoryStep`]; see [`HistorySettings`](crate::settings::HistorySettings)).
//!
//! The history a frame reads is the one the previous frame wrote in the
//! other frame slot, with that slot's G-buffer: both stay untouched until
//! their slot's next frame, which the queue runs after this one.

use std::sync::Arc;

use glam::{Mat4, Vec3};

use super::gbuffer::GBuffer;
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
use crate::layer::Layer;
use crate::shaders::{temporal_blend_comp, temporal_reproject_comp};
use crate::vk::{ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image, Work};

/// What the pass writes.
pub struct Temporal {
    /// Direct light + the mean indirect light: the frame's final image.
    pub output: Image,
    /// rgb: the mean indirect light; a: frames it averages (0: background).
    pub history: Image,
    /// The previous frame's history in this frame's pixels (a = 0 where
    /// the surface was not seen).
    pub reprojected: Image,
}


/// How a frame folds into history.
#[derive(Clone, Copy, Debug)]
pub struct HistoryStep {
    /// Frames the mean may average (1: the frame alone).
    pub max_frames: u32,
    /// Weigh history by the local change of the indirect light, dropping it
    /// at this relative change (lights changed).
    pub light_change: Option<f32>,
    /// The previous frame's world-to-clip transform (its history's pixels).
    pub previous_view_proj: Mat4,
    /// The previous frame's eye (glossy history depends on the view).
    pub previous_camera: Vec3,
}

/// What the pass reads.
pub struct TemporalReads<'a> {
    /// This frame's G-buffer.
    pub gbuffer: &'a GBuffer,
    /// Its final image.
    pub final_image: &'a Image,
    /// Its direct light.
    pub direct: &'a Image,
    /// The previous frame's G-buffer and history (None: start anew).
    pub previous: Option<(&'a GBuffer, &'a Temporal)>,
    /// How this frame folds in.
    pub step: HistoryStep,
}

/// The reprojection and blending kernels.
pub struct TemporalPass {
    reproject: ComputeKernel<temporal_reproject_comp::Interface>,
    blend: ComputeKernel<temporal_blend_comp::Interface>,
}

impl TemporalPass {
    /// Creates both kernels.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            reproject: ComputeKernel::new(device)?,
            blend: ComputeKernel::new(device)?,
        })
    }
}

impl Pass for TemporalPass {
    const NAME: &'static str = "temporal";
    /// Width and height.
    type Key = (u32, u32);
    type Resources = Temporal;
    type Reads<'a> = TemporalReads<'a>;

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.extent()
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<Temporal> {
        let image = |name: &str| super::radiance_image(setup.device, name, setup.extent());
        let (name, desc) = ("temporal.reprojected", super::radiance_desc(setup.extent()));
        let reprojected = match setup.region(super::transient::Tenancy::Temporal) {
            Some(mut region) => Image::new_aliased(setup.device, name, desc, &mut region)?,
            None => Image::new(setup.device, name, desc)?,
        };
        Ok(Temporal {
            output: image("temporal.output")?,
            history: image("temporal.history")?,
            reprojected,
        })
    }

    /// The history's image replaces the frame's own final image.
    fn layers<'r>(&self, temporal: &'r Temporal) -> Vec<(Layer, &'r Image)> {
        vec![(Layer::Final, &temporal.output)]
    }

    fn set_layouts(&self, _: &Temporal) -> Vec<&DescriptorSetLayout> {
        vec![self.reproject.set_layout(), self.blend.set_layout()]
    }

    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        reads: TemporalReads<'_>,
        out: &Temporal,
    ) -> Result<()> {
        let Recording {
            rec, profiler, view, ..
        } = cx;
        let scope = profiler.begin(rec.cmd, "temporal");
        let (w, h) = reads.gbuffer.extent();
        let step = reads.step;
        // Without history the kernel reads nothing and marks every pixel
        // new; its bindings still need images: this frame's own.
        let (previous_gbuffer, previous_history) = match reads.previous {
            Some((gbuffer, temporal)) => (gbuffer, &temporal.history),
            None => (reads.gbuffer, &out.history),
        };
        let push = temporal_reproject_comp::Push {
            previous_view_proj: step.previous_view_proj.to_cols_array_2d(),
            camera_position: view.camera.position.extend(1.0).into(),
            previous_camera: step.previous_camera.extend(1.0).into(),
            size: [w, h],
            has_history: reads.previous.is_some() as u32,
        };
        let bindings = temporal_reproject_comp::Bindings {
            g_position: &reads.gbuffer.position,
            g_normal: &reads.gbuffer.normal,
            previous_position: &previous_gbuffer.position,
            previous_normal: &previous_gbuffer.normal,
            previous_history,
            reprojected: &out.reprojected,
            g_albedo: &reads.gbuffer.albedo,
            previous_albedo: &previous_gbuffer.albedo,
        };
        self.reproject
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        let push = temporal_blend_comp::Push {
            size: [w, h],
            max_frames: step.max_frames as f32,
            lights_changed: step.light_change.is_some() as u32,
            light_change: step.light_change.unwrap_or(1.0),
        };
        let bindings = temporal_blend_comp::Bindings {
            frame_final: reads.final_image,
            frame_direct: reads.direct,
            reprojected: &out.reprojected,
            history: &out.history,
            temporal_final: &out.output,
        };
        self.blend
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}

/// What the pass places in the slot's transient memory
/// (`passes::transient`): the reprojected history.
pub(crate) fn transient_resources(extent: (u32, u32)) -> crate::vk::Tenant {
    vec![crate::vk::Planned::Image(super::radiance_desc(extent))]
}

/// The extent's history images in one slot (bytes; on `device` as its
/// memory requirements say): output and history, and the reprojection
/// unless it lives in the slot's `transient` memory.
pub fn slot_bytes(device: Option<&crate::vk::Device>, extent: (u32, u32), transient: bool) -> u64 {
    let images = if transient { 2 } else { 3 };
    images * super::radiance_desc(extent).bytes(device)
}
