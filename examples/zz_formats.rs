use ash::vk;
fn main() {
    let entry = unsafe { ash::Entry::load().unwrap() };
    let app = vk::ApplicationInfo::default().api_version(vk::API_VERSION_1_3);
    let inst = unsafe {
        entry
            .create_instance(
                &vk::InstanceCreateInfo::default().application_info(&app),
                None,
            )
            .unwrap()
    };
    for pd in unsafe { inst.enumerate_physical_devices().unwrap() } {
        let f = unsafe { inst.get_physical_device_features(pd) };
        println!(
            "readWithoutFormat {} writeWithoutFormat {} extended {}",
            f.shader_storage_image_read_without_format,
            f.shader_storage_image_write_without_format,
            f.shader_storage_image_extended_formats
        );
        for fmt in [
            vk::Format::R16G16B16A16_SNORM,
            vk::Format::R16G16B16A16_UNORM,
            vk::Format::R16G16B16A16_SFLOAT,
            vk::Format::R32G32B32A32_SFLOAT,
            vk::Format::R32G32_UINT,
            vk::Format::A2B10G10R10_UNORM_PACK32,
        ] {
            let mut p3 = vk::FormatProperties3::default();
            let mut p2 = vk::FormatProperties2::default().push_next(&mut p3);
            unsafe { inst.get_physical_device_format_properties2(pd, fmt, &mut p2) };
            let o = p3.optimal_tiling_features;
            println!(
                "{fmt:?}: storage {} color {} readNoFmt {} writeNoFmt {}",
                o.contains(vk::FormatFeatureFlags2::STORAGE_IMAGE),
                o.contains(vk::FormatFeatureFlags2::COLOR_ATTACHMENT),
                o.contains(vk::FormatFeatureFlags2::STORAGE_READ_WITHOUT_FORMAT),
                o.contains(vk::FormatFeatureFlags2::STORAGE_WRITE_WITHOUT_FORMAT)
            );
        }
    }
}
