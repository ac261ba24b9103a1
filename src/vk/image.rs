//! GPU images with their views, `Drop`-based lifetimes and tracked last access.

use std::cell::Cell;
use std::sync::Arc;

use ash::vk;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};
use gpu_allocator::MemoryLocation;

use super::aliasing::{AliasRegion, SharedUse};
use super::barrier::ResourceState;
use super::device::{Device, Garbage};
use crate::error::{Error, Result, VkResultExt};

/// What to create.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageDesc {
    /// Texel format.
    pub format: vk::Format,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Array layers (1 for a plain 2D image).
    pub layers: u32,
    /// Mip levels.
    pub mip_levels: u32,
    /// How the image is used.
    pub usage: vk::ImageUsageFlags,
    /// View it as a 2D array even with one layer (for `sampler2DArray`).
    pub array: bool,
}

impl ImageDesc {
    /// How [`Image::new`] creates it.
    pub fn create_info(&self) -> vk::ImageCreateInfo<'static> {
        vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(self.format)
            .extent(vk::Extent3D {
                width: self.width,
                height: self.height,
                depth: 1,
            })
            .mip_levels(self.mip_levels)
            .array_layers(self.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(self.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED)
    }

    /// The memory requirements of such an image on `device`, asked before
    /// it exists (Vulkan 1.3).
    pub fn memory_requirements(&self, device: &Device) -> vk::MemoryRequirements {
        let info = self.create_info();
        let query = vk::DeviceImageMemoryRequirements::default().create_info(&info);
        let mut requirements = vk::MemoryRequirements2::default();
        // SAFETY: a valid create info on a live Vulkan 1.3 device.
        unsafe {
            device
                .raw
                .get_device_image_memory_requirements(&query, &mut requirements)
        };
        requirements.memory_requirements
    }

    /// Bytes of device memory such an image takes on `device`.
    pub fn memory_bytes(&self, device: &Device) -> u64 {
        self.memory_requirements(device).size
    }

    /// Bytes it takes: on `device`, its memory requirements there;
    /// without one, its texels (one mip level) as asked for.
    /// (Asked of the device only where the device could make it: an
    /// absurd size is refused later, with its own error.)
    pub fn bytes(&self, device: Option<&Device>) -> u64 {
        match device {
            Some(d) if self.fits(d) => self.memory_bytes(d),
            _ => {
                let texel = match self.format {
                    vk::Format::R32G32B32A32_SFLOAT | vk::Format::R32G32B32A32_UINT => 16,
                    vk::Format::R16G16B16A16_SFLOAT | vk::Format::R32G32_UINT => 8,
                    _ => 4,
                };
                texel * self.width as u64 * self.height as u64 * self.layers as u64
            }
        }
    }

    /// Whether `device` can make such an image: a size and layer count
    /// within its limits.
    fn fits(&self, device: &Device) -> bool {
        let limits = device.limits();
        let side = 1..=limits.max_image_dimension2_d;
        side.contains(&self.width)
            && side.contains(&self.height)
            && (1..=limits.max_image_array_layers).contains(&self.layers)
    }

    /// A single-layer, single-mip 2D image.
    pub fn new_2d(format: vk::Format, width: u32, height: u32, usage: vk::ImageUsageFlags) -> Self {
        Self {
            format,
            width,
            height,
            layers: 1,
            mip_levels: 1,
            usage,
            array: false,
        }
    }
}

/// A 2D (array) image, a view of all of it, and one view per mip level and
/// per array layer (used as attachments and storage targets).
pub struct Image {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::Image,
    allocation: Option<Allocation>,
    /// Its place in memory other phases' resources share (none: its own).
    pub(crate) shared: Option<SharedUse>,
    /// How it was created.
    pub desc: ImageDesc,
    /// A view of all layers and mips (2D, or 2D array when `layers > 1`).
    pub view: vk::ImageView,
    /// One 2D view per mip level (all layers), for storage writes per level.
    pub mip_views: Vec<vk::ImageView>,
    /// One 2D view per array layer (mip 0), for rendering into a layer.
    pub layer_views: Vec<vk::ImageView>,
    pub(crate) state: Cell<ResourceState>,
    /// Its debug name (`gbuffer.normal`, ...).
    name: String,
    /// False for a host's image: its handle and view are never destroyed here.
    owned: bool,
}

/// The aspects a barrier on an image of `format` names: both of a combined
/// depth-stencil format (valid without separate depth-stencil layouts).
fn aspect_of(format: vk::Format) -> vk::ImageAspectFlags {
    match format {
        vk::Format::D32_SFLOAT | vk::Format::D16_UNORM | vk::Format::X8_D24_UNORM_PACK32 => {
            vk::ImageAspectFlags::DEPTH
        }
        vk::Format::D16_UNORM_S8_UINT
        | vk::Format::D24_UNORM_S8_UINT
        | vk::Format::D32_SFLOAT_S8_UINT => {
            vk::ImageAspectFlags::DEPTH | vk::ImageAspectFlags::STENCIL
        }
        _ => vk::ImageAspectFlags::COLOR,
    }
}

