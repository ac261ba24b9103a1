//! Shadow maps for direct light: six 90° perspective faces for a point light,
//! one perspective map for a spot light, one orthographic map fitted to the
//! scene for a directional light. All layers live in one depth array image.
//! Alpha-masked texels cast no shadow (the fragment shader discards them).

use std::mem::offset_of;
use std::sync::Arc;

use ash::vk;
use glam::{Mat4, Vec3, Vec4};

use crate::scene::Vertex;
use crate::error::Result;
use crate::gpu_scene::SlotScene;
use crate::gpu_types::{GpuLight, ShadowView};
use crate::scene::{Bounds, Light, LightKind};
use crate::shaders::{shadow_map_frag, shadow_map_vert};
use crate::vk::{
    declare_bindings, push_size, BindingAccess, Buffer, DescriptorPool, RenderTargets,
    DescriptorSetLayout, Device, GraphicsDesc, Image, ImageDesc, Pipeline, ShaderBindings,
};

use super::{Pass, Recording, SlotSetup};

/// Each light's entry (with its range of layers) and every layer's view.
fn light_table(
    lights: &[Light],
    bounds: &Bounds,
    resolution: u32,
) -> (Vec<GpuLight>, Vec<(Mat4, Vec4)>) {
    let mut gpu_lights = Vec::new();
    let mut views = Vec::new();
    for light in lights {
        let lv = light_views(light, bounds, resolution);
        gpu_lights.push(GpuLight::new(light, views.len() as u32, lv.len() as u32));
        views.extend(lv);
    }
    (gpu_lights, views)
}

/// The depth pipeline (created once) and its descriptor layout (materials
/// and colour textures, for alpha masks).
pub struct ShadowMapPass {
    layout: DescriptorSetLayout,
    /// Alpha-masked triangles: a fragment shader discards cut-out texels.
    pipeline: Pipeline,
    /// Opaque triangles: depth only, no fragment shader.
    depth_only: Pipeline,
}

/// One frame's shadow maps and the light table that points into them.
pub struct ShadowMaps {
    /// Depth array: one layer per view.
    pub depth: Image,
    /// `ShadowView` per layer.
    pub views: Buffer,
    /// `GpuLight` per light (with its layer range).
    pub lights: Buffer,
    /// Number of lights.
    pub light_count: u32,
    view_proj: Vec<Mat4>,
}

/// A unit vector orthogonal to `d`, for look-at matrices.
fn any_up(d: Vec3) -> Vec3 {
    if d.y.abs() > 0.99 {
        Vec3::Z
    } else {
        Vec3::Y
    }
}

use glam::camera::rh::proj::vulkan;
use glam::camera::rh::view::look_to_mat4;

fn vulkan_perspective(fov: f32, near: f32, far: f32) -> Mat4 {
    vulkan::perspective(fov, 1.0, near, far)
}

/// The shadow views of one light: (view-projection, params) per layer.
pub fn light_views(light: &Light, bounds: &Bounds, resolution: u32) -> Vec<(Mat4, Vec4)> {
    let radius = bounds.radius().max(1e-3);
    let res = resolution as f32;
    match light.kind {
        LightKind::Point | LightKind::Spot { .. } => {
            let far = (light.position - bounds.center()).length() + radius * 1.01;
            let near = (far * 1e-4).max(1e-4);
            if let LightKind::Spot { outer_cone, .. } = light.kind {
                let fov = (2.0 * outer_cone + 0.05).min(170f32.to_radians());
                let view = look_to_mat4(light.position, light.direction, any_up(light.direction));
                let params = Vec4::new(near, far, 0.0, 2.0 * (fov * 0.5).tan() / res);
                return vec![(vulkan_perspective(fov, near, far) * view, params)];
            }
            let faces = [
                (Vec3::X, -Vec3::Y),
                (-Vec3::X, -Vec3::Y),
                (Vec3::Y, Vec3::Z),
                (-Vec3::Y, -Vec3::Z),
                (Vec3::Z, -Vec3::Y),
                (-Vec3::Z, -Vec3::Y),
            ];
            let proj = vulkan_perspective(std::f32::consts::FRAC_PI_2, near, far);
            let params = Vec4::new(near, far, 0.0, 2.0 / res);
            faces
                .iter()
                .map(|&(dir, up)| (proj * look_to_mat4(light.position, dir, up), params))
                .collect()
        }
        LightKind::Directional => {
            let eye = bounds.center() - light.direction * (2.0 * radius);
            let view = look_to_mat4(eye, light.direction, any_up(light.direction));
            let (near, far) = (0.9 * radius, 3.1 * radius);
            let proj = vulkan::orthographic(-radius, radius, -radius, radius, near, far);
            vec![(proj * view, Vec4::new(near, far, 1.0, 2.0 * radius / res))]
        }
    }
}

