//! A thin, explicit Vulkan layer on `ash`: one file per Vulkan concept.
//!
//! Invariants every `unsafe` block here relies on, stated once:
//! - handles are created from the [`Device`] they are used and destroyed with,
//!   and every wrapper holds an `Arc<Device>` so the device outlives them;
//! - destruction is deferred (see `device.rs`) until the GPU is done with the
//!   handle;
//! - command recording happens on one thread at a time per command pool.

pub mod barrier;
pub mod buffer;
pub mod buffer_view;
pub mod commands;
pub mod descriptor;
pub mod device;
pub mod image;
pub mod instance;
pub mod pipeline;
pub mod profiler;
pub mod swapchain;

pub use barrier::Access;
pub use buffer::Buffer;
pub use buffer_view::BufferView;
pub use commands::{CommandPool, Recorder, TrackedImage};
pub use descriptor::{Binding, DescriptorPool, DescriptorSetLayout};
pub use device::{Device, DeviceSelector, HostDevice, ProfilingSupport, RequiredFeatures};
pub use image::{Image, ImageDesc, Sampler};
pub use instance::{Instance, Validation, ValidationLog};
pub use pipeline::{ComputeKernel, GraphicsDesc, Pipeline};
pub use profiler::{GpuFrameTimes, GpuProfiler, PassTiming};
pub use swapchain::{BinarySemaphore, Swapchain, SwapchainImage};
