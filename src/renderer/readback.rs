//! What a frame hands back: its layers read back to the host ([`Frame`]),
//! or one of its images ([`Layer`]; kept on the GPU, or copied into a
//! host's image).

use ash::vk;
use gpu_allocator::MemoryLocation;

use crate::cpu::vpl::Vpl;
use crate::error::{Error, Result};
use crate::layer::Layer;
use crate::memory::{FrameMemory, MemoryReport};
use crate::passes::indirect_bounded::IsmTest;
use crate::passes::ism::Ism;
use crate::passes::ssbc::{Integration, SsbcFrame, SsbcPass, CUT_SHORT};
use crate::passes::FrameView;
use crate::scene_cache::SceneCache;
use crate::settings::{RenderSettings, Visibility};
use crate::timings::{CpuSpan, CpuTimings, SsbcStepTiming, Timings};
use crate::vk::HostImage;
use crate::vk::{Access, Buffer, CommandPool, Device, GpuFrameTimes, Image, Recorder};

use super::guard_band::GuardBand;

/// One layer read back: linear radiance (or, for the debug layers, the
/// G-buffer's values), RGBA f32 per pixel, rows top to bottom.
#[derive(Clone, Debug)]
pub struct LayerImage {
    /// Which layer.
    pub layer: Layer,
    /// `width * height * 4` floats (the second layer's at its resolution);
    /// alpha is 1 on geometry, 0 on background.
    pub rgba: Vec<f32>,
}

/// The ISM atlas, read back for diagnostics.
#[derive(Clone, Debug)]
pub struct IsmReadback {
    /// Atlas width.
    pub width: u32,
    /// Atlas height.
    pub height: u32,
    /// Tile side.
    pub tile: u32,
    /// Tiles per row.
    pub tiles_per_row: u32,
    /// Distances are stored divided by this.
    pub far: f32,
    /// The atlas, as distances divided by `far`.
    pub depth: Vec<f32>,
    /// Per texel, |cos| between the VPL's ray and the normal of the surface
    /// it stores where only that is known (the ray-cast layer's blocks; -1:
    /// not known, or see `normal`).
    pub facing: Vec<f32>,
    /// Per texel, the normal (up to sign) of the surface it stores, where
    /// known (a splatted point's).
    pub normal: Vec<Option<glam::Vec3>>,
    /// Per texel, ISM_BACK_FLAG (front texels whose back-face map texel
    /// holds a surface that the back-face test may need).
    pub back_flag: Vec<bool>,
    /// World radius of one splatted point.
    pub point_radius: f32,
}

impl IsmReadback {
    /// The GPU's ISM visibility test, replayed on the CPU: is `x` visible from
    /// VPL `index` (at `vpl`) according to its imperfect shadow map? `normal`
    /// is the receiver's surface's (its geometric normal where a normal map
    /// turns the shading normal), `test` how its BRDF is tested
    /// ([`ism_test_for`](crate::passes::indirect_bounded::ism_test_for)).
    pub fn visible(
        &self,
        index: usize,
        vpl: &Vpl,
        x: glam::Vec3,
        normal: glam::Vec3,
        test: IsmTest,
    ) -> bool {
        self.front_visible(index, vpl, x, normal, test) && !self.behind_back_face(index, vpl, x)
    }

