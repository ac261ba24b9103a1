//! Shaders as `build.rs` compiled and reflected them: SPIR-V, bindings
//! with how the shader accesses each, push-block size, workgroup size; and
//! their shader modules.

use ash::vk;

use super::barrier::Access;
use super::device::Device;
use crate::error::{Error, Result, VkResultExt};

/// A shader as `build.rs` compiled and reflected it
/// (`crate::shaders::<file>::SHADER`).
#[derive(Clone, Copy, Debug)]
pub struct Shader {
    /// Its file in `shaders/`.
    pub name: &'static str,
    /// SPIR-V (entry point `main`).
    pub spirv: &'static [u8],
    /// Its descriptor bindings in set 0 (those the optimised SPIR-V still
    /// uses).
    pub bindings: &'static [BindingInfo],
    /// Bytes of its push-constant block (0: none).
    pub push_bytes: u32,
    /// Its local workgroup size (compute; `[1, 1, 1]` for other stages).
    pub local_size: [u32; 3],
}

/// One reflected binding of a shader.
#[derive(Clone, Copy, Debug)]
pub struct BindingInfo {
    /// Binding number in set 0.
    pub number: u32,
    /// Descriptor type.
    pub ty: vk::DescriptorType,
    /// Name in the GLSL.
    pub name: &'static str,
    /// How the shader accesses it.
    pub access: BindingAccess,
}

/// How a shader accesses a binding, from its SPIR-V decorations
/// (`readonly`: `NonWritable`; `writeonly`: `NonReadable`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingAccess {
    /// A storage image or buffer read only.
    Read,
    /// A storage image or buffer written only.
    Write,
    /// A storage image or buffer read and written.
    ReadWrite,
    /// A sampled image or texel buffer.
    Sampled,
    /// An acceleration structure traced by ray queries.
    RayQuery,
}

impl BindingAccess {
    /// The barrier tracker's access from a compute shader.
    pub fn in_compute(self) -> Access {
        match self {
            BindingAccess::Read => Access::ComputeRead,
            BindingAccess::Write | BindingAccess::ReadWrite => Access::ComputeWrite,
            BindingAccess::Sampled => Access::ComputeSampled,
            BindingAccess::RayQuery => Access::ComputeRayQuery,
        }
    }

    /// The barrier tracker's access from a vertex or fragment shader (which
    /// only read in ssbc).
    pub fn in_graphics(self) -> Access {
        match self {
            BindingAccess::Sampled => Access::FragmentSampled,
            _ => Access::GraphicsStorageRead,
        }
    }
}

pub(super) fn shader_module(device: &Device, spirv: &[u8]) -> Result<vk::ShaderModule> {
    // Embedded SPIR-V comes from build.rs; a failure here is a build bug.
    let code =
        ash::util::read_spv(&mut std::io::Cursor::new(spirv)).map_err(|_| Error::Vulkan {
            call: "read_spv (embedded SPIR-V is malformed)",
            result: vk::Result::ERROR_INITIALIZATION_FAILED,
        })?;
    let info = vk::ShaderModuleCreateInfo::default().code(&code);
    // SAFETY: SPIR-V produced by build.rs from our own shaders.
    unsafe { device.raw.create_shader_module(&info, None) }.vk("vkCreateShaderModule")
}
