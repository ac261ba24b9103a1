//! A minimal host engine that owns its Vulkan instance and device, embeds
//! ssbc on them, renders a frame, reads it back, and destroys its own
//! objects afterwards (ssbc never destroys what it does not own).
//!
//! `cargo run --example embed` (set `SSBC_VALIDATION=1` for the Khronos
//! validation layer; the tests run it that way).

#[path = "common/host.rs"]
mod host;

use ash::vk;
use ssbc::vk::RequiredFeatures;

/// What the host saw: mean radiance of the frame, its passes, validation messages.
pub struct EmbedReport {
    /// Mean of the final image's RGB.
    pub mean_radiance: f32,
    /// Pass names and GPU milliseconds.
    pub passes: Vec<(String, f64)>,
    /// Validation warnings and errors (0 without validation).
    pub validation_messages: u32,
    /// Largest difference between the frame read back by ssbc and the GPU
    /// image ssbc handed over, copied by the host's own commands.
    pub handoff_max_difference: f32,
}

/// The host reads ssbc's output image with its own command buffer, waiting
/// on ssbc's timeline semaphore, into its own host-visible buffer.
fn host_reads_gpu_image(
    instance: &ash::Instance,
    physical: vk::PhysicalDevice,
    device: &ash::Device,
    family: u32,
    out: &ssbc::GpuImage,
) -> Result<Vec<f32>, Box<dyn std::error::Error>> {
    let size = out.extent.0 as u64 * out.extent.1 as u64 * 16;
    // SAFETY (whole function): plain Vulkan calls on the host's live objects,
    // each created here and destroyed before returning.
    unsafe {
        let buffer = device.create_buffer(
            &vk::BufferCreateInfo::default()
                .size(size)
                .usage(vk::BufferUsageFlags::TRANSFER_DST),
            None,
        )?;
        let req = device.get_buffer_memory_requirements(buffer);
        let props = instance.get_physical_device_memory_properties(physical);
        let wanted = vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT;
        let type_index = (0..props.memory_type_count)
            .find(|&i| {
                req.memory_type_bits & (1 << i) != 0
                    && props.memory_types[i as usize]
                        .property_flags
                        .contains(wanted)
            })
            .ok_or("no host-visible memory")?;
        let memory = device.allocate_memory(
            &vk::MemoryAllocateInfo::default()
                .allocation_size(req.size)
                .memory_type_index(type_index),
            None,
        )?;
        device.bind_buffer_memory(buffer, memory, 0)?;
        let pool = device.create_command_pool(
            &vk::CommandPoolCreateInfo::default().queue_family_index(family),
            None,
        )?;
        let cmd = device.allocate_command_buffers(
            &vk::CommandBufferAllocateInfo::default()
                .command_pool(pool)
                .command_buffer_count(1),
        )?[0];
        device.begin_command_buffer(cmd, &vk::CommandBufferBeginInfo::default())?;
        // ssbc left the image in `out.layout`; make its writes visible to the copy.
        let barrier = vk::ImageMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
            .src_access_mask(vk::AccessFlags2::MEMORY_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .dst_access_mask(vk::AccessFlags2::TRANSFER_READ)
            .old_layout(out.layout)
            .new_layout(vk::ImageLayout::TRANSFER_SRC_OPTIMAL)
            .image(out.image)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                base_mip_level: 0,
                level_count: 1,
                base_array_layer: 0,
                layer_count: 1,
            });
        device.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().image_memory_barriers(&[barrier]),
        );
        let region = vk::BufferImageCopy::default()
            .image_subresource(vk::ImageSubresourceLayers {
                aspect_mask: vk::ImageAspectFlags::COLOR,
                mip_level: 0,
                base_array_layer: 0,
                layer_count: 1,
            })
            // The frame's part of the image (offset only with a guard band).
            .image_offset(vk::Offset3D {
                x: out.origin.0 as i32,
                y: out.origin.1 as i32,
                z: 0,
            })
            .image_extent(vk::Extent3D {
                width: out.extent.0,
                height: out.extent.1,
                depth: 1,
            });
        device.cmd_copy_image_to_buffer(
            cmd,
            out.image,
            vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
            buffer,
            &[region],
        );
        let to_host = vk::BufferMemoryBarrier2::default()
            .src_stage_mask(vk::PipelineStageFlags2::TRANSFER)
            .src_access_mask(vk::AccessFlags2::TRANSFER_WRITE)
            .dst_stage_mask(vk::PipelineStageFlags2::HOST)
            .dst_access_mask(vk::AccessFlags2::HOST_READ)
            .buffer(buffer)
            .size(vk::WHOLE_SIZE);
        device.cmd_pipeline_barrier2(
            cmd,
            &vk::DependencyInfo::default().buffer_memory_barriers(&[to_host]),
        );
        device.end_command_buffer(cmd)?;
        let wait = [vk::SemaphoreSubmitInfo::default()
            .semaphore(out.semaphore)
            .value(out.value)
            .stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)];
        let cmds = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = vk::SubmitInfo2::default()
            .wait_semaphore_infos(&wait)
            .command_buffer_infos(&cmds);
        let queue = device.get_device_queue(family, 0);
        device.queue_submit2(queue, &[submit], vk::Fence::null())?;
        device.queue_wait_idle(queue)?;
        let ptr = device.map_memory(memory, 0, size, vk::MemoryMapFlags::empty())? as *const f32;
        let texels = std::slice::from_raw_parts(ptr, (size / 4) as usize).to_vec();
        device.unmap_memory(memory);
        device.destroy_command_pool(pool, None);
        device.destroy_buffer(buffer, None);
        device.free_memory(memory, None);
        Ok(texels)
    }
}

