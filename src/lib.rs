//! # ssbc — Screen-Space Bias Compensation on explicit Vulkan
//!
//! A reference implementation of Novák, Engelhardt and Dachsbacher's
//! "Screen-Space Bias Compensation for Interactive High-Quality Global
//! Illumination with Virtual Point Lights" (I3D 2011) on `ash`.
//!
//! Start with [`renderer::Renderer`]: create it with a
//! [`renderer::RendererConfig`], load a [`scene::Scene`] and call
//! [`renderer::Renderer::render`].
#![warn(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod compare;
pub mod cpu;
pub mod error;
pub mod gpu_scene;
pub mod gpu_types;
pub mod output;
pub mod passes;
pub mod renderer;
pub mod scene;
pub mod viewer;
pub mod vk;

/// SPIR-V of every shader, compiled by `build.rs`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

pub use error::{Error, Result};
pub use renderer::{Frame, GpuImage, Layer, RenderSettings, Renderer, RendererConfig, Timings};
pub use scene::Scene;
