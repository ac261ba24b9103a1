//! A thin, explicit Vulkan layer on `ash`: one file per Vulkan concept.
//!
//! Invariants every `unsafe` block here relies on, stated once:
//! - handles are created from the [`Device`] they are used and destroyed with,
//!   and every wrapper holds an `Arc<Device>` so the device outlives them;
//! - destruction is deferred (see `device.rs`) until the GPU is done with the
//!   handle;
//! - command recording happens on one thread at a time per command pool.
//!
//! What a host uses is public: [`Instance`] and [`Device`] (made by ssbc, or
//! wrapping the host's own with `from_host`), [`HostDevice`],
//! [`RequiredFeatures`], [`DeviceSelector`], [`Validation`] and
//! [`ValidationLog`], and the GPU timings of a frame ([`GpuFrameTimes`],
//! [`PassTiming`]). The rest (buffers, images, descriptors, pipelines,
//! command recording, barriers, the profiler) is the renderer's own and
//! public only with the `unstable` feature.
//!
//! ```no_run
//! # fn main() -> ssbc::Result<()> {
//! use ssbc::vk::{Device, DeviceSelector, Instance, Validation};
//! let instance = Instance::with_validation(Validation::Synchronization, &[])?;
//! let device = Device::new(instance, &DeviceSelector::default(), &[])?;
//! println!("{}", device.name());
//! let mut renderer = ssbc::Renderer::with_device(device)?;
//! # Ok(()) }
//! ```

mod device;
mod driver_libraries;
mod instance;
unstable_pub! {
    mod acceleration;
    mod aliasing;
    mod barrier;
    mod buffer;
    mod buffer_view;
    mod commands;
    mod descriptor;
    mod image;
    mod pipeline;
    mod profiler;
    mod rendering;
    mod shader;
}

pub use self::image::HostImage;
pub use device::{
    Device, DeviceSelector, HostDevice, ProfilingSupport, RayQueries, RequiredFeatures,
};
pub use instance::{Instance, Validation, ValidationLog};
pub use profiler::{GpuFrameTimes, PassTiming};
unstable_pub! {
    use self::acceleration::{AccelerationStructure, TriangleRange};
    use self::aliasing::{AliasPlan, AliasRegion, AliasedMemory, Planned, Tenant};
    use self::barrier::Access;
    use self::buffer::{buffer_bytes, Buffer};
    use self::buffer_view::BufferView;
    use self::commands::{CommandPool, Recorder, TrackedImage};
    use self::descriptor::{Binding, DescriptorPool, DescriptorSetLayout, Tracked};
    use self::image::{Image, ImageDesc, Sampler};
    use self::pipeline::{
        declare_bindings, push_size, ComputeKernel, GraphicsDesc, Pipeline, ShaderBindings,
        ShaderInterface, Work,
    };
    use self::shader::{BindingAccess, BindingInfo, Shader};
    use self::profiler::GpuProfiler;
    use self::rendering::RenderTargets;
}
