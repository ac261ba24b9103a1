//! G-buffer: world position, camera-facing shading normal (normal-mapped),
//! linear albedo and emitted radiance per pixel, rasterized at pixel centres.
//! Alpha-masked texels are discarded, one-sided surfaces seen from behind
//! are culled.
//!
//! Layer 1 is a deep G-buffer's second layer (Mara, McGuire,
//! Nowrouzezahrai, Luebke, "Deep G-Buffers for Stable Global Illumination
//! Approximation", HPG 2016) by depth peeling, at full or half resolution
//! ([`crate::settings::LayerResolution`]): per pixel the nearest surface at
//! least a separation farther from the camera than the visible one (layer
//! 0) under it, back faces included. SSBC gathers from its surfaces too:
//! the hidden faces of objects light the visible surfaces around them.

use std::mem::offset_of;
use std::sync::Arc;

use ash::vk;

use super::{Pass, Recording, SlotSetup};
use crate::scene::Vertex;
use crate::error::{Error, Result};
use crate::layer::Layer;
use crate::gpu_scene::{GpuScene, SlotScene};
use crate::shaders::{gbuffer_frag, gbuffer_peel_frag, gbuffer_vert};
use crate::vk::{
    declare_bindings, push_size, AliasRegion, BindingAccess, DescriptorPool, DescriptorSetLayout,
    Device, GraphicsDesc, Image, ImageDesc, Pipeline, Planned, Recorder, RenderTargets, Shader,
    ShaderBindings, ShaderInterface, Tenant,
};

/// Format of the position and emission targets (storage-image compatible).
pub const GBUFFER_FORMAT: vk::Format = vk::Format::R32G32B32A32_SFLOAT;

/// Format of the normal and albedo targets: two words a pixel, four 16-bit
/// normalized values each (`pack_gbuffer_normal` / `pack_gbuffer_albedo`
/// in shaders/include/common.glsl; [`unpack_normal`], [`unpack_albedo`]).
pub const GBUFFER_PACKED_FORMAT: vk::Format = vk::Format::R32G32_UINT;

/// The colour targets' formats, in attachment order.
const TARGET_FORMATS: [vk::Format; 4] = [
    GBUFFER_FORMAT,
    GBUFFER_PACKED_FORMAT,
    GBUFFER_PACKED_FORMAT,
    GBUFFER_FORMAT,
];

/// A packed normal texel's (xyz, roughness) as the shaders read it.
pub fn unpack_normal(words: [u32; 2]) -> [f32; 4] {
    let snorm = |w: u32| (w as u16 as i16 as f32 / 32767.0).max(-1.0);
    let [x, y, z, w] = [words[0], words[0] >> 16, words[1], words[1] >> 16].map(snorm);
    let l = (x * x + y * y + z * z).sqrt();
    let s = if l > 0.0 { 1.0 / l } else { 0.0 };
    [x * s, y * s, z * s, w]
}

/// A packed albedo texel's (rgb, metallic).
pub fn unpack_albedo(words: [u32; 2]) -> [f32; 4] {
    let unorm = |w: u32| (w & 0xFFFF) as f32 / 65535.0;
    [words[0], words[0] >> 16, words[1], words[1] >> 16].map(unorm)
}

/// The G-buffer images of one frame.
pub struct GBuffer {
    /// xyz world position (m), w = 1 where there is geometry, 0 for background.
    pub position: Image,
    /// xyz unit normal facing the camera, w the roughness (-1: Lambertian),
    /// packed ([`GBUFFER_PACKED_FORMAT`]).
    pub normal: Image,
    /// rgb linear albedo, w the metallic, packed ([`GBUFFER_PACKED_FORMAT`]).
    pub albedo: Image,
    /// rgb radiance emitted towards the camera (W/(m² sr)); w < 0: the
    /// geometric normal where a normal map turned `normal`'s
    /// (shaders/include/geometric_normal.glsl), else 1.
    pub emission: Image,
    /// Depth buffer.
    pub depth: Image,
}