/// Push constants of the shadow-map shaders: world to the layer's clip
/// space, and the object drawn (set per draw).
type ShadowPush = shadow_map_vert::Push;

/// The shadow maps' depth array: `views` layers of `resolution` texels a
/// side (a cube's six per light).
pub(crate) fn depth_desc(resolution: u32, views: u32) -> ImageDesc {
    ImageDesc {
        format: vk::Format::D32_SFLOAT,
        width: resolution,
        height: resolution,
        layers: views,
        mip_levels: 1,
        usage: vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
        array: true,
    }
}

impl ShadowMapPass {
    /// Creates the depth pipeline.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        let stages = [&shadow_map_vert::SHADER, &shadow_map_frag::SHADER];
        let layout = DescriptorSetLayout::for_shaders(device, &stages)?;
        let push = push_size::<ShadowPush>(&stages)?;
        // The same depth pipeline with and without the alpha test.
        let depth = |fragment, name| -> Result<Pipeline> {
            let pipeline = Pipeline::graphics(
                device,
                &GraphicsDesc {
                    vertex: &shadow_map_vert::SHADER,
                    fragment,
                    vertex_stride: std::mem::size_of::<Vertex>() as u32,
                    attributes: &[
                        (0, vk::Format::R32G32B32_SFLOAT, offset_of!(Vertex, position)),
                        (2, vk::Format::R32G32_SFLOAT, offset_of!(Vertex, uv)),
                        (3, vk::Format::R32_UINT, offset_of!(Vertex, material)),
                        (5, vk::Format::R16G16B16A16_UNORM, offset_of!(Vertex, color)),
                    ],
                    color_formats: &[],
                    depth_format: vk::Format::D32_SFLOAT,
                    depth_bias: (0.0, 0.0),
                    reversed_depth: false,
                },
                &[&layout],
                push,
            )?;
            pipeline.name(name);
            Ok(pipeline)
        };
        let pipeline = depth(Some(&shadow_map_frag::SHADER), "shadow_maps masked")?;
        let depth_only = depth(None, "shadow_maps opaque")?;
        layout.name("shadow_maps set layout");
        Ok(Self {
            layout,
            pipeline,
            depth_only,
        })
    }
}

impl Pass for ShadowMapPass {
    const NAME: &'static str = "shadow_maps";
    /// The depth layers depend on the lights, the surfaces and the resolution.
    const VIEW_INDEPENDENT: bool = true;
    /// The (lights, geometry, objects, materials: alpha masks cut them)
    /// versions the views were made for, and the resolution.
    type Key = (u64, u64, u64, u64, u32);
    /// Depth layers and the light table.
    type Resources = ShadowMaps;
    type Reads<'a> = SlotScene<'a>;

    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key {
        let versions = &setup.cache.versions;
        let resolution = setup.settings.shadow_map_size;
        (
            versions.lights,
            versions.geometry,
            versions.objects,
            versions.materials,
            resolution,
        )
    }

