//! CPU-side light transport, no Vulkan: ray casting against a BVH, VPL
//! distribution by light tracing, scene point sampling for imperfect shadow
//! maps, materials (textures, alpha masks, emission, normal maps), emitters,
//! and low-discrepancy sampling.

pub mod brdf;
pub mod bvh;
pub mod default_light;
pub mod emitters;
pub mod enclosure;
pub mod ism_rays;
pub mod point_discs;
pub mod points;
pub mod reference;
pub mod sampling;
pub mod shading;
pub mod ssbc;
pub mod vpl;
