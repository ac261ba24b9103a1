//! The SSBC steps: per step the radiance pyramids of the previous term, then
//! the residual coarse to fine (evaluation points, resolve, the pixels
//! evaluated alone), the texels-read image, and with a second layer its own
//! residual for the next step.

use super::push::{
    EvalPush, FrameBlock, GeometryMipsPush, IntegralPush, ListPointsPush, ResidualParams,
    ResolvePush, SamplesPush,
};
use super::frame::LIST_HEADER_BYTES;
use super::{SsbcFrame, SsbcGBuffer, SsbcInputs, SsbcLayer, SsbcPass};
use crate::error::Result;
use crate::shaders::{
    ssbc_eval_comp, ssbc_eval_glossy_comp, ssbc_fallback_comp, ssbc_fallback_glossy_comp, ssbc_layer_residual_comp,
    ssbc_list_points_comp, ssbc_resolve_comp, ssbc_samples_comp,
};
use crate::vk::{
    Access, Buffer, ComputeKernel, DescriptorPool, GpuProfiler, Image, Recorder, ShaderInterface,
};

/// A list's header (`ListHeader` in shaders/include/ssbc_types.glsl): a
/// `VkDispatchIndirectCommand` over both ends and the front's count, one
/// over the front and the back's count, one over the back and padding.
const LIST_HEADER: [u32; 12] = [0, 1, 1, 0, 0, 1, 1, 0, 0, 1, 1, 0];
/// Where in a list's header the dispatch over both its ends, its front
/// alone and its back alone are.
const BOTH_ENDS: u64 = 0;
const FRONT: u64 = 16;
const BACK: u64 = 32;

/// The `Bindings` of shader module `$shader`, a kernel that writes a step's
/// output (ssbc_output.glsl's images, from the `StepOutput` `$out`), with
/// the kernel's other bindings.
macro_rules! with_output_images {
    ($shader:ident, $out:expr, { $($field:ident $(: $value:expr)?),* $(,)? }) => {
        $shader::Bindings {
            g_position: $out.gbuffer.position,
            g_normal: $out.gbuffer.normal,
            g_albedo: $out.gbuffer.albedo,
            previous: $out.previous,
            final_image: $out.final_image,
            residual: $out.residual,
            residual_sources: $out.residual_sources,
            samples: $out.samples,
            $($field $(: $value)?),*
        }
    };
}

/// What a step writes, and what it reads from the frame besides the pyramids.
struct StepOutput<'a> {
    gbuffer: SsbcGBuffer<'a>,
    /// `S0 + ... + S_{k-1}` (the final image itself after the first step).
    previous: &'a Image,
    final_image: &'a Image,
    residual: &'a Image,
    residual_sources: &'a Image,
    samples: &'a Image,
}

impl StepOutput<'_> {
    /// Declares the images of ssbc_output.glsl.
    fn declare(&self, rec: &mut Recorder<'_>) {
        self.gbuffer.read_in_compute(rec);
        // After the first step `previous` is the final image itself (read and
        // written by the same invocation).
        if !std::ptr::eq(self.previous, self.final_image) {
            rec.use_image(self.previous, Access::ComputeRead);
        }
        rec.use_image(self.final_image, Access::ComputeWrite);
        rec.use_image(self.residual, Access::ComputeWrite);
        rec.use_image(self.residual_sources, Access::ComputeWrite);
        rec.use_image(self.samples, Access::ComputeWrite);
    }
}

/// The push constants of one step, its kernels' blocks built from these.
#[derive(Clone, Copy)]
struct StepPush {
    frame: FrameBlock,
    residual: ResidualParams,
    generation: u32,
    eval_level: u32,
    texels_per_radius: f32,
    scale_fraction: f32,
}

impl StepPush {
    fn eval(&self, level: u32, from_list: bool) -> EvalPush {
        EvalPush {
            frame: self.frame,
            residual: self.residual,
            level,
            from_list: from_list as u32,
            generation: self.generation,
            texels_per_radius: self.texels_per_radius,
        }
    }