impl GBuffer {
    /// What it allocates for `extent`: the four colour targets (position,
    /// normal, albedo, emission), then depth.
    pub fn descs(extent: (u32, u32)) -> [ImageDesc; 5] {
        let color = |format| {
            super::storage_desc(format, extent, vk::ImageUsageFlags::COLOR_ATTACHMENT)
        };
        let [position, normal, albedo, emission] = TARGET_FORMATS.map(color);
        let depth = vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT;
        let depth = ImageDesc::new_2d(vk::Format::D32_SFLOAT, extent.0, extent.1, depth);
        [position, normal, albedo, emission, depth]
    }

    /// Allocates the images for `extent`, named `{prefix}.position` etc.;
    /// in `transient` (a frame slot's transient memory) where given, as
    /// `GBuffer::transient_resources` plans them: the depth buffer,
    /// which only the draw uses, and with `emission_transient` the
    /// emission image.
    pub fn new(
        device: &Arc<Device>,
        prefix: &str,
        extent: (u32, u32),
        mut transient: Option<AliasRegion>,
        emission_transient: bool,
    ) -> Result<Self> {
        let [position, normal, albedo, emission, depth] = Self::descs(extent);
        let mut image = |name: &str, desc, shared: bool| {
            let name = format!("{prefix}.{name}");
            match transient.as_mut().filter(|_| shared) {
                Some(region) => Image::new_aliased(device, &name, desc, region),
                None => Image::new(device, &name, desc),
            }
        };
        // In the order of `transient_resources`.
        let emission = image("emission", emission, emission_transient)?;
        let depth = image("depth", depth, true)?;
        Ok(Self {
            position: image("position", position, false)?,
            normal: image("normal", normal, false)?,
            albedo: image("albedo", albedo, false)?,
            emission,
            depth,
        })
    }

    /// What the G-buffer places in a frame slot's transient memory
    /// (`passes::transient`): with `emission` its emission image, and its
    /// depth buffer.
    pub(crate) fn transient_resources(extent: (u32, u32), emission: bool) -> Tenant {
        let [_, _, _, color, depth] = Self::descs(extent);
        let emission = emission.then_some(Planned::Image(color));
        emission.into_iter().chain([Planned::Image(depth)]).collect()
    }

    /// The three colour targets: position, normal, albedo.
    pub fn targets(&self) -> [&Image; 3] {
        [&self.position, &self.normal, &self.albedo]
    }

    /// Width and height.
    pub fn extent(&self) -> (u32, u32) {
        (self.position.desc.width, self.position.desc.height)
    }

    /// Rasterizes `scene`'s visible objects into the G-buffer with
    /// `pipeline` (bound with `set` and `push`): declares the attachments
    /// and vertex input (the set's bindings are the caller's), begins and
    /// ends rendering.
    pub(crate) fn draw(
        &self,
        rec: &mut Recorder<'_>,
        SlotScene { scene, .. }: SlotScene<'_>,
        pipeline: &Pipeline,
        set: vk::DescriptorSet,
        push: &[u8],
    ) {
        let targets = RenderTargets {
            colors: &[&self.position, &self.normal, &self.albedo, &self.emission],
            depth: &self.depth,
            depth_clear: 0.0,
            vertex_input: &[&scene.vertices, &scene.indices],
        };
        rec.declare_targets(&targets);
        rec.begin_rendering(&targets, None);
        pipeline.bind(rec.cmd, set, push);
        scene.bind_geometry(rec.device, rec.cmd);
        let object_offset = std::mem::offset_of!(Push, object) as u32;
        for masked in [false, true] {
            let draws = scene.draws(masked);
            scene.record_draws(rec.device, rec.cmd, (pipeline, object_offset), draws);
        }
        rec.end_rendering();
    }
}

