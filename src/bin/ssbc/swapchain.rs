//! A window surface and its swapchain (FIFO present), recreated on resize or
//! when the presentation engine reports it out of date.

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;

use ssbc::error::VkResultExt;
use ssbc::vk::barrier::ResourceState;
use ssbc::vk::{Device, TrackedImage};
use ssbc::{Error, Result};

/// One swapchain image, with tracked access like any other image.
pub struct SwapchainImage {
    /// The raw handle (owned by the swapchain).
    pub raw: vk::Image,
    state: Cell<ResourceState>,
    /// Signalled when this image's frame is ready to present.
    pub render_done: vk::Semaphore,
}

impl TrackedImage for SwapchainImage {
    fn tracked_raw(&self) -> vk::Image {
        self.raw
    }
    fn tracked_state(&self) -> &Cell<ResourceState> {
        &self.state
    }
    fn tracked_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: vk::ImageAspectFlags::COLOR,
            base_mip_level: 0,
            level_count: 1,
            base_array_layer: 0,
            layer_count: 1,
        }
    }
}

/// The surface and the swapchain presenting to it.
pub struct Swapchain {
    device: Arc<Device>,
    surface_loader: ash::khr::surface::Instance,
    loader: ash::khr::swapchain::Device,
    surface: vk::SurfaceKHR,
    raw: vk::SwapchainKHR,
    /// The images.
    pub images: Vec<SwapchainImage>,
    /// Pixel format (an 8-bit UNORM format; ssbc encodes sRGB itself).
    pub format: vk::Format,
    /// Size in pixels.
    pub extent: vk::Extent2D,
}

/// A binary semaphore (for acquire/present). Destroyed on drop: the owner
/// makes sure no queue operation still uses it.
pub struct BinarySemaphore {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::Semaphore,
}

impl BinarySemaphore {
    /// Creates one.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        // SAFETY: valid device.
        let raw = unsafe {
            device
                .raw
                .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
        }
        .vk("vkCreateSemaphore")?;
        Ok(Self {
            device: device.clone(),
            raw,
        })
    }
}

impl Drop for BinarySemaphore {
    fn drop(&mut self) {
        // SAFETY: the owner waited for the queue operations that use it.
        unsafe { self.device.raw.destroy_semaphore(self.raw, None) };
    }
}

impl Swapchain {
    /// Takes ownership of `surface` (created for the device's instance) and
    /// builds a swapchain of about `extent`.
    pub fn new(
        device: &Arc<Device>,
        surface: vk::SurfaceKHR,
        extent: vk::Extent2D,
    ) -> Result<Self> {
        let instance = &device.instance;
        let surface_loader = ash::khr::surface::Instance::new(&instance.entry, &instance.raw);
        // SAFETY: valid physical device, family and surface.
        let supported = unsafe {
            surface_loader.get_physical_device_surface_support(
                device.physical,
                device.queue_family,
                surface,
            )
        }
        .unwrap_or(false);
        if !supported {
            // SAFETY: the surface is ours and unused.
            unsafe { surface_loader.destroy_surface(surface, None) };
            return Err(Error::NoDevice(format!(
                "'{}' cannot present to this window",
                device.name()
            )));
        }
        let loader = ash::khr::swapchain::Device::new(&instance.raw, &device.raw);
        let mut swapchain = Self {
            device: device.clone(),
            surface_loader,
            loader,
            surface,
            raw: vk::SwapchainKHR::null(),
            images: Vec::new(),
            format: vk::Format::B8G8R8A8_UNORM,
            extent,
        };
        swapchain.recreate(extent)?;
        Ok(swapchain)
    }