    fn resolve(&self, level: u32, from_list: bool) -> ResolvePush {
        ResolvePush {
            frame: self.frame,
            level,
            from_list: from_list as u32,
            generation: self.generation,
            texels_per_radius: self.texels_per_radius,
            scale_fraction: self.scale_fraction,
        }
    }

    fn integral(&self) -> IntegralPush {
        IntegralPush {
            frame: self.frame,
            residual: self.residual,
        }
    }
}

impl SsbcPass {
    /// Records the geometry pyramids and every step: `visible` is layer 0
    /// (its G-buffer and `S0 = T Le + T_b L^`, where the residual is
    /// written), `hidden` the optional second layer (at the frame's
    /// [`SsbcFrame::layer1`] resolution), whose surfaces are sources too.
    #[allow(clippy::too_many_arguments)]
    pub fn record_steps(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        pool: &DescriptorPool,
        visible: SsbcLayer<'_>,
        hidden: Option<SsbcLayer<'_>>,
        inputs: &SsbcInputs<'_>,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let extent = visible.gbuffer.extent();
        let hidden = hidden.filter(|_| frame.layer1.is_some());
        let frame_block = FrameBlock::new(inputs, extent, frame, hidden.is_some())
            .with_one_dispatch(self.one_dispatch);

        let scope = profiler.begin(rec.cmd, "ssbc_geometry_mips");
        let mips = GeometryMipsPush {
            frame: frame_block,
            layer: 0,
            level: 0,
            max_normal_spread: inputs.settings.max_normal_spread,
            max_thickness: inputs.settings.max_thickness,
        };
        for (layer, source) in std::iter::once(visible).chain(hidden).enumerate() {
            self.record_geometry(rec, pool, source.gbuffer, layer as u32, mips, frame)?;
        }
        // Evaluation points are stamped with the step's generation (1, 2, ...).
        rec.fill_buffer(&frame.points, 0);
        rec.fill_buffer(&frame.point_glossy, 0);
        rec.fill_buffer(&frame.claims, 0);
        if frame_block.glossy_receivers() {
            self.record_list_points(rec, pool, frame_block, inputs.eval_level, frame)?;
        }
        profiler.end(rec.cmd, scope);

        let steps = inputs.settings.steps as usize;
        for step in 0..steps {
            let previous = if step == 0 {
                visible.s0
            } else {
                &frame.final_image
            };
            let term = if step == 0 {
                visible.sources
            } else {
                &frame.residual_sources[step - 1]
            };
            let push = StepPush {
                frame: frame_block,
                residual: ResidualParams::new(inputs),
                generation: step as u32 + 1,
                eval_level: inputs.eval_level,
                texels_per_radius: inputs.settings.texels_per_radius,
                scale_fraction: inputs.settings.scale_fraction,
            };
            let name = format!("ssbc_step_{}", step + 1);
            let scope = profiler.begin(rec.cmd, &name);
            let sub = profiler.begin(rec.cmd, &format!("{name}/radiance_mips"));
            self.record_radiance_mips(rec, pool, term, 0, frame_block, frame)?;
            if let Some(hidden) = hidden {
                let term = if step == 0 {
                    hidden.sources
                } else {
                    &frame.layer1_residuals[step - 1]
                };
                self.record_radiance_mips(rec, pool, term, 1, frame_block, frame)?;
            }
            profiler.end(rec.cmd, sub);
            let step_out = StepOutput {
                gbuffer: visible.gbuffer,
                previous,
                final_image: &frame.final_image,
                residual: &frame.residuals[step],
                residual_sources: &frame.residual_sources[step],
                samples: &frame.samples[step],
            };
            self.record_residual(rec, profiler, &name, pool, &step_out, &push, frame)?;
            let header = LIST_HEADER_BYTES;
            rec.copy_buffer(&frame.fallback, 0, &frame.stats, header * step as u64, header);
            if let (Some(hidden), true) = (hidden, step + 1 < steps) {
                let sub = profiler.begin(rec.cmd, &format!("{name}/layer1_residual"));
                self.record_layer1_residual(rec, pool, hidden.gbuffer, step, &push, frame)?;
                profiler.end(rec.cmd, sub);
            }
            profiler.end(rec.cmd, scope);
        }
        Ok(())
    }

