//! Shader modules, pipeline layouts, compute and graphics pipelines.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;

use super::descriptor::{Binding, DescriptorPool, DescriptorSetLayout};
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// A shader as `build.rs` compiled and reflected it
/// (`crate::shaders::<file>::SHADER`).
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Its file in `shaders/`.
    pub name: &'static str,
    /// SPIR-V (entry point `main`).
    pub spirv: &'static [u8],
    /// Its descriptor bindings in set 0: number, type, name in the GLSL
    /// (those the optimised SPIR-V still uses).
    pub bindings: &'static [(u32, vk::DescriptorType, &'static str)],
    /// Bytes of its push-constant block (0: none).
    pub push_bytes: u32,
}

/// The resources for a shader's bindings: `build.rs` generates one struct
/// per shader (`crate::shaders::<file>::Bindings`) with a field per binding,
/// named and typed from the SPIR-V, so that a binding missing, extra or of
/// another kind does not compile.
pub trait ShaderBindings<'a> {
    /// Every binding with its number.
    fn bindings(&self) -> Vec<(u32, Binding<'a>)>;
}

/// A shader as a type (`crate::shaders::<file>::Interface`): what kernels
/// and pipelines are made of, tying the shader to its bindings.
pub trait ShaderInterface {
    /// The shader.
    const SHADER: Shader;
    /// Its bindings.
    type Bindings<'a>: ShaderBindings<'a>;
}

/// The size of the push block `P`, which the stages `shaders` share (each
/// declares it, or a prefix of it, or none); an error names the shader if
/// `P` is not the size of the largest.
pub fn push_size<P>(shaders: &[&Shader]) -> Result<u32> {
    let size = std::mem::size_of::<P>();
    let declared = shaders.iter().max_by_key(|s| s.push_bytes);
    match declared {
        Some(s) if s.push_bytes as usize != size => Err(Error::InvalidParameter(format!(
            "internal: shaders/{} has a {}-byte push block, the Rust side {size} bytes",
            s.name, s.push_bytes
        ))),
        _ => Ok(size as u32),
    }
}

fn shader_module(device: &Device, spirv: &[u8]) -> Result<vk::ShaderModule> {
    // Embedded SPIR-V comes from build.rs; a failure here is a build bug.
    let code =
        ash::util::read_spv(&mut std::io::Cursor::new(spirv)).map_err(|_| Error::Vulkan {
            call: "read_spv (embedded SPIR-V is malformed)",
            result: vk::Result::ERROR_INITIALIZATION_FAILED,
        })?;
    let info = vk::ShaderModuleCreateInfo::default().code(&code);
    // SAFETY: SPIR-V produced by build.rs from our own shaders.
    unsafe { device.raw.create_shader_module(&info, None) }.vk("vkCreateShaderModule")
}

/// A pipeline and its layout (one descriptor set, optional push constants).
pub struct Pipeline {
    device: Arc<Device>,
    /// The raw pipeline.
    pub raw: vk::Pipeline,
    /// Its layout.
    pub layout: vk::PipelineLayout,
    /// Bind point (compute or graphics).
    pub bind_point: vk::PipelineBindPoint,
    push_stages: vk::ShaderStageFlags,
}

fn pipeline_layout(
    device: &Device,
    set_layouts: &[&DescriptorSetLayout],
    push_size: u32,
    stages: vk::ShaderStageFlags,
) -> Result<vk::PipelineLayout> {
    let raw_layouts: Vec<_> = set_layouts.iter().map(|l| l.raw).collect();
    let ranges = [vk::PushConstantRange {
        stage_flags: stages,
        offset: 0,
        size: push_size,
    }];
    let info = vk::PipelineLayoutCreateInfo::default()
        .set_layouts(&raw_layouts)
        .push_constant_ranges(if push_size > 0 { &ranges[..] } else { &[] });
    // SAFETY: valid create info.
    unsafe { device.raw.create_pipeline_layout(&info, None) }.vk("vkCreatePipelineLayout")
}