impl Image {
    /// The debug name it was created with.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Wraps a host engine's 2D image and view (never destroyed by ssbc) so
    /// passes can record barriers for it. `layout` is its layout when the
    /// commands ssbc records start; its last write is taken to be any
    /// command's, so the first barrier waits for whatever the host did.
    pub fn from_host(
        device: &Arc<Device>,
        raw: vk::Image,
        view: vk::ImageView,
        desc: ImageDesc,
        layout: vk::ImageLayout,
    ) -> Self {
        Self {
            device: device.clone(),
            raw,
            allocation: None,
            shared: None,
            desc,
            view,
            mip_views: Vec::new(),
            layer_views: Vec::new(),
            state: Cell::new(ResourceState {
                layout,
                last_write: Some((
                    vk::PipelineStageFlags2::ALL_COMMANDS,
                    vk::AccessFlags2::MEMORY_WRITE,
                )),
                visible_stages: vk::PipelineStageFlags2::empty(),
                visible_access: vk::AccessFlags2::empty(),
            }),
            name: "host image".into(),
            owned: false,
        }
    }

    /// Creates the image in device memory of its own, with its views.
    pub fn new(device: &Arc<Device>, name: &str, desc: ImageDesc) -> Result<Self> {
        let raw = Self::create_raw(device, name, &desc)?;
        // SAFETY: created above from this device.
        let requirements = unsafe { device.raw.get_image_memory_requirements(raw) };
        let allocation = match device.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        }) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: never bound or used.
                unsafe { device.raw.destroy_image(raw, None) };
                return Err(e.into());
            }
        };
        // SAFETY: the handle is only bound to this image; the allocation
        // is freed after the image is destroyed.
        let (memory, offset) = (unsafe { allocation.memory() }, allocation.offset());
        let mut image = Self::unbound(device, name, raw, desc);
        image.allocation = Some(allocation);
        image.bind(memory, offset)?;
        Ok(image)
    }

    /// Creates the image in `region` of memory other phases' resources
    /// share (see [`AliasedMemory`](super::AliasedMemory)), with its views.
    pub fn new_aliased(
        device: &Arc<Device>,
        name: &str,
        desc: ImageDesc,
        region: &mut AliasRegion,
    ) -> Result<Self> {
        let raw = Self::create_raw(device, name, &desc)?;
        // SAFETY: created above from this device.
        let requirements = unsafe { device.raw.get_image_memory_requirements(raw) };
        let (memory, offset, shared) = match region.place(name, requirements) {
            Ok(p) => p,
            Err(e) => {
                // SAFETY: never bound or used.
                unsafe { device.raw.destroy_image(raw, None) };
                return Err(e);
            }
        };
        let mut image = Self::unbound(device, name, raw, desc);
        image.shared = Some(shared);
        image.bind(memory, offset)?;
        Ok(image)
    }

    /// Creates the image handle, its size checked against the device's
    /// limits.
    fn create_raw(device: &Arc<Device>, name: &str, desc: &ImageDesc) -> Result<vk::Image> {
        let limits = device.limits();
        if desc.width == 0 || desc.height == 0 {
            return Err(Error::InvalidParameter(format!(
                "image '{name}' has a zero size"
            )));
        }
        if desc.width > limits.max_image_dimension2_d || desc.height > limits.max_image_dimension2_d
        {
            return Err(Error::InvalidParameter(format!(
                "image '{name}' of {}x{} exceeds the device limit of {} texels per side",
                desc.width, desc.height, limits.max_image_dimension2_d
            )));
        }
        if desc.layers > limits.max_image_array_layers {
            return Err(Error::InvalidParameter(format!(
                "image '{name}' needs {} layers, the device allows {}",
                desc.layers, limits.max_image_array_layers
            )));
        }
        let info = desc.create_info();
        // SAFETY: valid create info; sizes checked against the limits.
        unsafe { device.raw.create_image(&info, None) }.map_err(|result| match result {
            vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY => {
                Error::InvalidParameter(format!(
                    "image '{name}' ({}x{}x{}) does not fit in memory",
                    desc.width, desc.height, desc.layers
                ))
            }
            result => Error::Vulkan {
                call: "vkCreateImage",
                result,
            },
        })
    }

    /// The wrapper of a created, unbound image (its drop destroys it).
    fn unbound(device: &Arc<Device>, name: &str, raw: vk::Image, desc: ImageDesc) -> Self {
        Self {
            device: device.clone(),
            raw,
            allocation: None,
            shared: None,
            desc,
            view: vk::ImageView::null(),
            mip_views: Vec::new(),
            layer_views: Vec::new(),
            state: Cell::new(ResourceState::default()),
            name: name.to_string(),
            owned: true,
        }
    }

    /// Binds the image to `memory` at `offset` and makes its views.
    fn bind(&mut self, memory: vk::DeviceMemory, offset: u64) -> Result<()> {
        let (device, name, desc) = (self.device.clone(), self.name.clone(), self.desc);
        // SAFETY: memory placed for this image's requirements.
        unsafe { device.raw.bind_image_memory(self.raw, memory, offset) }
            .vk("vkBindImageMemory")?;
        let array = desc.layers > 1 || desc.array;
        self.view = self.create_view(0, desc.mip_levels, 0, desc.layers, array)?;
        device.set_name(self.raw, &name);
        device.count_resource();
        device.set_name(self.view, &format!("{name} view"));
        if desc.mip_levels > 1 {
            for level in 0..desc.mip_levels {
                let v = self.create_view(level, 1, 0, desc.layers, array)?;
                device.set_name(v, &format!("{name} mip {level}"));
                self.mip_views.push(v);
            }
        }
        if array {
            for layer in 0..desc.layers {
                let v = self.create_view(0, 1, layer, 1, false)?;
                device.set_name(v, &format!("{name} layer {layer}"));
                self.layer_views.push(v);
            }
        }
        Ok(())
    }

    fn create_view(
        &self,
        base_mip: u32,
        mips: u32,
        base_layer: u32,
        layers: u32,
        array: bool,
    ) -> Result<vk::ImageView> {
        let info = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(if array {
                vk::ImageViewType::TYPE_2D_ARRAY
            } else {
                vk::ImageViewType::TYPE_2D
            })
            .format(self.desc.format)
            .subresource_range(vk::ImageSubresourceRange {
                aspect_mask: aspect_of(self.desc.format),
                base_mip_level: base_mip,
                level_count: mips,
                base_array_layer: base_layer,
                layer_count: layers,
            });
        // SAFETY: the range lies inside the image.
        unsafe { self.device.raw.create_image_view(&info, None) }.vk("vkCreateImageView")
    }

    /// The range covering every mip and layer.
    pub fn full_range(&self) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange {
            aspect_mask: aspect_of(self.desc.format),
            base_mip_level: 0,
            level_count: self.desc.mip_levels,
            base_array_layer: 0,
            layer_count: self.desc.layers,
        }
    }

    /// Extent of mip `level`.
    pub fn mip_extent(&self, level: u32) -> (u32, u32) {
        (
            (self.desc.width >> level).max(1),
            (self.desc.height >> level).max(1),
        )
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        if !self.owned {
            return;
        }
        let views = std::iter::once(self.view)
            .chain(self.mip_views.drain(..))
            .chain(self.layer_views.drain(..));
        for v in views.filter(|v| *v != vk::ImageView::null()) {
            self.device.defer_destroy(Garbage::ImageView(v));
        }
        // Its own memory is freed with it; aliased memory after its last
        // resource (queued when `shared` drops, after this).
        self.device
            .defer_destroy(Garbage::Image(self.raw, self.allocation.take()));
    }
}

