//! Shader modules, pipeline layouts, compute and graphics pipelines.

use std::marker::PhantomData;
use std::sync::Arc;

use ash::vk;

use super::barrier::Access;
use super::shader::{shader_module, BindingAccess, Shader};
use super::buffer::Buffer;
use super::commands::Recorder;
use super::descriptor::{Binding, DescriptorPool, DescriptorSetLayout, Tracked};
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// The resources for a shader's bindings: `build.rs` generates one struct
/// per shader (`crate::shaders::<file>::Bindings`) with a field per binding,
/// named and typed from the SPIR-V, so that a binding missing, extra or of
/// another kind does not compile.
pub trait ShaderBindings<'a> {
    /// Every binding with its number.
    fn bindings(&self) -> Vec<(u32, Binding<'a>)>;
}

/// A shader as a type (`crate::shaders::<file>::Interface`): what kernels
/// and pipelines are made of, tying the shader to its bindings and its
/// push block.
pub trait ShaderInterface {
    /// The shader.
    const SHADER: Shader;
    /// Its bindings.
    type Bindings<'a>: ShaderBindings<'a>;
    /// Its push block (`()` for none), generated from the SPIR-V.
    type Push: bytemuck::Pod;
}

/// Declares to `rec` every resource of `bindings` with the access the
/// `stages` that bind it make of it (`access` maps it to the pipeline's
/// stage), for the barriers before the next command. A resource bound twice
/// is declared once, written if either binding writes it.
pub fn declare_bindings(
    rec: &mut Recorder<'_>,
    stages: &[&Shader],
    bindings: &[(u32, Binding<'_>)],
    access: fn(BindingAccess) -> Access,
) {
    let access_of = |number: u32| {
        let info = stages
            .iter()
            .flat_map(|s| s.bindings)
            .find(|b| b.number == number);
        access(info.map_or(BindingAccess::ReadWrite, |b| b.access))
    };
    let mut uses: Vec<(Tracked<'_>, Access)> = Vec::with_capacity(bindings.len());
    for &(number, binding) in bindings {
        let (resource, access) = (binding.tracked(), access_of(number));
        match uses.iter_mut().find(|(r, _)| r.same(&resource)) {
            Some((_, a)) if access.info().writes => *a = access,
            Some(_) => {}
            None => uses.push((resource, access)),
        }
    }
    for (resource, access) in uses {
        match resource {
            Tracked::Image(image) => rec.use_image(image, access),
            Tracked::Buffer(buffer) => rec.use_buffer(buffer, access),
        }
    }
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

impl GraphicsDesc<'_> {
    /// Filled triangles, both faces, with the depth bias asked for.
    fn rasterization(&self) -> vk::PipelineRasterizationStateCreateInfo<'static> {
        vk::PipelineRasterizationStateCreateInfo::default()
            .polygon_mode(vk::PolygonMode::FILL)
            .cull_mode(vk::CullModeFlags::NONE)
            .front_face(vk::FrontFace::COUNTER_CLOCKWISE)
            .depth_bias_enable(self.depth_bias != (0.0, 0.0))
            .depth_bias_constant_factor(self.depth_bias.0)
            .depth_bias_slope_factor(self.depth_bias.1)
            .line_width(1.0)
    }

    /// Depth tested and written, nearer passing (greater when reversed).
    fn depth_stencil(&self) -> vk::PipelineDepthStencilStateCreateInfo<'static> {
        let compare = if self.reversed_depth {
            vk::CompareOp::GREATER
        } else {
            vk::CompareOp::LESS
        };
        vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(compare)
    }
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
        Self::compute_specialized(device, spirv, set_layouts, push_size, &[])
    }

    /// [`Pipeline::compute`] with the shader's specialization constants
    /// (`layout(constant_id = id)`, 32-bit scalars; a `bool` is 0 or 1)
    /// set to `constants` as `(id, value)`.
    pub fn compute_specialized(
        device: &Arc<Device>,
        spirv: &[u8],
        set_layouts: &[&DescriptorSetLayout],
        push_size: u32,
        constants: &[(u32, u32)],
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
        let entries: Vec<vk::SpecializationMapEntry> = (constants.iter().zip(0u32..))
            .map(|(&(constant_id, _), i)| vk::SpecializationMapEntry {
                constant_id,
                offset: 4 * i,
                size: 4,
            })
            .collect();
        let data: Vec<u8> = constants.iter().flat_map(|c| c.1.to_ne_bytes()).collect();
        let specialization = vk::SpecializationInfo::default()
            .map_entries(&entries)
            .data(&data);
        let stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(c"main")
            .specialization_info(&specialization);
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
        let raster = desc.rasterization();
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth = desc.depth_stencil();
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
/// its reflection: the unit most passes are made of. `I` is the shader:
/// its bindings, push block, accesses and workgroup size come with it.
pub struct ComputeKernel<I: ShaderInterface> {
    layout: DescriptorSetLayout,
    pipeline: Pipeline,
    name: String,
    shader: PhantomData<fn() -> I>,
}

/// What a kernel runs over.
#[derive(Clone, Copy)]
pub enum Work<'a> {
    /// One invocation per element of an extent (x, y, z), in as many work
    /// groups of the shader's size as cover it.
    Threads([u32; 3]),
    /// This many work groups.
    Groups([u32; 3]),
    /// Work groups read by the GPU from a `VkDispatchIndirectCommand` in
    /// the buffer at the offset (declared as an indirect read).
    Indirect(&'a Buffer, u64),
}

impl Work<'_> {
    /// One invocation per pixel of a `width` x `height` image.
    pub fn pixels((width, height): (u32, u32)) -> Self {
        Work::Threads([width, height, 1])
    }
}

impl<I: ShaderInterface> ComputeKernel<I> {
    /// Creates the layout (from the shader's bindings) and the pipeline.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Self::specialized(device, &[])
    }

    /// [`ComputeKernel::new`] with the shader's specialization constants
    /// set to `constants` (see [`Pipeline::compute_specialized`]): the
    /// driver compiles only the code they select.
    pub fn specialized(device: &Arc<Device>, constants: &[(u32, u32)]) -> Result<Self> {
        let shader = I::SHADER;
        let push_size = push_size::<I::Push>(&[&shader])?;
        let layout = DescriptorSetLayout::for_shaders(device, &[&shader])?;
        let pipeline = Pipeline::compute_specialized(device, shader.spirv, &[&layout], push_size, constants)?;
        let name = shader.name.trim_end_matches(".comp").to_string();
        let kernel = Self {
            layout,
            pipeline,
            name,
            shader: PhantomData,
        };
        Ok(kernel.named_objects())
    }

    /// Names the kernel (its debug label) and so its pipeline `<name>
    /// pipeline`, its layout and its descriptor set layout (see
    /// [`Device::set_name`]). By default it is named after its shader.
    pub fn named(mut self, name: &str) -> Self {
        self.name = name.to_string();
        self.named_objects()
    }

    fn named_objects(self) -> Self {
        self.layout.name(&format!("{} set layout", self.name));
        self.pipeline.name(&self.name);
        self
    }

    /// The descriptor set layout (for sizing a frame's pool).
    pub fn set_layout(&self) -> &DescriptorSetLayout {
        &self.layout
    }

    /// Runs the kernel: declares every binding with the access the shader
    /// makes of it (and indirect arguments), flushes the barriers, writes a
    /// set for `bindings`, binds it with the pipeline, pushes `push` and
    /// dispatches `work` with the shader's workgroup size, in a debug label
    /// named after the kernel.
    pub fn dispatch(
        &self,
        rec: &mut Recorder<'_>,
        pool: &DescriptorPool,
        bindings: &I::Bindings<'_>,
        push: &I::Push,
        work: Work<'_>,
    ) -> Result<()> {
        let bindings = bindings.bindings();
        declare_bindings(rec, &[&I::SHADER], &bindings, BindingAccess::in_compute);
        if let Work::Indirect(args, _) = work {
            rec.use_buffer(args, Access::IndirectRead);
        }
        rec.flush_barriers();
        let set = pool.allocate(&self.layout, &bindings)?;
        let device = &self.pipeline.device;
        device.begin_label(rec.cmd, &self.name);
        self.pipeline.bind(rec.cmd, set, bytemuck::bytes_of(push));
        let size = I::SHADER.local_size;
        // SAFETY: recording with this compute pipeline and its set bound;
        // indirect arguments come from a buffer with INDIRECT_BUFFER usage
        // (the caller's) holding a dispatch command at the offset.
        unsafe {
            match work {
                Work::Threads(n) => device.raw.cmd_dispatch(
                    rec.cmd,
                    n[0].div_ceil(size[0]),
                    n[1].div_ceil(size[1]),
                    n[2].div_ceil(size[2]),
                ),
                Work::Groups(g) => device.raw.cmd_dispatch(rec.cmd, g[0], g[1], g[2]),
                Work::Indirect(args, offset) => {
                    device.raw.cmd_dispatch_indirect(rec.cmd, args.raw, offset)
                }
            }
        }
        device.end_label(rec.cmd);
        Ok(())
    }

    /// The shader's local workgroup size.
    pub fn local_size(&self) -> [u32; 3] {
        I::SHADER.local_size
    }
}