/// Fixed-function state of a graphics pipeline (dynamic rendering).
pub struct GraphicsDesc<'a> {
    /// Vertex shader.
    pub vertex: &'a Shader,
    /// Fragment shader (None: depth-only).
    pub fragment: Option<&'a Shader>,
    /// Vertex stride in bytes.
    pub vertex_stride: u32,
    /// Vertex attributes (location, format, byte offset in the vertex).
    pub attributes: &'a [(u32, vk::Format, usize)],
    /// Colour attachment formats.
    pub color_formats: &'a [vk::Format],
    /// Depth attachment format.
    pub depth_format: vk::Format,
    /// Constant depth bias and slope factor (0, 0 for none).
    pub depth_bias: (f32, f32),
    /// Depth runs from 1 at the near plane to 0 at the far plane (reversed
    /// Z: the nearer fragment is the greater; clear depth to 0).
    pub reversed_depth: bool,
}

/// The vertex and (optional) fragment modules of `desc`; none is left
/// behind on failure.
fn graphics_modules(
    device: &Device,
    desc: &GraphicsDesc<'_>,
) -> Result<(vk::ShaderModule, Option<vk::ShaderModule>)> {
    let vert = shader_module(device, desc.vertex.spirv)?;
    match desc
        .fragment
        .map(|f| shader_module(device, f.spirv))
        .transpose()
    {
        Ok(frag) => Ok((vert, frag)),
        Err(e) => {
            // SAFETY: the module is unused.
            unsafe { device.raw.destroy_shader_module(vert, None) };
            Err(e)
        }
    }
}

/// One interleaved vertex buffer (binding 0) with `desc`'s attributes.
fn vertex_layout(
    desc: &GraphicsDesc<'_>,
) -> (
    [vk::VertexInputBindingDescription; 1],
    Vec<vk::VertexInputAttributeDescription>,
) {
    let binding = vk::VertexInputBindingDescription {
        binding: 0,
        stride: desc.vertex_stride,
        input_rate: vk::VertexInputRate::VERTEX,
    };
    let attributes = desc.attributes.iter();
    let attributes =
        attributes.map(
            |&(location, format, offset)| vk::VertexInputAttributeDescription {
                location,
                binding: 0,
                format,
                offset: offset as u32,
            },
        );
    ([binding], attributes.collect())
}

