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

unstable_pub! {
    mod barrier;
}
unstable_pub! {
    mod buffer;
}
unstable_pub! {
    mod buffer_view;
}
unstable_pub! {
    mod commands;
}
unstable_pub! {
    mod descriptor;
}
mod device;
unstable_pub! {
    mod image;
}
mod instance;
unstable_pub! {
    mod pipeline;
}
unstable_pub! {
    mod profiler;
}

pub use device::{Device, DeviceSelector, HostDevice, ProfilingSupport, RequiredFeatures};
pub use instance::{Instance, Validation, ValidationLog};
pub use profiler::{GpuFrameTimes, PassTiming};
unstable_pub! {
    use self::barrier::Access;
}
unstable_pub! {
    use self::buffer::Buffer;
}
unstable_pub! {
    use self::buffer_view::BufferView;
}
unstable_pub! {
    use self::commands::{CommandPool, Recorder, TrackedImage};
}
unstable_pub! {
    use self::descriptor::{Binding, DescriptorPool, DescriptorSetLayout};
}
unstable_pub! {
    use self::image::{Image, ImageDesc, Sampler};
}
unstable_pub! {
    use self::pipeline::{
        push_size, ComputeKernel, GraphicsDesc, Pipeline, Shader, ShaderBindings, ShaderInterface,
    };
}
unstable_pub! {
    use self::profiler::GpuProfiler;
}
