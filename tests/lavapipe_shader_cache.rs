//! A standalone reproducer (plain ash, no ssbc code) of the lavapipe crash
//! that forced 4-wide subgroups used to hit (docs/development.md, "Subgroup
//! width"). It is the driver's, and it is not about what a shader does:
//!
//! lavapipe's on-disk shader cache does not key its entries by the vector
//! width (`LP_NATIVE_VECTOR_WIDTH`). A process at the default width (256
//! bits on an AVX machine) caches its vertex shaders compiled 8 vertices a
//! loop iteration. A later process at 128 bits loads them from the cache,
//! but its draw module allocates the vertex shader's outputs for batches of
//! 4 (`align(count, lp_native_vector_width / 32)` vertices plus 512 bytes),
//! so a draw of 3 vertices gets room for 4 and the cached code writes 8:
//! four vertices' outputs land past the end of the block, in malloc's heap.
//! glibc then aborts ("malloc(): invalid next size", "corrupted
//! double-linked list") or the process segfaults, at once or later.
//!
//! Evidence (2026-11-27): with a guard page after every heap block of 512
//! bytes or more, the 128-bit process faults in the cached vertex code on
//! `vextractf128 $1, %ymm6, 0x85c(%rdi)`: stores of one output for vertices
//! 0..7 at a stride of 356 bytes into a 1936-byte block (4 x 356 + 512),
//! in a loop whose counter steps by 8. With `MESA_SHADER_CACHE_DISABLE=true`,
//! or a cache directory per width, nothing crashes.
//!
//! Seen with Debian's Mesa 22.3.6-1+deb12u2 and 25.0.7-2~bpo12+1 (LLVM 15,
//! AVX-512 Xeon). The test suite therefore gives every forced-width run a
//! shader cache of its own (tests/subgroup_width.rs).
//!
//! Run it by hand; it passes while the driver has the bug:
//!
//! ```sh
//! cargo test --release --test lavapipe_shader_cache -- --ignored --nocapture
//! ```

use std::os::unix::process::ExitStatusExt;
use std::process::Command;

use ash::vk;

/// Eight varyings: a vertex large enough that four of them overflow the
/// draw module's 512-byte padding.
const VERTEX: &str = r#"
#version 460
layout(location = 0) in vec3 in_position;
layout(location = 0) out vec4 v_out[8];
void main() {
    for (int i = 0; i < 8; i++) v_out[i] = vec4(in_position, float(i));
    gl_Position = vec4(in_position, 1.0);
}
"#;

#[test]
#[ignore = "reproduces a driver bug; run by hand (see the module docs)"]
fn cached_vertex_code_of_another_vector_width_overflows_the_heap() {
    let cache = tempfile::tempdir().unwrap();
    let run = |width: Option<&str>, cache: &std::path::Path| {
        let mut cmd = Command::new(std::env::current_exe().unwrap());
        cmd.args(["--ignored", "--exact", "draw_one_triangle", "--nocapture"])
            .env("REPRO_CHILD", "1")
            .env("MESA_SHADER_CACHE_DIR", cache)
            .env_remove("MESA_SHADER_CACHE_DISABLE");
        if let Some(w) = width {
            cmd.env("LP_NATIVE_VECTOR_WIDTH", w);
        }
        let out = cmd.output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        (out.status, stderr)
    };
    let (status, stderr) = run(None, cache.path());
    assert!(status.success(), "default width failed: {stderr}");
    if !stderr.contains("llvmpipe") {
        eprintln!("not lavapipe: nothing to reproduce ({stderr})");
        return;
    }
    // The same cache at 128 bits: the driver bug, if the driver has it.
    let (status, stderr) = run(Some("128"), cache.path());
    eprintln!(
        "128 bits, the default width's cache: {status} (signal {:?})\n{stderr}",
        status.signal()
    );
    // A cache of its own: always fine.
    let own = tempfile::tempdir().unwrap();
    let (clean, clean_stderr) = run(Some("128"), own.path());
    assert!(
        clean.success(),
        "128 bits, own cache: {clean}\n{clean_stderr}"
    );
    assert!(
        status.signal().is_some(),
        "the driver no longer crashes on another width's cached vertex code: \
         the workaround in tests/subgroup_width.rs may go"
    );
}