/// The G-buffer's graphics pipeline description for `fragment`.
pub(crate) fn pipeline_desc(fragment: &Shader) -> GraphicsDesc<'_> {
    GraphicsDesc {
        vertex: &gbuffer_vert::SHADER,
        fragment: Some(fragment),
        vertex_stride: std::mem::size_of::<Vertex>() as u32,
        attributes: &[
            (0, vk::Format::R32G32B32_SFLOAT, offset_of!(Vertex, position)),
            (1, vk::Format::R32G32B32_SFLOAT, offset_of!(Vertex, normal)),
            (2, vk::Format::R32G32_SFLOAT, offset_of!(Vertex, uv)),
            (3, vk::Format::R32_UINT, offset_of!(Vertex, material)),
            (4, vk::Format::R32G32B32A32_SFLOAT, offset_of!(Vertex, tangent)),
            (5, vk::Format::R16G16B16A16_UNORM, offset_of!(Vertex, color)),
        ],
        color_formats: &TARGET_FORMATS,
        depth_format: vk::Format::D32_SFLOAT,
        depth_bias: (0.0, 0.0),
        // Float depth keeps its precision near 0: far from the camera a
        // fixture 1 mm under a ceiling stays in front of it.
        reversed_depth: true,
    }
}

/// A G-buffer pipeline with the fragment shader `F` and its set layout
/// (the union of both stages' bindings), named `name`.
pub(crate) fn raster_pipeline<F: ShaderInterface>(
    device: &Arc<Device>,
    name: &str,
) -> Result<(DescriptorSetLayout, Pipeline)> {
    let stages = [&gbuffer_vert::SHADER, &F::SHADER];
    let layout = DescriptorSetLayout::for_shaders(device, &stages)?;
    let push = push_size::<Push>(&stages)?;
    let pipeline = Pipeline::graphics(device, &pipeline_desc(&F::SHADER), &[&layout], push)?;
    pipeline.name(name);
    layout.name(&format!("{name} set layout"));
    Ok((layout, pipeline))
}

/// The scene's materials and textures as the G-buffer's fragment shader
/// binds them.
fn material_bindings(scene: &GpuScene) -> gbuffer_frag::Bindings<'_> {
    gbuffer_frag::Bindings {
        materials: &scene.materials,
        color_textures: (&scene.color_textures, &scene.texture_sampler),
        linear_textures: (&scene.linear_textures, &scene.texture_sampler),
    }
}

/// The vertex shader's bindings and the fragment shader `F`'s, declared to
/// `rec` with the accesses the shaders make of them.
pub(crate) fn with_objects<'a, F: ShaderInterface>(
    rec: &mut Recorder<'_>,
    objects: &'a crate::vk::Buffer,
    fragment: &F::Bindings<'a>,
) -> Vec<(u32, crate::vk::Binding<'a>)> {
    let mut all = gbuffer_vert::Bindings { objects }.bindings();
    all.extend(fragment.bindings());
    let stages = [&gbuffer_vert::SHADER, &F::SHADER];
    declare_bindings(rec, &stages, &all, BindingAccess::in_graphics);
    all
}

/// Push constants of the G-buffer shaders (the vertex shader's block, of
/// which the fragment shaders declare a prefix): `camera_position.w` is
/// the separation behind layer 0 and `layer1_shift` log2 of a layer-1
/// pixel's side in layer-0 pixels (layer 1 only); `object` is set per draw.
pub(crate) type Push = gbuffer_vert::Push;

/// The G-buffer pipeline of one layer and its descriptor layout.
pub struct GBufferPass {
    layout: DescriptorSetLayout,
    pipeline: Pipeline,
    layer: u32,
}