    /// Allocates the shadow maps of the lights at the resolution asked for.
    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<ShadowMaps> {
        let (device, resolution) = (setup.device, setup.settings.shadow_map_size);
        let (gpu_lights, views) = light_table(&setup.scene.lights, &setup.cache.bounds, resolution);
        let layers = views.len().max(1) as u32;
        let desc = depth_desc(resolution, layers);
        let depth = match setup.region(super::transient::Tenancy::ShadowMaps) {
            Some(mut region) => Image::new_aliased(device, "shadow_maps.depth", desc, &mut region)?,
            None => Image::new(device, "shadow_maps.depth", desc)?,
        };
        let packed: Vec<ShadowView> = views.iter().map(|&(m, p)| ShadowView::new(m, p)).collect();
        let packed = if packed.is_empty() {
            vec![ShadowView::default()]
        } else {
            packed
        };
        let gpu_lights_buf = if gpu_lights.is_empty() {
            vec![GpuLight::default()]
        } else {
            gpu_lights.clone()
        };
        Ok(ShadowMaps {
            depth,
            views: Buffer::with_data(
                device,
                "shadow_maps.views",
                &packed,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            lights: Buffer::with_data(
                device,
                "scene.lights",
                &gpu_lights_buf,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            light_count: setup.scene.lights.len() as u32,
            view_proj: views.iter().map(|v| v.0).collect(),
        })
    }

    /// Rewrites the views and lights in place when they fit the layers.
    fn update(&self, maps: &mut ShadowMaps, setup: &SlotSetup<'_>) -> Result<bool> {
        let (lights, resolution) = (&setup.scene.lights, setup.settings.shadow_map_size);
        let (gpu_lights, views) = light_table(lights, &setup.cache.bounds, resolution);
        if views.len().max(1) as u32 != maps.depth.desc.layers
            || resolution != maps.depth.desc.width
            || lights.len().max(1) * std::mem::size_of::<GpuLight>() != maps.lights.size as usize
        {
            return Ok(false);
        }
        let packed: Vec<ShadowView> = views.iter().map(|&(m, p)| ShadowView::new(m, p)).collect();
        if !packed.is_empty() {
            maps.views.write(0, bytemuck::cast_slice(&packed))?;
        }
        if !gpu_lights.is_empty() {
            maps.lights.write(0, bytemuck::cast_slice(&gpu_lights))?;
        }
        maps.light_count = lights.len() as u32;
        maps.view_proj = views.iter().map(|v| v.0).collect();
        Ok(true)
    }

    fn set_layouts(&self, _: &ShadowMaps) -> Vec<&DescriptorSetLayout> {
        vec![&self.layout]
    }

    /// Renders every layer.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        SlotScene { scene, objects, .. }: SlotScene<'_>,
        maps: &ShadowMaps,
    ) -> Result<()> {
        let Recording { rec, profiler, .. } = cx;
        let bindings = shadow_map_frag::Bindings {
            materials: &scene.materials,
            color_textures: (&scene.color_textures, &scene.texture_sampler),
        };
        let mut all = shadow_map_vert::Bindings { objects }.bindings();
        all.extend(bindings.bindings());
        let set = pool.allocate(&self.layout, &all)?;
        let scope = profiler.begin(rec.cmd, "shadow_maps");
        let stages = [&shadow_map_vert::SHADER, &shadow_map_frag::SHADER];
        declare_bindings(rec, &stages, &all, BindingAccess::in_graphics);
        let targets = RenderTargets {
            colors: &[],
            depth: &maps.depth,
            depth_clear: 1.0,
            vertex_input: &[&scene.vertices, &scene.indices],
        };
        rec.declare_targets(&targets);
        for (layer, view_proj) in maps.view_proj.iter().enumerate() {
            rec.begin_rendering(&targets, Some(maps.depth.layer_views[layer]));
            let push = ShadowPush {
                view_proj: view_proj.to_cols_array_2d(),
                ..Default::default()
            };
            let object_offset = std::mem::offset_of!(ShadowPush, object) as u32;
            // Opaque triangles depth-only, alpha-masked ones with the test.
            let parts = [(&self.depth_only, false), (&self.pipeline, true)];
            for (pipeline, masked) in parts {
                let draws = scene.draws(masked);
                if draws.is_empty() {
                    continue;
                }
                pipeline.bind(rec.cmd, set, bytemuck::bytes_of(&push));
                scene.bind_geometry(rec.device, rec.cmd);
                scene.record_draws(rec.device, rec.cmd, (pipeline, object_offset), draws);
            }
            rec.end_rendering();
        }
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