/// One frame of three vertices, depth only (the child process of the test
/// above; does nothing unless `REPRO_CHILD` is set).
#[test]
#[ignore = "child process of the reproducer"]
fn draw_one_triangle() {
    if std::env::var_os("REPRO_CHILD").is_none() {
        return;
    }
    // SAFETY: plain Vulkan calls on objects created here, destroyed in
    // reverse order after the queue is idle.
    unsafe {
        let entry = ash::Entry::load().unwrap();
        let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
        let instance = entry
            .create_instance(
                &vk::InstanceCreateInfo::default().application_info(&app),
                None,
            )
            .unwrap();
        let pd = instance.enumerate_physical_devices().unwrap()[0];
        let props = instance.get_physical_device_properties(pd);
        eprintln!("device: {:?}", props.device_name_as_c_str().unwrap());
        let priorities = [1.0];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(0)
            .queue_priorities(&priorities)];
        let mut f13 = vk::PhysicalDeviceVulkan13Features::default().dynamic_rendering(true);
        let device = instance
            .create_device(
                pd,
                &vk::DeviceCreateInfo::default()
                    .queue_create_infos(&queues)
                    .push_next(&mut f13),
                None,
            )
            .unwrap();
        let memory = instance.get_physical_device_memory_properties(pd);
        let allocate = |req: vk::MemoryRequirements| {
            let host =
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
            let index = (0..memory.memory_type_count)
                .find(|&i| {
                    req.memory_type_bits & (1 << i) != 0
                        && memory.memory_types[i as usize]
                            .property_flags
                            .contains(host)
                })
                .unwrap();
            let info = vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(index);
            device.allocate_memory(&info, None).unwrap()
        };

        let positions: [f32; 9] = [-0.5, -0.5, 0.5, 0.5, -0.5, 0.5, 0.0, 0.5, 0.5];
        let info = vk::BufferCreateInfo::default()
            .size(std::mem::size_of_val(&positions) as u64)
            .usage(vk::BufferUsageFlags::VERTEX_BUFFER);
        let vertices = device.create_buffer(&info, None).unwrap();
        let vertex_memory = allocate(device.get_buffer_memory_requirements(vertices));
        device
            .bind_buffer_memory(vertices, vertex_memory, 0)
            .unwrap();
        let mapped = device
            .map_memory(
                vertex_memory,
                0,
                vk::WHOLE_SIZE,
                vk::MemoryMapFlags::empty(),
            )
            .unwrap();
        std::ptr::copy_nonoverlapping(positions.as_ptr(), mapped.cast(), positions.len());
        device.unmap_memory(vertex_memory);

        let (size, format) = (64, vk::Format::D32_SFLOAT);
        let image_info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: size,
                height: size,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .usage(vk::ImageUsageFlags::DEPTH_STENCIL_ATTACHMENT);
        let depth = device.create_image(&image_info, None).unwrap();
        let depth_memory = allocate(device.get_image_memory_requirements(depth));
        device.bind_image_memory(depth, depth_memory, 0).unwrap();
        let range = vk::ImageSubresourceRange::default()
            .aspect_mask(vk::ImageAspectFlags::DEPTH)
            .level_count(1)
            .layer_count(1);
        let view_info = vk::ImageViewCreateInfo::default()
            .image(depth)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(range);
        let view = device.create_image_view(&view_info, None).unwrap();

        let code = {
            let compiler = shaderc::Compiler::new().unwrap();
            let mut options = shaderc::CompileOptions::new().unwrap();
            options.set_target_env(
                shaderc::TargetEnv::Vulkan,
                shaderc::EnvVersion::Vulkan1_2 as u32,
            );
            let kind = shaderc::ShaderKind::Vertex;
            let spirv =
                compiler.compile_into_spirv(VERTEX, kind, "repro.vert", "main", Some(&options));
            spirv.unwrap().as_binary().to_vec()
        };
        let module_info = vk::ShaderModuleCreateInfo::default().code(&code);
        let module = device.create_shader_module(&module_info, None).unwrap();
        let layout = device
            .create_pipeline_layout(&vk::PipelineLayoutCreateInfo::default(), None)
            .unwrap();
        let stages = [vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::VERTEX)
            .module(module)
            .name(c"main")];
        let bindings = [vk::VertexInputBindingDescription::default().stride(12)];
        let attributes =
            [vk::VertexInputAttributeDescription::default().format(vk::Format::R32G32B32_SFLOAT)];
        let vertex_input = vk::PipelineVertexInputStateCreateInfo::default()
            .vertex_binding_descriptions(&bindings)
            .vertex_attribute_descriptions(&attributes);
        let assembly = vk::PipelineInputAssemblyStateCreateInfo::default()
            .topology(vk::PrimitiveTopology::TRIANGLE_LIST);
        let area = vk::Rect2D {
            offset: vk::Offset2D::default(),
            extent: vk::Extent2D {
                width: size,
                height: size,
            },
        };
        let viewports = [vk::Viewport {
            width: size as f32,
            height: size as f32,
            max_depth: 1.0,
            ..Default::default()
        }];
        let scissors = [area];
        let viewport = vk::PipelineViewportStateCreateInfo::default()
            .viewports(&viewports)
            .scissors(&scissors);
        let raster = vk::PipelineRasterizationStateCreateInfo::default().line_width(1.0);
        let multisample = vk::PipelineMultisampleStateCreateInfo::default()
            .rasterization_samples(vk::SampleCountFlags::TYPE_1);
        let depth_state = vk::PipelineDepthStencilStateCreateInfo::default()
            .depth_test_enable(true)
            .depth_write_enable(true)
            .depth_compare_op(vk::CompareOp::LESS);
        let mut rendering =
            vk::PipelineRenderingCreateInfo::default().depth_attachment_format(format);
        let pipeline_info = vk::GraphicsPipelineCreateInfo::default()
            .stages(&stages)
            .vertex_input_state(&vertex_input)
            .input_assembly_state(&assembly)
            .viewport_state(&viewport)
            .rasterization_state(&raster)
            .multisample_state(&multisample)
            .depth_stencil_state(&depth_state)
            .layout(layout)
            .push_next(&mut rendering);
        let pipeline = device
            .create_graphics_pipelines(vk::PipelineCache::null(), &[pipeline_info], None)
            .unwrap()[0];

        let pool = device
            .create_command_pool(&vk::CommandPoolCreateInfo::default(), None)
            .unwrap();
        let cmd_info = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .command_buffer_count(1);
        let cmd = device.allocate_command_buffers(&cmd_info).unwrap()[0];
        device
            .begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())
            .unwrap();
        let to_attachment = [vk::ImageMemoryBarrier::default()
            .image(depth)
            .subresource_range(range)
            .old_layout(vk::ImageLayout::UNDEFINED)
            .new_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .dst_access_mask(vk::AccessFlags::DEPTH_STENCIL_ATTACHMENT_WRITE)];
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TOP_OF_PIPE,
            vk::PipelineStageFlags::EARLY_FRAGMENT_TESTS,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &to_attachment,
        );
        let attachment = vk::RenderingAttachmentInfo::default()
            .image_view(view)
            .image_layout(vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL)
            .load_op(vk::AttachmentLoadOp::CLEAR)
            .store_op(vk::AttachmentStoreOp::STORE)
            .clear_value(vk::ClearValue {
                depth_stencil: vk::ClearDepthStencilValue {
                    depth: 1.0,
                    stencil: 0,
                },
            });
        let rendering_info = vk::RenderingInfo::default()
            .render_area(area)
            .layer_count(1)
            .depth_attachment(&attachment);
        device.cmd_begin_rendering(cmd, &rendering_info);
        device.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::GRAPHICS, pipeline);
        device.cmd_bind_vertex_buffers(cmd, 0, &[vertices], &[0]);
        device.cmd_draw(cmd, 3, 1, 0, 0);
        device.cmd_end_rendering(cmd);
        device.end_command_buffer(cmd).unwrap();
        let queue = device.get_device_queue(0, 0);
        let cmds = [cmd];
        let submit = vk::SubmitInfo::default().command_buffers(&cmds);
        device
            .queue_submit(queue, &[submit], vk::Fence::null())
            .unwrap();
        device.queue_wait_idle(queue).unwrap();

        device.destroy_command_pool(pool, None);
        device.destroy_pipeline(pipeline, None);
        device.destroy_pipeline_layout(layout, None);
        device.destroy_shader_module(module, None);
        device.destroy_image_view(view, None);
        device.destroy_image(depth, None);
        device.free_memory(depth_memory, None);
        device.destroy_buffer(vertices, None);
        device.free_memory(vertex_memory, None);
        device.destroy_device(None);
        instance.destroy_instance(None);
    }
    eprintln!("drawn");
}