/// Runs the host: returns what it measured.
pub fn run(validation: bool) -> Result<EmbedReport, Box<dyn std::error::Error>> {
    // --- The host's own instance and device (made with ash; ssbc's
    // features merged into the device's). ---
    let own = host::OwnInstance::new(validation)?;
    let before = host::OwnInstance::messages();
    let (ssbc_device, device) = host::host_device_with(&own.for_ssbc(), RequiredFeatures::ALL)?;
    let (physical, family) = (ssbc_device.physical, ssbc_device.queue_family);

    // --- Embed ssbc. ---
    let report = {
        let mut renderer = ssbc::Renderer::with_device(ssbc_device)?;
        // A scene from the host's own data: a floor and a wall under a point light.
        let mut scene = ssbc::Scene::new("host scene");
        let grey = scene.add_material(glam::Vec3::splat(0.7), None);
        let red = scene.add_material(glam::Vec3::new(0.7, 0.1, 0.1), None);
        let quad = [
            glam::Vec3::new(-1.0, 0.0, 1.0),
            glam::Vec3::new(1.0, 0.0, 1.0),
            glam::Vec3::new(1.0, 0.0, -1.0),
            glam::Vec3::new(-1.0, 0.0, -1.0),
        ];
        scene.add_mesh(
            &quad,
            &[],
            &[],
            &[0, 1, 2, 0, 2, 3],
            glam::Mat4::IDENTITY,
            grey,
        )?;
        let wall = glam::Mat4::from_translation(glam::Vec3::new(0.0, 1.0, -1.0))
            * glam::Mat4::from_rotation_x(std::f32::consts::FRAC_PI_2);
        scene.add_mesh(&quad, &[], &[], &[0, 1, 2, 0, 2, 3], wall, red)?;
        scene.lights.push(ssbc::scene::Light {
            kind: ssbc::scene::LightKind::Point,
            position: glam::Vec3::new(0.0, 1.5, 0.3),
            direction: -glam::Vec3::Y,
            intensity: glam::Vec3::splat(2.0),
        });
        scene.cameras.push(ssbc::scene::Camera::look_at(
            glam::Vec3::new(0.0, 1.2, 3.0),
            glam::Vec3::new(0.0, 0.4, 0.0),
            0.8,
        ));
        let mut settings = ssbc::RenderSettings {
            width: 64,
            height: 48,
            ..Default::default()
        };
        settings.vpl.count = 32;
        let frame = renderer.render(&scene, &settings)?;
        // The same image, handed over on the GPU and read by the host's own commands.
        let gpu_image = renderer.output_image().ok_or("no output image")?;
        let texels = host_reads_gpu_image(&own.raw, physical, &device, family, &gpu_image)?;
        let handoff_max_difference = texels
            .iter()
            .zip(&frame.image.rgba)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        let rgb: Vec<f32> = frame
            .image
            .rgba
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        EmbedReport {
            mean_radiance: rgb.iter().sum::<f32>() / rgb.len() as f32,
            passes: frame
                .timings
                .timed_passes()
                .iter()
                .map(|p| (p.name.clone(), p.gpu_ms))
                .collect(),
            validation_messages: 0,
            handoff_max_difference,
        }
        // The renderer and ssbc's device wrapper drop here: they destroy only
        // their own objects.
    };

    // --- The host still owns a working device: use it, then destroy it. ---
    // SAFETY: ssbc is gone; nothing else uses the device.
    unsafe {
        device.device_wait_idle()?;
        device.destroy_device(None);
    }
    drop(own);
    Ok(EmbedReport {
        validation_messages: host::OwnInstance::messages() - before,
        ..report
    })
}

#[allow(dead_code)]
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let validation = std::env::var("SSBC_VALIDATION").is_ok_and(|v| v == "1");
    let report = run(validation)?;
    println!("mean radiance {:.4}", report.mean_radiance);
    println!(
        "GPU hand-off vs read-back: max difference {}",
        report.handoff_max_difference
    );
    for (name, ms) in &report.passes {
        println!("  {name:<22} {ms:>8.3} ms");
    }
    if report.validation_messages > 0 {
        return Err(format!("{} validation messages", report.validation_messages).into());
    }
    Ok(())
}
