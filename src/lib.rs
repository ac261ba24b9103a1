//! # ssbc — Screen-Space Bias Compensation on explicit Vulkan
//!
//! A reference implementation of Novák, Engelhardt and Dachsbacher's
//! "Screen-Space Bias Compensation for Interactive High-Quality Global
//! Illumination with Virtual Point Lights" (I3D 2011) on `ash`.
//!
//! Start with [`Renderer`]: create it with a [`RendererConfig`], load a
//! [`Scene`] and call [`Renderer::render`]:
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
//! // The same mesh drawn again, 2 m to the right: stored once.
//! let mesh = scene.objects()[0].mesh;
//! scene.add_object(ssbc::scene::Object::new(mesh, Mat4::from_translation(Vec3::X * 2.0))).unwrap();
//! assert_eq!((scene.meshes().len(), scene.triangle_count()), (1, 4));
//! ```
//!
//! ## What is public
//!
//! The API above: [`Renderer`] and its settings, [`Frame`] and its typed
//! [`Layer`]s, [`GpuImage`], [`resident::ResidentScene`], SSBC alone as
//! [`postprocess::SsbcPostProcess`], the [`scene`] model and glTF loading,
//! [`timings`] and [`profile`], [`Error`], the CPU [`reference`](mod@reference) renderer,
//! image [`compare`]ison and [`output`], and the host-device types of
//! [`vk`]. The renderer's internals (its passes, Vulkan layer, CPU stages and
//! GPU structs) are public only with the `unstable` feature, for ssbc's own
//! binary, tests, benches and examples; they may change in any release.
#![warn(unsafe_op_in_unsafe_fn)]
#![warn(missing_docs)]

/// Declares items `pub` with the `unstable` feature and `pub(crate)`
/// without it: the renderer's internals, reachable by ssbc's own binary,
/// tests, benches and examples, never part of the supported API. Takes one
/// item, or a list of `mod name;` and `use path;` items.
macro_rules! unstable_pub {
    ($(#[$meta:meta])* mod $name:ident; $($rest:tt)+) => {
        unstable_pub! { $(#[$meta])* mod $name; }
        unstable_pub! { $($rest)+ }
    };
    ($(#[$meta:meta])* use $head:tt $(:: $segment:tt)*; $($rest:tt)+) => {
        unstable_pub! { $(#[$meta])* use $head $(:: $segment)*; }
        unstable_pub! { $($rest)+ }
    };
    ($(#[$meta:meta])* $kw:ident $($rest:tt)*) => {
        #[cfg(feature = "unstable")]
        $(#[$meta])*
        pub $kw $($rest)*
        #[cfg(not(feature = "unstable"))]
        $(#[$meta])*
        #[allow(dead_code, unused_imports)]
        pub(crate) $kw $($rest)*
    };
}

/// The README's Rust examples, compiled as doc-tests so that they keep
/// matching the API.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;

/// docs/embedding.md's Rust examples, compiled as doc-tests.
#[cfg(doctest)]
#[doc = include_str!("../docs/embedding.md")]
pub struct EmbeddingDoctests;

pub mod compare;
pub mod error;
mod layer;
pub mod memory;
pub mod output;
pub mod postprocess;
pub mod profile;
pub mod renderer;
pub mod resident;
pub mod scene;
pub mod sequence;
pub mod settings;
mod texture_mips;
pub mod timings;
pub mod vk;

unstable_pub! {
    mod cpu;
    mod gpu_scene;
    mod gpu_types;
    mod passes;
    mod ray_scene;
    mod scene_cache;
}
unstable_pub! {
    /// SPIR-V of every shader, compiled by `build.rs` (unstable).
    mod shaders {
        include!(concat!(env!("OUT_DIR"), "/shaders.rs"));
    }
}

/// Ground truth on the CPU: a path tracer for the same scenes, cameras and
/// light units as the GPU renderer, the VPL baselines (the clamped VPL sum
/// with exact visibility; Kollig & Keller's unbiased compensation), and a
/// CPU twin of one SSBC step by brute force on read-back G-buffers.
///
/// ```no_run
/// # fn main() -> ssbc::Result<()> {
/// use std::sync::atomic::AtomicBool;
/// use ssbc::reference::{Reference, ReferenceSettings};
/// let mut scene = ssbc::scene::load("cornell")?;
/// scene.ensure_light();
/// let settings = ReferenceSettings { width: 160, height: 120, spp: 64, ..Default::default() };
/// let reference = Reference::new(&scene, settings)?;
/// let (rgba, passes) = reference.render(&AtomicBool::new(false), |done| eprintln!("{done} passes"));
/// assert_eq!(rgba.len(), 160 * 120 * 4);
/// # Ok(()) }
/// ```
pub mod reference {
    pub use crate::cpu::reference::{Method, Reference, ReferenceSettings};
    pub use crate::cpu::ssbc::{BruteForceTwin, GBufferView, TwinCamera};
}

pub use error::{Error, Result};
pub use renderer::{Frame, GpuImage, Layer, LayerImage, Renderer};
pub use scene::Scene;
pub use settings::{HistorySettings, RenderSettings, RendererConfig, SsbcSettings};
pub use timings::Timings;
