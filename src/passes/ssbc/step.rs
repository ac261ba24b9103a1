//! The SSBC steps: per step the radiance pyramids of the previous term, then
//! the residual coarse to fine (evaluation points, resolve, the pixels
//! evaluated alone), the texels-read image, and with a second layer its own
//! residual for the next step.

use super::push::{
    EvalPush, FrameBlock, GeometryMipsPush, IntegralPush, ListPointsPush, ResidualParams,
    ResolvePush, SamplesPush,
};
use super::layout::LIST_HEADER_BYTES;
use super::{Integration, SsbcFrame, SsbcGBuffer, SsbcInputs, SsbcLayer, SsbcPass};
use crate::error::Result;
use crate::shaders::{
    ssbc_eval_comp, ssbc_eval_glossy_comp, ssbc_fallback_comp, ssbc_fallback_glossy_comp, ssbc_layer_residual_comp,
    ssbc_list_points_comp, ssbc_resolve_comp, ssbc_samples_comp,
};
use crate::vk::{Buffer, DescriptorPool, GpuProfiler, Image, Recorder, Work};

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
            level0_position0: $out.level0[0],
            level0_position1: $out.level0[1],
            $($field $(: $value)?),*
        }
    };
}

/// What a step writes, and what it reads from the frame besides the pyramids.
struct StepOutput<'a> {
    gbuffer: SsbcGBuffer<'a>,
    /// Both layers' G-buffer positions (layer 0's twice with one layer),
    /// where the pyramids' level-0 texels are.
    level0: [&'a Image; 2],
    /// `S0 + ... + S_{k-1}` (the final image itself after the first step).
    previous: &'a Image,
    final_image: &'a Image,
    residual: &'a Image,
    residual_sources: &'a Image,
    samples: &'a Image,
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
    /// Which pixel-by-pixel kernels sum the residual (not a push constant:
    /// a specialization of their pipelines).
    integration: Integration,
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
        let level0 = [visible.gbuffer.position, hidden.map_or(visible.gbuffer.position, |h| h.gbuffer.position)];
        let frame_block = FrameBlock::new(inputs, extent, frame, hidden.is_some())
            .with_one_dispatch(self.one_dispatch(inputs.settings));

        let scope = profiler.begin(rec.cmd, "ssbc_geometry_mips");
        let mips = GeometryMipsPush {
            frame: frame_block,
            layer: 0,
            level: 0,
            max_normal_spread: inputs.settings.max_normal_spread,
            max_thickness: inputs.settings.max_thickness,
        };
        for (layer, source) in std::iter::once(visible).chain(hidden).enumerate() {
            let mips = GeometryMipsPush {
                layer: layer as u32,
                ..mips
            };
            let principal = inputs.camera.principal;
            self.record_geometry(rec, pool, (source.gbuffer, level0), mips, principal, frame)?;
        }
        // Evaluation points are stamped with the step's generation (1, 2, ...).
        rec.fill_buffer(&frame.points.buffer, 0);
        rec.fill_buffer(&frame.point_tails.buffer, 0);
        rec.fill_buffer(&frame.point_glossy.buffer, 0);
        rec.fill_buffer(&frame.claims, 0);
        if frame_block.glossy_receivers() && inputs.eval_level >= 1 {
            self.record_list_points(rec, pool, frame_block, inputs.eval_level, frame)?;
        }
        profiler.end(rec.cmd, scope);

        let steps = inputs.settings.steps as usize;
        // Each step adds its residual to the image before it: S0's own, or
        // a copy of S0 in the frame's final image.
        let final_image = frame.final_image.as_ref().unwrap_or(visible.s0);
        for step in 0..steps {
            let previous = if step == 0 { visible.s0 } else { final_image };
            let term = if step == 0 {
                visible.sources
            } else {
                &frame.residual_sources[step - 1]
            };
            let last = step + 1 == steps;
            let push = StepPush {
                frame: frame_block
                    .with_last_step(last)
                    .with_residual_kept(!frame.residuals.is_empty()),
                residual: ResidualParams::new(inputs),
                generation: step as u32 + 1,
                eval_level: inputs.eval_level,
                texels_per_radius: inputs.settings.texels_per_radius,
                scale_fraction: inputs.settings.scale_fraction,
                integration: inputs.settings.integration,
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
                level0,
                previous,
                final_image,
                // Without residual images, the final image (NO_RESIDUAL);
                // a last step's sources are never read (LAST_STEP).
                residual: frame.residuals.get(step).unwrap_or(final_image),
                residual_sources: frame
                    .residual_sources
                    .get(step)
                    .or(frame.residuals.get(step))
                    .unwrap_or(final_image),
                samples: &frame.samples[step],
            };
            let fallback = self.record_residual(rec, profiler, &name, pool, &step_out, &push, frame)?;
            let header = LIST_HEADER_BYTES;
            rec.copy_buffer(fallback, 0, &frame.stats, header * step as u64, header);
            if let (Some(hidden), true) = (hidden, step + 1 < steps) {
                let sub = profiler.begin(rec.cmd, &format!("{name}/layer1_residual"));
                self.record_layer1_residual(rec, pool, (hidden.gbuffer, level0), step, &push, frame)?;
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
        let bindings = ssbc_list_points_comp::Bindings {
            geo_texels: &frame.geo,
            aux_texels: &frame.aux,
            points: &frame.top_points,
        };
        let (w, h) = Self::level_extent(frame, 0, level);
        let push = ListPointsPush {
            frame: frame_block,
            level,
        };
        let texels = Work::Threads([w, h, 1]);
        self.list_points.dispatch(rec, pool, &bindings, &push, texels)
    }

    /// Layer 1's residual of step `step` (its sources in the next step).
    fn record_layer1_residual(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        (gbuffer, level0): (SsbcGBuffer<'_>, [&Image; 2]),
        step: usize,
        push: &StepPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let out = &frame.layer1_residuals[step];
        let bindings = ssbc_layer_residual_comp::Bindings {
            geo_texels: &frame.geo,
            level0_position0: level0[0],
            level0_position1: level0[1],
            radiance_texels: &frame.radiance,
            g_position: gbuffer.position,
            g_normal: gbuffer.normal,
            g_albedo: gbuffer.albedo,
            residual: out,
        };
        let pixels = Work::pixels(gbuffer.extent());
        let kernel = &self.pixel_integrals(push.integration).layer_residual;
        kernel.dispatch(rec, pool, &bindings, &push.integral(), pixels)
    }

    /// One step's residual, coarse to fine: the evaluation points of the
    /// coarsest level; every pixel interpolates them or asks for finer ones
    /// and waits for the next level; at level 1 what is left is evaluated
    /// pixel by pixel (the fallback list, which it returns: one of the two
    /// pending lists). Then the samples image.
    #[allow(clippy::too_many_arguments)]
    fn record_residual<'f>(
        &self,
        rec: &mut Recorder<'_>,
        profiler: &mut GpuProfiler,
        step_name: &str,
        pool: &DescriptorPool,
        out: &StepOutput<'_>,
        push: &StepPush,
        frame: &'f SsbcFrame,
    ) -> Result<&'f Buffer> {
        let pixels = out.gbuffer.extent();
        let top = push.eval_level;
        // The coarsest level: every texel is an evaluation point, every pixel
        // tries to interpolate. Level 0 has no points: every pixel goes to
        // the fallback list.
        if top >= 1 {
            let (w, h) = Self::level_extent(frame, 0, top);
            let timed = (&mut *profiler, format!("{step_name}/eval_{top}"));
            let top_list = push.frame.glossy_receivers().then_some(&frame.top_points);
            let eval = push.eval(top, top_list.is_some());
            self.record_eval(rec, timed, pool, &eval, (frame, out), (top_list, [w, h, 1]))?;
        }
        // The two pixel lists in turn: what one level's resolve leaves, the
        // next reads; level 1's leaves the pixels evaluated alone (the
        // fallback list).
        let mut pending_in = &frame.pending[1]; // unused while not from a list
        let mut pending_out = &frame.pending[0];
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{top}"));
        self.record_resolve(
            rec,
            pool,
            &push.resolve(top, false),
            frame,
            out,
            (pending_in, pending_out),
            Some([pixels.0, pixels.1, 1]),
        )?;
        profiler.end(rec.cmd, sub);
        // Finer levels: the points asked for, the pixels still pending.
        for level in (1..top).rev() {
            let timed = (&mut *profiler, format!("{step_name}/eval_{level}"));
            let list = Some(&frame.requests);
            self.record_eval(rec, timed, pool, &push.eval(level, true), (frame, out), (list, [0; 3]))?;
            pending_in = pending_out;
            pending_out = if std::ptr::eq(pending_in, &frame.pending[0]) {
                &frame.pending[1]
            } else {
                &frame.pending[0]
            };
            let sub = profiler.begin(rec.cmd, &format!("{step_name}/resolve_{level}"));
            let lists = (pending_in, pending_out);
            self.record_resolve(rec, pool, &push.resolve(level, true), frame, out, lists, None)?;
            profiler.end(rec.cmd, sub);
        }
        let fallback = pending_out;
        // The pixels no point could stand for, glossy receivers at the back
        // of the list: the kernel without the glossy code takes the front,
        // the glossy kernel the back (with one dispatch, both).
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/fallback"));
        let kernels = self.pixel_integrals(push.integration);
        let one = push.frame.one_dispatch();
        if !one {
            let bindings = with_output_images!(ssbc_fallback_comp, out, {
                geo_texels: &frame.geo,
                radiance_texels: &frame.radiance,
                pending_in: fallback,
            });
            let front = Work::Indirect(fallback, FRONT);
            kernels.fallback.dispatch(rec, pool, &bindings, &push.integral(), front)?;
        }
        if push.frame.glossy_receivers() {
            // Timed on its own only where it follows the other kernel.
            let sub = (!one).then(|| profiler.begin(rec.cmd, &format!("{step_name}/fallback/glossy")));
            let bindings = with_output_images!(ssbc_fallback_glossy_comp, out, {
                geo_texels: &frame.geo,
                radiance_texels: &frame.radiance,
                pending_in: fallback,
            });
            let ends = Work::Indirect(fallback, if one { BOTH_ENDS } else { BACK });
            kernels.fallback_glossy.dispatch(rec, pool, &bindings, &push.integral(), ends)?;
            if let Some(sub) = sub {
                profiler.end(rec.cmd, sub);
            }
        }
        profiler.end(rec.cmd, sub);
        let sub = profiler.begin(rec.cmd, &format!("{step_name}/samples"));
        self.record_samples(rec, pool, out, push, frame)?;
        profiler.end(rec.cmd, sub);
        Ok(fallback)
    }

    /// Texels read per pixel: each pixel's own, plus its share of the
    /// evaluation points whose blocks it is in.
    fn record_samples(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        out: &StepOutput<'_>,
        push: &StepPush,
        frame: &SsbcFrame,
    ) -> Result<()> {
        let bindings = ssbc_samples_comp::Bindings {
            geo_texels: &frame.geo,
            aux_texels: &frame.aux,
            point_tails: &frame.point_tails,
            samples: out.samples,
        };
        let samples_push = SamplesPush {
            frame: push.frame,
            eval_level: push.eval_level,
            generation: push.generation,
        };
        let pixels = Work::pixels(out.gbuffer.extent());
        self.samples
            .dispatch(rec, pool, &bindings, &samples_push, pixels)
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
        (frame, out): (&SsbcFrame, &StepOutput<'_>),
        (list, groups): (Option<&Buffer>, [u32; 3]),
    ) -> Result<()> {
        let gbuffer = &out.gbuffer;
        let scope = profiler.begin(rec.cmd, &name);
        // Bound (and so, for synchronization, read) even when unused.
        let requests = list.unwrap_or(&frame.requests);
        let one = push.frame.one_dispatch();
        if !one {
            let bindings = ssbc_eval_comp::Bindings {
                geo_texels: &frame.geo,
                aux_texels: &frame.aux,
                radiance_texels: &frame.radiance,
                eval_points: &frame.points,
                point_tails: &frame.point_tails,
                requests,
                g_normal: gbuffer.normal,
                level0_position0: out.level0[0],
                level0_position1: out.level0[1],
            };
            let ends = if push.frame.glossy_receivers() { FRONT } else { BOTH_ENDS };
            let work = threads_or_list(list.is_none().then_some(groups), (requests, ends));
            self.eval.dispatch(rec, pool, &bindings, push, work)?;
        }
        if push.frame.glossy_receivers() {
            // Timed on its own only where it follows the other kernel.
            let sub = (!one).then(|| profiler.begin(rec.cmd, &format!("{name}/glossy")));
            let bindings = ssbc_eval_glossy_comp::Bindings {
                geo_texels: &frame.geo,
                aux_texels: &frame.aux,
                radiance_texels: &frame.radiance,
                eval_points: &frame.points,
                point_tails: &frame.point_tails,
                requests,
                g_normal: gbuffer.normal,
                g_albedo: gbuffer.albedo,
                point_glossy: &frame.point_glossy,
                level0_position0: out.level0[0],
                level0_position1: out.level0[1],
            };
            let ends = Work::Indirect(requests, if one { BOTH_ENDS } else { BACK });
            self.eval_glossy.dispatch(rec, pool, &bindings, push, ends)?;
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
        // Points of this level are read as texels; the next finer level's
        // are claimed.
        let bindings = with_output_images!(ssbc_resolve_comp, out, {
            geo_texels: &frame.geo,
            aux_texels: &frame.aux,
            claims: &frame.claims,
            pending_in,
            pending_out,
            requests: &frame.requests,
            point_texels: &frame.points,
            point_tails: &frame.point_tails,
            point_glossy: &frame.point_glossy,
        });
        let work = threads_or_list(groups, (pending_in, FRONT));
        self.resolve.dispatch(rec, pool, &bindings, push, work)
    }
}

/// `threads` invocations, or (None) the work groups a list's header in
/// `args` holds at the offset.
fn threads_or_list<'a>(threads: Option<[u32; 3]>, (args, offset): (&'a Buffer, u64)) -> Work<'a> {
    match threads {
        Some(threads) => Work::Threads(threads),
        None => Work::Indirect(args, offset),
    }
}