    /// (Re)creates the swapchain for the surface's current size (or `wanted`
    /// where the surface leaves it to us). Waits for the device first.
    pub fn recreate(&mut self, wanted: vk::Extent2D) -> Result<()> {
        self.device.wait_idle()?;
        // SAFETY: valid physical device and surface.
        let caps = unsafe {
            self.surface_loader
                .get_physical_device_surface_capabilities(self.device.physical, self.surface)
        }
        .vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR")?;
        // SAFETY: as above.
        let formats = unsafe {
            self.surface_loader
                .get_physical_device_surface_formats(self.device.physical, self.surface)
        }
        .vk("vkGetPhysicalDeviceSurfaceFormatsKHR")?;
        let format = formats
            .iter()
            .find(|f| {
                matches!(
                    f.format,
                    vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM
                )
            })
            .copied()
            .ok_or_else(|| {
                Error::NoDevice("the surface offers no 8-bit UNORM BGRA/RGBA format".into())
            })?;
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: wanted
                    .width
                    .clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: wanted
                    .height
                    .clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(self.surface)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST | vk::ImageUsageFlags::COLOR_ATTACHMENT)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(vk::CompositeAlphaFlagsKHR::OPAQUE)
            .present_mode(vk::PresentModeKHR::FIFO)
            .clipped(true)
            .old_swapchain(self.raw);
        // SAFETY: valid surface; the old swapchain is retired by this call.
        let raw =
            unsafe { self.loader.create_swapchain(&info, None) }.vk("vkCreateSwapchainKHR")?;
        self.destroy_images_and_swapchain();
        self.raw = raw;
        // SAFETY: swapchain just created.
        let images =
            unsafe { self.loader.get_swapchain_images(raw) }.vk("vkGetSwapchainImagesKHR")?;
        for raw_image in images {
            // SAFETY: valid device.
            let render_done = unsafe {
                self.device
                    .raw
                    .create_semaphore(&vk::SemaphoreCreateInfo::default(), None)
            }
            .vk("vkCreateSemaphore")?;
            self.images.push(SwapchainImage {
                raw: raw_image,
                state: Cell::new(ResourceState::default()),
                render_done,
            });
        }
        self.format = format.format;
        self.extent = extent;
        Ok(())
    }

    /// Acquires the next image, signalling `acquired` when it may be
    /// written; None when the swapchain must be recreated.
    pub fn acquire(&self, acquired: &BinarySemaphore) -> Result<Option<usize>> {
        // SAFETY: valid swapchain; `acquired` is unsignalled (the frame that
        // last waited on it has finished).
        match unsafe {
            self.loader
                .acquire_next_image(self.raw, u64::MAX, acquired.raw, vk::Fence::null())
        } {
            // Suboptimal still acquires (and signals): use the image; the
            // present that follows reports it and the caller recreates then.
            Ok((index, _suboptimal)) => Ok(Some(index as usize)),
            // Out of date signals nothing: recreate and try again.
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(None),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => {
                Err(Error::NoDevice("the window surface was lost".into()))
            }
            Err(result) => Err(Error::Vulkan {
                call: "vkAcquireNextImageKHR",
                result,
            }),
        }
    }

    /// Presents image `index`; returns false when the swapchain must be recreated.
    pub fn present(&self, index: usize) -> Result<bool> {
        let waits = [self.images[index].render_done];
        let swapchains = [self.raw];
        let indices = [index as u32];
        let info = vk::PresentInfoKHR::default()
            .wait_semaphores(&waits)
            .swapchains(&swapchains)
            .image_indices(&indices);
        // SAFETY: the image was acquired and its frame signals `render_done`.
        match unsafe { self.loader.queue_present(self.device.queue, &info) } {
            Ok(false) => Ok(true),
            Ok(true) | Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(false),
            Err(vk::Result::ERROR_SURFACE_LOST_KHR) => {
                Err(Error::NoDevice("the window surface was lost".into()))
            }
            Err(result) => Err(Error::Vulkan {
                call: "vkQueuePresentKHR",
                result,
            }),
        }
    }

    fn destroy_images_and_swapchain(&mut self) {
        // SAFETY: callers wait for the device to be idle first.
        unsafe {
            for image in self.images.drain(..) {
                self.device.raw.destroy_semaphore(image.render_done, None);
            }
            if self.raw != vk::SwapchainKHR::null() {
                self.loader.destroy_swapchain(self.raw, None);
                self.raw = vk::SwapchainKHR::null();
            }
        }
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        let _ = self.device.wait_idle();
        self.destroy_images_and_swapchain();
        // SAFETY: idle device; the surface outlives its swapchain and is destroyed last.
        unsafe { self.surface_loader.destroy_surface(self.surface, None) };
    }
}