    /// The coarsest level's evaluation points as a two-ended list
    /// (`frame.top_points`), for frames with glossy receivers.
    fn record_list_points(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        frame_block: FrameBlock,
        level: u32,
        frame: &SsbcFrame,
    ) -> Result<()> {
        rec.update_buffer(&frame.top_points, 0, bytemuck::bytes_of(&LIST_HEADER));
        Self::read_pyramids(rec, frame);
        rec.use_buffer(&frame.top_points, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = ssbc_list_points_comp::Bindings {
            aux_texels: &frame.aux_view,
            points: &frame.top_points,
        };
        let (w, h) = Self::level_extent(frame, 0, level);
        let push = ListPointsPush {
            frame: frame_block,
            level,
        };
        self.list_points
            .dispatch(rec.cmd, pool, &bindings, &push, [w.div_ceil(64), h, 1])
    }

    /// Layer 1's residual of step `step` (its sources in the next step).
    fn record_layer1_residual(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        gbuffer: SsbcGBuffer<'_>,
        step: usize,
        push: &StepPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let out = &frame.layer1_residuals[step];
        Self::read_pyramids(rec, frame);
        gbuffer.read_in_compute(rec);
        rec.use_image(out, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = ssbc_layer_residual_comp::Bindings {
            geo_texels: &frame.geo_view,
            radiance_texels: &frame.radiance_view,
            g_position: gbuffer.position,
            g_normal: gbuffer.normal,
            g_albedo: gbuffer.albedo,
            residual: out,
        };
        self.layer_residual.dispatch_2d(
            rec.cmd,
            pool,
            &bindings,
            &push.integral(),
            gbuffer.extent(),
        )
    }

    /// One step's residual, coarse to fine: the evaluation points of the
    /// coarsest level; every pixel interpolates them or asks for finer ones
    /// and waits for the next level; at level 1 what is left is evaluated
    /// pixel by pixel (the fallback list). Then the samples image.
    #[allow(clippy::too_many_arguments)]
    fn record_residual(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        step_name: &str,
        pool: &DescriptorPool,
        out: &StepOutput<'_>,
        push: &StepPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let pixels = out.gbuffer.extent();
        let top = push.eval_level;
        // The coarsest level: every texel is an evaluation point, every pixel
        // tries to interpolate.
        let (w, h) = Self::level_extent(frame, 0, top);
        let timed = (&mut *profiler, format!("{step_name}/eval_{top}"));
        let top_list = push.frame.glossy_receivers().then_some(&frame.top_points);
        let eval = push.eval(top, top_list.is_some());
        self.record_eval(rec, timed, pool, &eval, (frame, &out.gbuffer), (top_list, [w.div_ceil(64), h, 1]))?;
        let mut pending_in = &frame.fallback; // unused while not from a list
        let mut pending_out = if top >= 2 {
            &frame.pending[0]
        } else {
            &frame.fallback
        };
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{top}"));
        self.record_resolve(
            rec,
            pool,
            &push.resolve(top, false),
            frame,
            out,
            (pending_in, pending_out),
            Some([pixels.0.div_ceil(64), pixels.1, 1]),
        )?;
        profiler.end(rec.cmd, sub);
        // Finer levels: the points asked for, the pixels still pending.
        for level in (1..top).rev() {
            let timed = (&mut *profiler, format!("{step_name}/eval_{level}"));
            let list = Some(&frame.requests);
            self.record_eval(rec, timed, pool, &push.eval(level, true), (frame, &out.gbuffer), (list, [0; 3]))?;
            pending_in = pending_out;
            pending_out = if level == 1 {
                &frame.fallback
            } else if std::ptr::eq(pending_in, &frame.pending[0]) {
                &frame.pending[1]
            } else {
                &frame.pending[0]
            };
            let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{level}"));
            let lists = (pending_in, pending_out);
            self.record_resolve(rec, pool, &push.resolve(level, true), frame, out, lists, None)?;
            profiler.end(rec.cmd, sub);
        }
        // The pixels no point could stand for, glossy receivers at the back
        // of the list: the kernel without the glossy code takes the front,
        // the glossy kernel the back (with one dispatch, both).
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/fallback"));
        let one = push.frame.one_dispatch();
        if !one {
            Self::read_pyramids(rec, frame);
            out.declare(rec);
            read_list(rec, &frame.fallback);
            rec.flush_barriers();
            let bindings = with_output_images!(ssbc_fallback_comp, out, {
                geo_texels: &frame.geo_view,
                radiance_texels: &frame.radiance_view,
                pending_in: &frame.fallback,
            });
            let push = push.integral();
            self.fallback.dispatch_indirect(rec.cmd, pool, &bindings, &push, &frame.fallback, FRONT)?;
        }
        if push.frame.glossy_receivers() {
            // Timed on its own only where it follows the other kernel.
            let sub = (!one).then(|| profiler.begin(rec.cmd, &format!("{step_name}/fallback/glossy")));
            Self::read_pyramids(rec, frame);
            out.declare(rec);
            read_list(rec, &frame.fallback);
            rec.flush_barriers();
            let bindings = with_output_images!(ssbc_fallback_glossy_comp, out, {
                geo_texels: &frame.geo_view,
                radiance_texels: &frame.radiance_view,
                pending_in: &frame.fallback,
            });
            let ends = if one { BOTH_ENDS } else { BACK };
            let push = push.integral();
            self.fallback_glossy.dispatch_indirect(rec.cmd, pool, &bindings, &push, &frame.fallback, ends)?;
            if let Some(sub) = sub {
                profiler.end(rec.cmd, sub);
            }
        }
        profiler.end(rec.cmd, sub);
        // Texels read per pixel.
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/samples"));
        Self::read_pyramids(rec, frame);
        rec.use_buffer(&frame.points, Access::ComputeSampled);
        rec.use_image(out.samples, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = ssbc_samples_comp::Bindings {
            aux_texels: &frame.aux_view,
            point_texels: &frame.point_view,
            samples: out.samples,
        };
        let samples_push = SamplesPush {
            frame: push.frame,
            eval_level: push.eval_level,
            generation: push.generation,
        };
        self.samples
            .dispatch_2d(rec.cmd, pool, &bindings, &samples_push, pixels)?;
        profiler.end(rec.cmd, sub);
        Ok(())
    }

    /// Evaluation points of `push.level`: those of a list (a two-ended
    /// one, glossy receivers at the back) or, without one, every texel in
    /// `groups` work groups. The kernel without the glossy code takes the
    /// front, the glossy kernel the back, with its pixel's BRDF from the
    /// G-buffer (with one dispatch, both). Timed as `timed.1`, the glossy
    /// kernel after the other also as `{timed.1}/glossy`.
    fn record_eval(
        &self,
        rec: &mut Recorder<'_>,
        (profiler, name): (&mut GpuProfiler, String),
        pool: &DescriptorPool,
        push: &EvalPush,
        (frame, gbuffer): (&SsbcFrame, &SsbcGBuffer<'_>),
        (list, groups): (Option<&Buffer>, [u32; 3]),
    ) -> Result<()> {
        let scope = profiler.begin(rec.cmd, &name);
        // Bound (and so, for synchronization, read) even when unused.
        let requests = list.unwrap_or(&frame.requests);
        let one = push.frame.one_dispatch();
        if !one {
            Self::read_pyramids(rec, frame);
            rec.use_buffer(&frame.points, Access::ComputeWrite);
            if list.is_some() {
                rec.use_buffer(requests, Access::IndirectRead);
            }
            rec.use_buffer(requests, Access::ComputeRead);
            rec.flush_barriers();
            let bindings = ssbc_eval_comp::Bindings {
                geo_texels: &frame.geo_view,
                aux_texels: &frame.aux_view,
                radiance_texels: &frame.radiance_view,
                eval_points: &frame.point_view,
                requests,
                g_normal: gbuffer.normal,
            };
            let groups = list.is_none().then_some(groups);
            let ends = if push.frame.glossy_receivers() { FRONT } else { BOTH_ENDS };
            dispatch_or_indirect(&self.eval, rec, pool, &bindings, push, groups, (requests, ends))?;
        }
        if push.frame.glossy_receivers() {
            // Timed on its own only where it follows the other kernel.
            let sub = (!one).then(|| profiler.begin(rec.cmd, &format!("{name}/glossy")));
            Self::read_pyramids(rec, frame);
            gbuffer.read_in_compute(rec);
            rec.use_buffer(&frame.points, Access::ComputeWrite);
            rec.use_buffer(&frame.point_glossy, Access::ComputeWrite);
            read_list(rec, requests);
            rec.flush_barriers();
            let bindings = ssbc_eval_glossy_comp::Bindings {
                geo_texels: &frame.geo_view,
                aux_texels: &frame.aux_view,
                radiance_texels: &frame.radiance_view,
                eval_points: &frame.point_view,
                requests,
                g_normal: gbuffer.normal,
                g_albedo: gbuffer.albedo,
                point_glossy: &frame.point_glossy_view,
            };
            let ends = if one { BOTH_ENDS } else { BACK };
            dispatch_or_indirect(&self.eval_glossy, rec, pool, &bindings, push, None, (requests, ends))?;
            if let Some(sub) = sub {
                profiler.end(rec.cmd, sub);
            }
        }
        profiler.end(rec.cmd, scope);
        Ok(())
    }

    /// Resolve at `push.level`: pixels of `lists.0` (or every pixel, with
    /// `groups`) interpolate or go on `lists.1`, asking for finer points.
    #[allow(clippy::too_many_arguments)]
    fn record_resolve(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        push: &ResolvePush,
        frame: &SsbcFrame,
        out: &StepOutput<'_>,
        lists: (&Buffer, &Buffer),
        groups: Option<[u32; 3]>,
    ) -> Result<()> {
        let (pending_in, pending_out) = lists;
        rec.update_buffer(pending_out, 0, bytemuck::bytes_of(&LIST_HEADER));
        rec.update_buffer(&frame.requests, 0, bytemuck::bytes_of(&LIST_HEADER));
        Self::read_pyramids(rec, frame);
        out.declare(rec);
        // Points of this level are read as texels; the next finer level's
        // are claimed.
        rec.use_buffer(&frame.points, Access::ComputeSampled);
        rec.use_buffer(&frame.point_glossy, Access::ComputeSampled);
        rec.use_buffer(&frame.claims, Access::ComputeWrite);
        if groups.is_none() {
            rec.use_buffer(pending_in, Access::IndirectRead);
        }
        // Bound (and so, for synchronization, read) even when unused.
        rec.use_buffer(pending_in, Access::ComputeRead);
        rec.use_buffer(pending_out, Access::ComputeWrite);
        rec.use_buffer(&frame.requests, Access::ComputeWrite);
        rec.flush_barriers();
        let bindings = with_output_images!(ssbc_resolve_comp, out, {
            geo_texels: &frame.geo_view,
            aux_texels: &frame.aux_view,
            claims: &frame.claims,
            pending_in,
            pending_out,
            requests: &frame.requests,
            point_texels: &frame.point_view,
            point_glossy: &frame.point_glossy_view,
        });
        dispatch_or_indirect(&self.resolve, rec, pool, &bindings, push, groups, (pending_in, FRONT))
    }
}

/// Dispatches `groups`, or (None) the work groups a list's header in `args`
/// holds.
fn dispatch_or_indirect<I: ShaderInterface, P: bytemuck::Pod>(
    kernel: &ComputeKernel<I, P>,
    rec: &mut Recorder<'_>,
    pool: &DescriptorPool,
    bindings: &I::Bindings<'_>,
    push: &P,
    groups: Option<[u32; 3]>,
    (args, offset): (&Buffer, u64),
) -> Result<()> {
    match groups {
        Some(groups) => kernel.dispatch(rec.cmd, pool, bindings, push, groups),
        None => kernel.dispatch_indirect(rec.cmd, pool, bindings, push, args, offset),
    }
}

/// Declares a work list read by an indirect dispatch over it: its header as
/// the dispatch's arguments, its items by the kernel.
fn read_list(rec: &mut Recorder<'_>, list: &Buffer) {
    rec.use_buffer(list, Access::IndirectRead);
    rec.use_buffer(list, Access::ComputeRead);
}