impl Pipeline {
    /// A compute pipeline from SPIR-V with entry `main`.
    pub fn compute(
        device: &Arc<Device>,
        spirv: &[u8],
        set_layouts: &[&DescriptorSetLayout],
        push_size: u32,
    ) -> Result<Self> {
        let stages = vk::ShaderStageFlags::COMPUTE;
        let layout = pipeline_layout(device, set_layouts, push_size, stages)?;
        let module = match shader_module(device, spirv) {
            Ok(m) => m,
            Err(e) => {
                device.defer_destroy(Garbage::PipelineLayout(layout));
                return Err(e);
            }
        };
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main");
        let info = vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout);
        // SAFETY: module and layout are valid; the module may be destroyed
        // right after pipeline creation.
        let result = unsafe {
            let r = device
                .raw
                .create_compute_pipelines(vk::PipelineCache::null(), &[info], None);
            device.raw.destroy_shader_module(module, None);
            r
        };
        let raw = match result {
            Ok(p) => p[0],
            Err((_, result)) => {
                device.defer_destroy(Garbage::PipelineLayout(layout));
                return Err(Error::Vulkan {
                    call: "vkCreateComputePipelines",
                    result,
                });
            }
        };
        Ok(Self {
            device: device.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::COMPUTE,
            push_stages: stages,
        })
    }

    /// A triangle-list graphics pipeline for dynamic rendering, no culling,
    /// depth test LESS with writes, dynamic viewport and scissor.
    pub fn graphics(
        device: &Arc<Device>,
        desc: &GraphicsDesc<'_>,
        set_layouts: &[&DescriptorSetLayout],
        push_size: u32,
    ) -> Result<Self> {
        let stages = vk::ShaderStageFlags::VERTEX | vk::ShaderStageFlags::FRAGMENT;
        let layout = pipeline_layout(device, set_layouts, push_size, stages)?;
        let (vert, frag) = match graphics_modules(device, desc) {
            Ok(modules) => modules,
            Err(e) => {
                device.defer_destroy(Garbage::PipelineLayout(layout));
                return Err(e);
            }
        };
        let mut shader_stages = vec![vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(vert)
            .name(c"main")];
        if let Some(f) = frag {
            shader_stages.push(
                vk::PipelineShaderStageCreateInfo::default()
                    .stage(vk::ShaderStageFlags::FRAGMENT)
                    .module(f)
                    .name(c"main"),
            );
        }
        let (vb, attrs) = vertex_layout(desc);
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&vb)
            .vertex_attribute_descriptions(&attrs);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewport_count(1)
            .scissor_count(1);
        let raster = vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .depth_bias_enable(desc.depth_bias != (0.0, 0.0))
            .depth_bias_constant_factor(desc.depth_bias.0)
            .depth_bias_slope_factor(desc.depth_bias.1)
            .line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(if desc.reversed_depth {
                vk::CompareOp::GREATER
            } else {
                vk::CompareOp::LESS
            });
        let blend_attachments: Vec<_> = desc
            .color_formats
            .iter()
            .map(|_| {
                vk::PipelineColorBlendAttachmentState::default()
                    .color_write_mask(vk::ColorComponentFlags::RGBA)
            })
            .collect();
        let blend =
            vk::PipelineColorBlendStateCreateInfo::default().attachments(&blend_attachments);
        let dynamic_states = [vk::DynamicState::VIEWPORT, vk::DynamicState::SCISSOR];
        let dynamic = vk::PipelineDynamicStateCreateInfo::default().dynamic_states(&dynamic_states);
        let mut rendering = vk::PipelineRenderingCreateInfo::default()
            .color_attachment_formats(desc.color_formats)
            .depth_attachment_format(desc.depth_format);
        let info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&shader_stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth)
            .color_blend_state(&blend)
            .dynamic_state(&dynamic)
            .layout(layout)
            .push_next(&mut rendering);
        // SAFETY: every referenced state struct lives until the call returns;
        // modules are destroyed after creation.
        let result = unsafe {
            let r = device
                .raw
                .create_graphics_pipelines(vk::PipelineCache::null(), &[info], None);
            device.raw.destroy_shader_module(vert, None);
            if let Some(f) = frag {
                device.raw.destroy_shader_module(f, None);
            }
            r
        };
        let raw = match result {
            Ok(p) => p[0],
            Err((_, result)) => {
                device.defer_destroy(Garbage::PipelineLayout(layout));
                return Err(Error::Vulkan {
                    call: "vkCreateGraphicsPipelines",
                    result,
                });
            }
        };
        Ok(Self {
            device: device.clone(),
            raw,
            layout,
            bind_point: vk::PipelineBindPoint::GRAPHICS,
            push_stages: stages,
        })
    }

    /// Binds the pipeline and its descriptor set, and pushes `push` constants.
    pub fn bind(&self, cmd: vk::CommandBuffer, set: vk::DescriptorSet, push: &[u8]) {
        // SAFETY: recording; the set matches the layout this pipeline was made with.
        unsafe {
            self.device
                .raw
                .cmd_bind_pipeline(cmd, self.bind_point, self.raw);
            self.device.raw.cmd_bind_descriptor_sets(
                cmd,
                self.bind_point,
                self.layout,
                0,
                &[set],
                &[],
            );
        }
        self.push(cmd, push);
    }

    /// Names the pipeline `<name> pipeline` and its layout.
    pub fn name(&self, name: &str) {
        self.device.set_name(self.raw, &format!("{name} pipeline"));
        self.device
            .set_name(self.layout, &format!("{name} pipeline layout"));
    }

    /// Pushes constants (no-op for an empty slice).
    pub fn push(&self, cmd: vk::CommandBuffer, push: &[u8]) {
        self.push_at(cmd, 0, push);
    }

    /// Pushes `bytes` at `offset` into the push block (one field between
    /// draws; no-op for an empty slice).
    pub fn push_at(&self, cmd: vk::CommandBuffer, offset: u32, bytes: &[u8]) {
        if bytes.is_empty() {
            return;
        }
        // SAFETY: recording; the range lies in the one declared at layout
        // creation (the caller's offset is a field of its push block).
        unsafe {
            self.device
                .raw
                .cmd_push_constants(cmd, self.layout, self.push_stages, offset, bytes)
        };
    }
}