impl GBufferPass {
    /// Creates the pipeline for layer `layer`: 0 rasterizes the visible
    /// surfaces, 1 peels the surfaces behind them.
    pub fn new(device: &Arc<Device>, layer: u32) -> Result<Self> {
        let name = super::layer_name("gbuffer", layer);
        let (layout, pipeline) = match layer {
            0 => raster_pipeline::<gbuffer_frag::Interface>(device, &name)?,
            _ => raster_pipeline::<gbuffer_peel_frag::Interface>(device, &name)?,
        };
        Ok(Self {
            layout,
            pipeline,
            layer,
        })
    }
}

impl Pass for GBufferPass {
    const NAME: &'static str = "gbuffer";
    fn layer(&self) -> u32 {
        self.layer
    }
    /// Width and height.
    type Key = (u32, u32);
    type Resources = GBuffer;
    /// The scene and, on layer 1, layer 0 (the surfaces to peel behind).
    type Reads<'a> = (SlotScene<'a>, Option<&'a GBuffer>);

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.layer_extent(self.layer)
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<GBuffer> {
        let name = super::layer_name("gbuffer", self.layer);
        let transient = setup.region(super::transient::Tenancy::GBuffer(self.layer));
        let emission = transient.is_some()
            && super::transient::emission_is_transient(setup.settings);
        GBuffer::new(setup.device, &name, setup.layer_extent(self.layer), transient, emission)
    }

    /// (The emission image only where it outlives the gathers, not in the
    /// slot's transient memory.)
    fn layers<'r>(&self, g: &'r GBuffer) -> Vec<(Layer, &'r Image)> {
        if self.layer() == 0 {
            let mut layers = vec![
                (Layer::GBufferPosition, &g.position),
                (Layer::GBufferNormal, &g.normal),
                (Layer::GBufferAlbedo, &g.albedo),
            ];
            if g.emission.shared.is_none() {
                layers.push((Layer::GBufferEmission, &g.emission));
            }
            layers
        } else {
            vec![
                (Layer::Layer1Position, &g.position),
                (Layer::Layer1Normal, &g.normal),
                (Layer::Layer1Albedo, &g.albedo),
            ]
        }
    }

    fn set_layouts(&self, _: &GBuffer) -> Vec<&DescriptorSetLayout> {
        vec![&self.layout]
    }

    /// Rasterizes the scene from the frame's camera (on layer 1 keeping
    /// only what lies a separation behind layer 0).
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (scene, front): (SlotScene<'_>, Option<&GBuffer>),
        gbuffer: &GBuffer,
    ) -> Result<()> {
        let Recording {
            rec,
            profiler,
            view,
            settings,
            ..
        } = cx;
        let materials = material_bindings(scene.scene);
        let (set, push) = match (self.layer, front) {
            (0, _) => {
                let all = with_objects::<gbuffer_frag::Interface>(rec, scene.objects, &materials);
                let set = pool.allocate(&self.layout, &all)?;
                (set, view.camera.position.extend(1.0))
            }
            (_, Some(front)) => {
                let bindings = gbuffer_peel_frag::Bindings {
                    materials: materials.materials,
                    color_textures: materials.color_textures,
                    linear_textures: materials.linear_textures,
                    layer0_position: &front.position,
                };
                let all =
                    with_objects::<gbuffer_peel_frag::Interface>(rec, scene.objects, &bindings);
                let set = pool.allocate(&self.layout, &all)?;
                let separation = settings.ssbc.layer_separation * view.diagonal;
                (set, view.camera.position.extend(separation))
            }
            (layer, None) => {
                return Err(Error::InvalidParameter(format!(
                    "G-buffer layer {layer} needs the layer in front of it"
                )))
            }
        };
        let name = super::layer_name("gbuffer", self.layer);
        let scope = profiler.begin(rec.cmd, &name);
        let push = Push {
            view_proj: view.view_proj.to_cols_array_2d(),
            camera_position: push.into(),
            layer1_shift: match self.layer {
                0 => 0,
                _ => settings.ssbc.layer1_resolution.shift(),
            },
            object: 0,
        };
        gbuffer.draw(rec, scene, &self.pipeline, set, bytemuck::bytes_of(&push));
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