    /// Whether `x` lands in a flagged texel (ISM_BACK_FLAG) and lies beyond
    /// the surface VPL `index`'s back-face map holds there
    /// (ism_behind_back_face() in shaders/include/vpl_gather.glsl).
    fn behind_back_face(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> bool {
        let (front, dist, w) = self.lookup(index, vpl, x);
        if !self.back_flag[front] {
            return false;
        }
        let texel = front + (self.height / 2) as usize * self.width as usize;
        let depth = self.depth[texel] * self.far;
        if dist <= depth {
            return false;
        }
        let Some(m) = self.normal[texel] else {
            return false;
        };
        let (wm, cm) = (w.dot(m), self.centre_ray(vpl, texel).dot(m));
        if wm.abs() < ISM_BACK_MIN_COS || cm * wm <= 0.0 {
            return false;
        }
        dist > depth * cm / wm + ISM_BACK_RELATIVE * dist / wm.abs() + self.floor()
    }

    /// The test's absolute tolerance: 1 mm, or a thousandth of the scene's
    /// diagonal (`far`) under a metre (ism_floor() in shaders/include/ism.glsl).
    fn floor(&self) -> f32 {
        1e-3 * self.far.min(1.0)
    }

    /// The front map's test alone (ism_front_visible()): without back-face
    /// maps, the whole test.
    pub fn front_visible(
        &self,
        index: usize,
        vpl: &Vpl,
        x: glam::Vec3,
        normal: glam::Vec3,
        test: IsmTest,
    ) -> bool {
        let relative_bias = test.relative_bias;
        // ism_visible() in shaders/include/vpl_gather.glsl.
        let (texel, dist, w) = self.lookup(index, vpl, x);
        let depth = self.depth[texel] * self.far;
        let footprint = (dist * 4.0 / self.tile as f32).max(self.point_radius);
        let lifted_visible = || {
            // Whether the receiver lifted off its surface passes too.
            let lifted = x + normal * (ISM_LIFT * footprint);
            if (lifted - vpl.position).dot(vpl.normal) <= 0.0 {
                return true;
            }
            let (texel, dist, _) = self.lookup(index, vpl, lifted);
            dist <= self.depth[texel] * self.far + relative_bias * dist + self.floor()
        };
        if dist <= depth + relative_bias * dist + self.floor() {
            return !test.lifted || lifted_visible();
        }
        let relative = relative_bias * dist + self.floor();
        let slope_of = |c: f32| {
            let c = c.clamp(0.1, 1.0);
            (1.0 - c * c).sqrt() / c
        };
        // Beyond the slope term's bound, the receiver's own slope: hidden.
        let own_slope = slope_of(-normal.dot(w));
        if dist > depth + relative + footprint * own_slope {
            return false;
        }
        // The stored plane along the receiver's ray, where it is known and
        // turns across the receiver's surface.
        let along = self.normal[texel].and_then(|m| {
            let (wm, cm) = (w.dot(m), self.centre_ray(vpl, texel).dot(m));
            (m.dot(normal).abs() < ISM_PLANE_MAX_COS
                && wm.abs() > ISM_PLANE_MIN_COS
                && cm * wm > 0.0)
                .then(|| depth * cm / wm)
        });
        let within = match along {
            Some(along) => dist <= along + ISM_PLANE_RELATIVE * relative,
            None => {
                // ism_tolerance() in shaders/include/ism.glsl.
                let mut slope = own_slope;
                let facing = self.normal[texel].map_or(self.facing[texel], |m| m.dot(w).abs());
                if facing >= 0.0 {
                    slope = slope.min(ISM_SLOPE_MARGIN * slope_of(facing));
                }
                dist <= depth + relative + footprint * slope
            }
        };
        if !within {
            return false;
        }
        !test.lifted || lifted_visible()
    }

    /// Whether the texel where `x` lands in VPL `index`'s map carries
    /// ISM_BACK_FLAG: a gather with back-face maps reads its back face
    /// there (where the front test passes).
    pub fn back_face_flagged(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> bool {
        self.back_flag[self.lookup(index, vpl, x).0]
    }

    /// Whether the distance VPL `index`'s map stores where `x` lands lies
    /// at or beyond `x` (no occluder there at all, rather than one within
    /// the test's tolerance).
    pub fn stored_beyond(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> bool {
        let (texel, dist, _) = self.lookup(index, vpl, x);
        self.depth[texel] * self.far >= dist
    }

    /// The normal (up to sign) of the surface the texel where `x` lands in
    /// VPL `index`'s map stores, where known (a splatted point's; `None`
    /// for the ray-cast layer's blocks and empty texels).
    pub fn stored_normal(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> Option<glam::Vec3> {
        self.normal[self.lookup(index, vpl, x).0]
    }

    /// Where `x` lands in VPL `index`'s map: the unit ray through its
    /// texel's centre (the one the texel's distance is measured along),
    /// and the distance (m) the texel stores.
    pub fn texel_centre_ray(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> (glam::Vec3, f32) {
        let (texel, _, _) = self.lookup(index, vpl, x);
        (self.centre_ray(vpl, texel), self.depth[texel] * self.far)
    }

    /// The unit ray through the centre of atlas texel `texel`, in the tile
    /// of `vpl` (ism_centre_ray()).
    fn centre_ray(&self, vpl: &Vpl, texel: usize) -> glam::Vec3 {
        let tile = self.tile as usize;
        let local = glam::Vec2::new(
            (texel % self.width as usize % tile) as f32,
            (texel / self.width as usize % tile) as f32,
        );
        let a = (local + glam::Vec2::splat(0.5)) * (2.0 / self.tile as f32) - glam::Vec2::ONE;
        let l = crate::cpu::ism_rays::projected_local(a);
        let (t, b) = crate::cpu::sampling::basis(vpl.normal);
        t * l.x + b * l.y + vpl.normal * l.z
    }

    /// The atlas texel where `x` lands in VPL `index`'s map, its distance
    /// from the VPL and the unit direction to it (ism_texel()).
    fn lookup(&self, index: usize, vpl: &Vpl, x: glam::Vec3) -> (usize, f32, glam::Vec3) {
        let d = x - vpl.position;
        let dist = d.length();
        let w = d / dist;
        let (t, b) = crate::cpu::sampling::basis(vpl.normal);
        let l = glam::Vec3::new(w.dot(t), w.dot(b), w.dot(vpl.normal));
        let a = crate::cpu::ism_rays::projected_coords(l);
        let uv = a * 0.5 + glam::Vec2::splat(0.5);
        let tile = self.tile as i64;
        let origin = (
            (index as u32 % self.tiles_per_row) as i64 * tile,
            (index as u32 / self.tiles_per_row) as i64 * tile,
        );
        let local = ((uv.x * tile as f32) as i64).clamp(0, tile - 1);
        let local_y = ((uv.y * tile as f32) as i64).clamp(0, tile - 1);
        let texel = ((origin.1 + local_y) * self.width as i64 + origin.0 + local) as usize;
        (texel, dist, w)
    }
}

/// ISM_SLOPE_MARGIN in shaders/include/ism.glsl, ISM_LIFT in
/// shaders/include/vpl_gather.glsl.
const ISM_SLOPE_MARGIN: f32 = 1.5;
const ISM_LIFT: f32 = 0.75;

/// ISM_PLANE_RELATIVE, ISM_PLANE_MIN_COS and ISM_PLANE_MAX_COS in
/// shaders/include/vpl_gather.glsl.
const ISM_PLANE_RELATIVE: f32 = 0.5;
const ISM_PLANE_MIN_COS: f32 = 0.05;
const ISM_PLANE_MAX_COS: f32 = 0.3;

/// ISM_BACK_MIN_COS and ISM_BACK_RELATIVE in shaders/include/vpl_gather.glsl.
const ISM_BACK_MIN_COS: f32 = 0.2;
const ISM_BACK_RELATIVE: f32 = 0.002;

/// An atlas texel's distance (divided by `far`), facing (-1: not known) and
/// normal, as `ism_pack` in shaders/include/ism.glsl packs them.
fn ism_unpack(texel: u32) -> (f32, f32, Option<glam::Vec3>) {
    let depth = (texel >> 13) as f32 * (4.0 / 524_287.0);
    let code = texel & 4095;
    match code {
        0 => (depth, -1.0, None),
        1..=255 => (depth, (code - 1) as f32 / 254.0, None),
        _ => {
            // ism_texel_normal(): a turned octahedral map, 6 bits a coordinate.
            let uv = glam::Vec2::new(
                ((code >> 6) as f32 - 4.0) * (2.0 / 59.0),
                (code & 63) as f32 * (2.0 / 63.0),
            ) - glam::Vec2::ONE;
            let e = glam::Vec2::new(uv.x + uv.y, uv.x - uv.y) * 0.5;
            (depth, -1.0, Some(crate::cpu::points::from_octahedral(e)))
        }
    }
}

/// A rendered frame: the final image, its component layers and timings.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// The final image (linear radiance).
    pub image: LayerImage,
    /// The other layers: with [`RenderSettings::output_layers`] the
    /// [`Layer::outputs`] after `Final`, with debug read-back also the
    /// G-buffer's and, with a second layer, its own.
    pub layers: Vec<LayerImage>,
    /// Per-pass GPU timings.
    pub timings: Timings,
    /// The VPLs used.
    pub vpls: Vec<Vpl>,
    /// The bound b used (the last frame's, for an accumulation).
    pub bound: f32,
    /// The ISM atlas (with debug readback).
    pub ism: Option<IsmReadback>,
    /// Texels read per pixel of each SSBC step (see [`SsbcStepTiming`]).
    pub samples: Vec<Vec<f32>>,
    /// Frames with independent VPL sets averaged into it: N for
    /// [`Renderer::render_accumulated`](super::Renderer::render_accumulated),
    /// the still frames a resident frame's temporal history averages
    /// ([`Renderer::accumulated_frames`](super::Renderer::accumulated_frames)),
    /// 1 otherwise.
    pub accumulated: u32,
}

impl Frame {
    /// The image of `layer`, if the frame read it back: [`Layer::Final`]
    /// always, the other outputs with `output_layers`, the G-buffers with
    /// `debug_readback`.
    ///
    /// ```no_run
    /// # fn main() -> ssbc::Result<()> {
    /// use ssbc::Layer;
    /// let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig::default())?;
    /// let mut scene = ssbc::scene::load("cornell")?;
    /// scene.ensure_light();
    /// let mut settings = ssbc::RenderSettings::new(320, 240);
    /// settings.debug_readback = true;
    /// let frame = renderer.render(&scene, &settings)?;
    /// // What the first SSBC step gave back (RGBA f32, row 0 at the top).
    /// let s1 = frame.layer(Layer::Residual(1)).expect("read back");
    /// let mean_red = s1.rgba.chunks(4).map(|p| p[0]).sum::<f32>() / (320.0 * 240.0);
    /// println!("S_1 adds {mean_red} W/(sr m^2) of red on average");
    /// # Ok(()) }
    /// ```
    pub fn layer(&self, layer: Layer) -> Option<&LayerImage> {
        std::iter::once(&self.image)
            .chain(&self.layers)
            .find(|l| l.layer == layer)
    }
}

/// What one frame slot's passes wrote: the layers they offer
/// ([`Pass::layers`](crate::passes::Pass::layers), in the frame's order),
/// SSBC's per-step counts and the ISM atlas.
pub(crate) struct FrameImages<'a> {
    pub layers: Vec<(Layer, &'a Image)>,
    pub ssbc: &'a SsbcFrame,
    pub ism: &'a Ism,
}

impl<'a> FrameImages<'a> {
    /// The image of `layer`, if the frame has it (of `Final`, the last
    /// pass's).
    pub fn layer(&self, layer: Layer) -> Option<&'a Image> {
        let mut offered = self.layers.iter().rev();
        offered.find(|(l, _)| *l == layer).map(|(_, image)| *image)
    }

    /// The images a read-back frame at `settings` copies to the host: the
    /// final image, with `output_layers` (or `debug_readback`) the other
    /// outputs, with `debug_readback` the debug layers too; the per-step
    /// sample counts; with `debug_readback` the ISM atlas.
    pub fn readback(&self, settings: &RenderSettings) -> Vec<(Readback, &'a Image)> {
        let debug = settings.debug_readback;
        let outputs = settings.every_output();
        let mut others: Vec<Layer> = Vec::new();
        for &(l, _) in &self.layers {
            let wanted = if l.is_debug() { debug } else { outputs };
            if wanted && l != Layer::Final && !others.contains(&l) {
                others.push(l);
            }
        }
        // The outputs first, then the debug layers, each in the frame's order.
        others.sort_by_key(|l| l.is_debug());
        let mut v: Vec<(Readback, &'a Image)> = std::iter::once(Layer::Final)
            .chain(others)
            .filter_map(|l| Some((Readback::Layer(l), self.layer(l)?)))
            .collect();
        v.extend(
            (1..)
                .zip(&self.ssbc.samples)
                .map(|(k, img)| (Readback::Samples(k), img)),
        );
        if debug {
            v.push((Readback::IsmAtlas, &self.ism.atlas));
        }
        v
    }
}

/// What a read-back buffer holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Readback {
    Layer(Layer),
    /// Texels read per pixel in step k.
    Samples(u32),
    IsmAtlas,
}

/// Bytes of a slot's host-visible staging buffer: what the largest image
/// to read back takes, at most [`STAGING_BYTES`].
pub(crate) fn staging_bytes(largest_image: u64) -> u64 {
    largest_image.clamp(4, STAGING_BYTES)
}

/// The most a slot's read-back staging takes: images larger than it are
/// copied through it in bands of rows, one submission each, after the
/// frame is done (a 1920x1080 RGBA32F image in 32 bands, 3840x2160 in
/// 127). A copy per band costs a submission and a wait; a buffer per image
/// cost 20 bytes per pixel of host-visible memory in every slot (4 MiB,
/// a quarter of the bands, took 2 bytes per pixel at 1920x1080).
pub(crate) const STAGING_BYTES: u64 = 1 << 20;

/// A slot's read-back: a host-visible staging buffer and the command pool
/// its copies are recorded in.
pub(crate) struct ReadbackBuffers {
    staging: Buffer,
    commands: CommandPool,
}

/// Bytes of a tightly packed host copy of `image`'s first level.
fn readback_size(image: &Image) -> u64 {
    image.desc.bytes(None)
}

/// Makes `held` fit `images` (kept while its staging's size is right).
pub(crate) fn ensure_buffers(
    device: &std::sync::Arc<Device>,
    held: &mut Option<ReadbackBuffers>,
    images: &[(Readback, &Image)],
) -> Result<()> {
    let largest = images.iter().map(|(_, img)| readback_size(img)).max();
    let bytes = staging_bytes(largest.unwrap_or(0));
    if held.as_ref().is_some_and(|r| r.staging.size == bytes) {
        return Ok(());
    }
    *held = None;
    let staging = Buffer::new(
        device,
        "readback.staging",
        bytes,
        vk::BufferUsageFlags::TRANSFER_DST,
        MemoryLocation::GpuToCpu,
    )?;
    let commands = CommandPool::new(device)?;
    commands.name("readback");
    *held = Some(ReadbackBuffers { staging, commands });
    Ok(())
}

/// Copies `images` (whose frame is done) to the host through the staging
/// buffer, band by band: each one's bytes, tightly packed.
pub(crate) fn read_images(
    device: &Device,
    buffers: &mut ReadbackBuffers,
    images: &[(Readback, &Image)],
) -> Result<Vec<(Readback, Vec<u8>)>> {
    let mut out = Vec::with_capacity(images.len());
    for &(what, image) in images {
        let (w, h) = (image.desc.width, image.desc.height);
        let row = readback_size(image) / h as u64;
        let rows_per_band = (buffers.staging.size / row).clamp(1, h as u64) as u32;
        let mut bytes = Vec::with_capacity(readback_size(image) as usize);
        for start in (0..h).step_by(rows_per_band as usize) {
            let rows = start..(start + rows_per_band).min(h);
            let mut rec = buffers.commands.begin()?;
            rec.copy_image_rows_to_buffer(image, rows.clone(), &buffers.staging);
            rec.use_buffer(&buffers.staging, Access::HostRead);
            rec.flush_barriers();
            device.wait(rec.submit()?)?;
            let len = row * (rows.end - rows.start) as u64;
            buffers.staging.read_into(len as usize, &mut bytes)?;
        }
        debug_assert_eq!(
            bytes.len() as u64,
            row * h as u64,
            "{} of {w}x{h}",
            image.name()
        );
        out.push((what, bytes));
    }
    Ok(out)
}

/// What besides the read-back buffers goes into a [`Frame`].
pub(crate) struct FrameRecord<'a> {
    pub device: &'a Device,
    /// The image's (not a guard band's wider frame's).
    pub settings: &'a RenderSettings,
    /// The buffers hold the wider frame: crop them.
    pub band: Option<GuardBand>,
    pub view: &'a FrameView,
    pub images: FrameImages<'a>,
    pub cache: &'a SceneCache,
    pub gpu_times: Option<GpuFrameTimes>,
    /// The frame's CPU stages.
    pub spans: Vec<CpuSpan>,
    /// Passes that kept the slot's previous output.
    pub reused: Vec<String>,
    /// When it was submitted (ns, CLOCK_MONOTONIC).
    pub submit_ns: u64,
    /// The slot's estimated device memory, and the slots that hold resources.
    pub memory: (FrameMemory, u32),
}

/// Milliseconds of the CPU stage `name` (0 if it did not run this frame).
fn span_ms(spans: &[CpuSpan], name: &str) -> f64 {
    spans
        .iter()
        .find(|s| s.name == name)
        .map_or(0.0, CpuSpan::ms)
}

/// A read-back layer's texels as RGBA f32: the G-buffer's packed normal
/// and albedo images unpacked as the shaders read them.
fn layer_rgba(layer: Layer, bytes: &[u8]) -> Vec<f32> {
    use crate::passes::gbuffer::{unpack_albedo, unpack_normal};
    let unpack: fn([u32; 2]) -> [f32; 4] = match layer {
        Layer::GBufferNormal | Layer::Layer1Normal => unpack_normal,
        Layer::GBufferAlbedo | Layer::Layer1Albedo => unpack_albedo,
        _ => return bytemuck::pod_collect_to_vec::<u8, f32>(bytes),
    };
    let words = bytemuck::pod_collect_to_vec::<u8, u32>(bytes);
    words
        .chunks_exact(2)
        .flat_map(|w| unpack([w[0], w[1]]))
        .collect()
}

/// Assembles the frame from what was read back (`read_images`).
pub(crate) fn read_frame(read: Vec<(Readback, Vec<u8>)>, record: FrameRecord<'_>) -> Result<Frame> {
    let mut layers = Vec::new();
    let mut samples = Vec::new();
    let mut ism_depth = None;
    let extent = (record.settings.width, record.settings.height);
    let crop = |data: Vec<f32>, channels| match record.band {
        Some(band) => band.crop(&data, channels, extent),
        None => data,
    };
    for (what, bytes) in read {
        match what {
            Readback::Samples(k) => {
                debug_assert_eq!(k as usize, samples.len() + 1);
                samples.push(bytemuck::pod_collect_to_vec::<u8, f32>(&bytes));
            }
            Readback::IsmAtlas => ism_depth = Some(bytemuck::pod_collect_to_vec::<u8, u32>(&bytes)),
            Readback::Layer(layer) => layers.push(LayerImage {
                layer,
                rgba: crop(layer_rgba(layer, &bytes), 4),
            }),
        }
    }
    let image = layers.remove(0);
    // A sum cut short in the band fails the frame too (its receivers are
    // the image's sources' neighbours, not sources).
    check_not_cut_short(&samples, record.settings)?;
    let mut samples: Vec<Vec<f32>> = samples.into_iter().map(|s| crop(s, 1)).collect();
    let FrameRecord {
        device,
        settings,
        band,
        view,
        images,
        cache,
        gpu_times,
        spans,
        reused,
        submit_ns,
        memory,
    } = record;
    let geometry = geometry_of(&mut samples);
    let ssbc_steps = ssbc_figures(&samples, &geometry, &images, view, settings, &gpu_times)?;
    let vpl_set = &cache.vpls().set;
    let bound = view.bound;
    let timings = Timings {
        device: device.name().to_string(),
        width: settings.width,
        height: settings.height,
        guard_band: band.map_or(0, |b| b.margin),
        frame_gpu_ms: gpu_times.as_ref().map(|t| t.frame_ms),
        gpu_start_ns: gpu_times.as_ref().and_then(|t| t.start_monotonic_ns),
        passes: gpu_times.map(|t| t.passes),
        reused_passes: reused,
        stats: None,
        cpu_ms: CpuTimings {
            bvh_build: span_ms(&spans, "bvh_build"),
            vpl_generation: span_ms(&spans, "vpl_generation"),
            point_sampling: span_ms(&spans, "point_sampling"),
            ism_rays: span_ms(&spans, "ism_rays"),
        },
        cpu_spans: spans,
        submit_ns,
        vpl_count: vpl_set.vpls.len(),
        light_paths: vpl_set.paths,
        max_vpls_per_light_path: vpl_set.max_per_path,
        emission_w: crate::cpu::emitters::luminance(vpl_set.emitted_power),
        enclosed_emission_w: crate::cpu::emitters::luminance(vpl_set.enclosed_power),
        device_memory_bytes: device.memory_in_use(),
        memory: MemoryReport {
            estimated: memory.0,
            measured: FrameMemory::measured(device),
            slots: memory.1,
        },
        visibility: match settings.visibility {
            Visibility::Auto => Visibility::Ism,
            v => v,
        },
        ism_back_faces: settings.ism_back_face_maps(),
        ism_tile: settings.ism_tile,
        points_per_vpl: settings.points_per_vpl,
        bound: if bound.is_finite() {
            serde_json::json!(bound)
        } else {
            serde_json::json!("inf")
        },
        integration: settings.ssbc.integration,
        ssbc_steps,
    };
    let ism_readback = ism_depth.map(|texels| IsmReadback::new(images.ism, texels));
    Ok(Frame {
        width: settings.width,
        height: settings.height,
        image,
        layers,
        timings,
        vpls: vpl_set.vpls.clone(),
        bound,
        ism: ism_readback,
        samples,
        accumulated: 1,
    })
}

impl IsmReadback {
    /// The atlas `ism` read back as `texels` (packed distance and normal or
    /// facing, `ism_unpack`).
    fn new(ism: &Ism, texels: Vec<u32>) -> Self {
        let (mut depth, mut facing, mut normal) = (vec![], vec![], vec![]);
        let back_flag = texels.iter().map(|t| t & 0x1000 != 0).collect();
        for (d, f, n) in texels.into_iter().map(ism_unpack) {
            depth.push(d);
            facing.push(f);
            normal.push(n);
        }
        IsmReadback {
            width: ism.atlas.desc.width,
            height: ism.atlas.desc.height,
            tile: ism.tile,
            tiles_per_row: ism.tiles_per_row,
            far: ism.far,
            depth,
            facing,
            normal,
            back_flag,
            point_radius: ism.point_radius,
        }
    }
}

/// An error if a pixel's sample count says its residual sum was cut short
/// by the device's loop limit (see [`CUT_SHORT`]).
/// The pixels with geometry, from the texels read per pixel of each step
/// (the resolve marks those without -1, ssbc_resolve.comp; they become 0).
fn geometry_of(samples: &mut [Vec<f32>]) -> Vec<bool> {
    let geometry = samples
        .first()
        .map(|s| s.iter().map(|&c| c >= 0.0).collect())
        .unwrap_or_default();
    for step in samples {
        step.iter_mut().for_each(|c| *c = c.max(0.0));
    }
    geometry
}

fn check_not_cut_short(samples: &[Vec<f32>], settings: &RenderSettings) -> Result<()> {
    if !samples.iter().flatten().any(|&c| c >= CUT_SHORT as f32) {
        return Ok(());
    }
    Err(Error::InvalidParameter(format!(
        "{}x{}: an SSBC residual sum needed more loop iterations than the device runs in one \
         invocation (lavapipe: 65535) and was cut short; render smaller{}",
        settings.width,
        settings.height,
        match settings.ssbc.integration {
            Integration::Brute => " or with ssbc.integration hierarchical",
            Integration::Hierarchical => "",
        }
    )))
}

/// Per-step SSBC figures from the per-pixel sample counts of each step.
fn ssbc_figures(
    samples: &[Vec<f32>],
    geometry: &[bool],
    images: &FrameImages<'_>,
    view: &FrameView,
    settings: &RenderSettings,
    gpu_times: &Option<GpuFrameTimes>,
) -> Result<Vec<SsbcStepTiming>> {
    let fallback_counts = images.ssbc.fallback_counts()?;
    let eval_level = SsbcPass::eval_level(
        &view.camera,
        view.centre_depth,
        view.bound,
        images.ssbc.levels(),
        &settings.ssbc,
    );
    let steps = samples.iter().enumerate().map(|(k, counts)| {
        let on_geometry: Vec<f32> = counts
            .iter()
            .zip(geometry)
            .filter(|(_, g)| **g)
            .map(|(c, _)| *c)
            .collect();
        let name = format!("ssbc_step_{}", k + 1);
        let pixels = on_geometry.len().max(1) as f64;
        SsbcStepTiming {
            gpu_ms: gpu_times
                .as_ref()
                .and_then(|t| t.passes.iter().find(|p| p.name == name))
                .map(|p| p.gpu_ms),
            samples_per_pixel_avg: on_geometry.iter().map(|&c| c as f64).sum::<f64>() / pixels,
            samples_per_pixel_max: on_geometry.iter().fold(0.0, |m, &c| m.max(c as f64)),
            eval_level,
            fallback_fraction: fallback_counts.get(k).copied().unwrap_or(0) as f64 / pixels,
        }
    });
    Ok(steps.collect())
}

/// Copies `layer` into the host's `output` image (recorded into the host's
/// command buffer).
pub(super) fn hand_off_to_host(
    rec: &mut Recorder<'_>,
    images: &FrameImages<'_>,
    output: &HostImage,
    layer: Layer,
    band: Option<GuardBand>,
) -> Result<()> {
    let source = images
        .layer(layer)
        .ok_or_else(|| Error::InvalidParameter(format!("no layer {layer}")))?;
    let (w, h) = output.extent;
    let out = Image::from_host(
        rec.device,
        output.image,
        output.view,
        crate::vk::ImageDesc::new_2d(output.format, w, h, vk::ImageUsageFlags::TRANSFER_DST),
        output.layout,
    );
    let m = band.map_or(0, |b| b.margin);
    rec.copy_image(source, (m, m), &out, (w, h));
    rec.flush_barriers();
    Ok(())
}