/// A sampler, destroyed with deferral.
pub struct Sampler {
    device: Arc<Device>,
    /// The raw handle.
    pub raw: vk::Sampler,
}

impl Sampler {
    /// Creates a sampler with the given filter and addressing.
    pub fn new(
        device: &Arc<Device>,
        filter: vk::Filter,
        address: vk::SamplerAddressMode,
    ) -> Result<Self> {
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(filter)
            .min_filter(filter)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .max_lod(vk::LOD_CLAMP_NONE);
        // SAFETY: valid create info.
        let raw = unsafe { device.raw.create_sampler(&info, None) }.vk("vkCreateSampler")?;
        Ok(Self {
            device: device.clone(),
            raw,
        })
    }

    /// Names the sampler (see [`Device::set_name`]).
    pub fn named(self, name: &str) -> Self {
        self.device.set_name(self.raw, name);
        self
    }
}

impl Drop for Sampler {
    fn drop(&mut self) {
        self.device.defer_destroy(Garbage::Sampler(self.raw));
    }
}

/// One of the host's images: handle, a 2D view of it, its size and the
/// layout it will be in when the recorded commands start.
#[derive(Clone, Copy, Debug)]
pub struct HostImage {
    /// The image (owned by the host).
    pub image: vk::Image,
    /// A 2D view of its only mip and layer (owned by the host).
    pub view: vk::ImageView,
    /// Its format (which ones each use accepts: the tables in
    /// `ssbc::postprocess`).
    pub format: vk::Format,
    /// Width and height.
    pub extent: (u32, u32),
    /// Its layout when the commands ssbc records begin.
    pub layout: vk::ImageLayout,
}
