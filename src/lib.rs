//! # ssbc — Screen-Space Bias Compensation on explicit Vulkan
//!
//! A reference implementation of Novák, Engelhardt and Dachsbacher's
//! "Screen-Space Bias Compensation for Interactive High-Quality Global
//! Illumination with Virtual Point Lights" (I3D 2011) on `ash`.
//!
//! Start with [`renderer::Renderer`]: create it with a
//! [`renderer::RendererConfig`], load a [`scene::Scene`] and call
//! [`renderer::Renderer::render`]:
//!
//! ```no_run
//! # fn main() -> ssbc::Result<()> {
//! let mut renderer = ssbc::Renderer::new(&ssbc::RendererConfig::default())?;
//! let mut scene = ssbc::scene::load("cornell")?;
//! scene.ensure_light();
//! let mut settings = ssbc::RenderSettings::new(640, 480);
//! settings.ssbc.steps = 2; // K steps of bias compensation
//! let frame = renderer.render(&scene, &settings)?;
//! for pass in frame.timings.timed_passes() {
//!     println!("{}: {:.2} ms", pass.name, pass.gpu_ms);
//! }
//! ssbc::output::write_image(&frame, "out.exr".as_ref(), true, None)?;
//! # Ok(()) }
//! ```
//!
//! A scene can also be built from a host's own data:
//!
//! ```
//! use glam::{Mat4, Vec3};
//! let mut scene = ssbc::Scene::new("host");
//! let grey = scene.add_material(Vec3::splat(0.5), None);
//! let quad = [Vec3::new(-1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(-1.0, 0.0, -1.0)];
//! scene.add_mesh(&quad, &[], &[], &[0, 1, 2, 0, 2, 3], Mat4::IDENTITY, grey).unwrap();
//! scene.ensure_light(); // a documented default point light
//! assert_eq!(scene.triangle_count(), 2);
//! assert_eq!(scene.lights.len(), 1);
//! ```
#![warn(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

pub mod compare;
pub mod cpu;
pub mod error;
pub mod gpu_scene;
pub mod gpu_types;
pub mod output;
pub mod passes;
pub mod postprocess;
pub mod profile;
pub mod renderer;
pub mod resident;
pub mod scene;
pub mod scene_cache;
pub mod settings;
pub mod timings;
#[cfg(feature = "viewer")]
pub mod viewer;
pub mod vk;

/// SPIR-V of every shader, compiled by `build.rs`.
pub mod shaders {
    include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
}

pub use error::{Error, Result};
pub use renderer::{Frame, GpuImage, Layer, RenderSettings, Renderer, RendererConfig, Timings};
pub use scene::Scene;