impl Drop for Pipeline {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::Pipeline(self.raw));
        self.device
            .defer_destroy(Garbage::PipelineLayout(self.layout));
    }
}

/// A compute shader with the one descriptor set layout it uses, made from
/// its reflection: the unit most passes are made of. `I` is the shader
/// (its bindings come with it), `P` its push block (`()` for none).
pub struct ComputeKernel<I: ShaderInterface, P: bytemuck::Pod = ()> {
    layout: DescriptorSetLayout,
    pipeline: Pipeline,
    shader: PhantomData<fn(&P) -> I>,
}

impl<I: ShaderInterface, P: bytemuck::Pod> ComputeKernel<I, P> {
    /// Creates the layout (from the shader's bindings) and the pipeline;
    /// fails if `P` is not the size of the shader's push block.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        let shader = I::SHADER;
        let push_size = push_size::<P>(&[&shader])?;
        let layout = DescriptorSetLayout::for_shaders(device, &[&shader])?;
        let pipeline = Pipeline::compute(device, shader.spirv, &[&layout], push_size)?;
        Ok(Self {
            layout,
            pipeline,
            shader: PhantomData,
        })
    }

    /// Names the pipeline `<name> pipeline`, its layout and its descriptor
    /// set layout (see [`Device::set_name`]).
    pub fn named(self, name: &str) -> Self {
        self.layout.name(&format!("{name} set layout"));
        self.pipeline.name(name);
        self
    }

    /// The descriptor set layout (for sizing a frame's pool).
    pub fn set_layout(&self) -> &DescriptorSetLayout {
        &self.layout
    }

    /// Writes a set for `bindings`, binds it with the pipeline, pushes `push`
    /// and dispatches `groups`. Barriers must already be flushed.
    pub fn dispatch(
        &self,
        cmd: vk::CommandBuffer,
        pool: &DescriptorPool,
        bindings: &I::Bindings<'_>,
        push: &P,
        groups: [u32; 3],
    ) -> Result<()> {
        self.bind(cmd, pool, bindings, push)?;
        // SAFETY: recording with this compute pipeline and its set bound.
        unsafe {
            self.pipeline
                .device
                .raw
                .cmd_dispatch(cmd, groups[0], groups[1], groups[2])
        };
        Ok(())
    }

    /// Like [`ComputeKernel::dispatch`], with the group counts read by the GPU
    /// from `args` at `offset` (a `VkDispatchIndirectCommand`). The caller
    /// declares `args` as [`crate::vk::Access::IndirectRead`].
    pub fn dispatch_indirect(
        &self,
        cmd: vk::CommandBuffer,
        pool: &DescriptorPool,
        bindings: &I::Bindings<'_>,
        push: &P,
        args: &crate::vk::Buffer,
        offset: u64,
    ) -> Result<()> {
        self.bind(cmd, pool, bindings, push)?;
        // SAFETY: recording with this compute pipeline and its set bound;
        // `args` holds a dispatch command at `offset` (usage INDIRECT_BUFFER).
        unsafe {
            self.pipeline
                .device
                .raw
                .cmd_dispatch_indirect(cmd, args.raw, offset)
        };
        Ok(())
    }

    /// [`ComputeKernel::dispatch`] over `extent` with 8x8 work groups.
    pub fn dispatch_2d(
        &self,
        cmd: vk::CommandBuffer,
        pool: &DescriptorPool,
        bindings: &I::Bindings<'_>,
        push: &P,
        extent: (u32, u32),
    ) -> Result<()> {
        let groups = [extent.0.div_ceil(8), extent.1.div_ceil(8), 1];
        self.dispatch(cmd, pool, bindings, push, groups)
    }

    fn bind(
        &self,
        cmd: vk::CommandBuffer,
        pool: &DescriptorPool,
        bindings: &I::Bindings<'_>,
        push: &P,
    ) -> Result<()> {
        use super::pipeline::ShaderBindings as _;
        let set = pool.allocate(&self.layout, &bindings.bindings())?;
        self.pipeline.bind(cmd, set, bytemuck::bytes_of(push));
        Ok(())
    }
}
