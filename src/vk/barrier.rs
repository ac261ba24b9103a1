//! Barriers derived from tracked access, never guessed.
//!
//! Every buffer and image remembers a `ResourceState`: its layout, its last
//! write, and which stages have been made to see that write. Asking for the
//! next [`Access`] yields the one barrier needed (or none) and the new state.
//! This is pure code, tested without a GPU.

use ash::vk;

/// The ways a pass can use a resource. Each maps to one stage, access mask and
/// (for images) layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Access {
    /// Written by a copy or clear.
    TransferWrite,
    /// Read by a copy.
    TransferRead,
    /// Read by the host after the GPU finishes (readback).
    HostRead,
    /// Vertex or index fetch.
    VertexInput,
    /// Colour attachment written by a render pass.
    ColorAttachmentWrite,
    /// Depth attachment tested and written.
    DepthAttachmentWrite,
    /// Sampled (texture) read from a fragment shader.
    FragmentSampled,
    /// Storage buffer or image read from a vertex or fragment shader.
    GraphicsStorageRead,
    /// Sampled (texture) read from a compute shader.
    ComputeSampled,
    /// Storage image or buffer read from a compute shader.
    ComputeRead,
    /// Storage image or buffer written (and possibly read) by a compute shader.
    ComputeWrite,
    /// Arguments of an indirect dispatch or draw.
    IndirectRead,
    /// Geometry or instances an acceleration-structure build reads.
    AccelerationStructureInput,
    /// An acceleration structure (or its scratch) a build writes.
    AccelerationStructureBuild,
    /// A bottom-level structure a top-level build reads.
    AccelerationStructureBuildRead,
    /// An acceleration structure a compute shader's ray queries read.
    ComputeRayQuery,
    /// Handed to the presentation engine.
    Present,
}

/// Stage, access mask and image layout of an [`Access`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct AccessInfo {
    /// Pipeline stage(s) of the access.
    pub stage: vk::PipelineStageFlags2,
    /// Memory access mask.
    pub access: vk::AccessFlags2,
    /// Image layout the access needs (ignored for buffers).
    pub layout: vk::ImageLayout,
    /// Whether the access writes.
    pub writes: bool,
}

impl Access {
    /// The stage, access mask and layout of this access (`wgpu-hal`'s `conv`
    /// style: a pure mapping, nothing else).
    pub fn info(self) -> AccessInfo {
        use vk::AccessFlags2 as A;
        use vk::ImageLayout as L;
        use vk::PipelineStageFlags2 as S;
        let (stage, access, layout, writes) = match self {
            Access::TransferWrite => (
                S::TRANSFER,
                A::TRANSFER_WRITE,
                L::TRANSFER_DST_OPTIMAL,
                true,
            ),
            Access::TransferRead => (
                S::TRANSFER,
                A::TRANSFER_READ,
                L::TRANSFER_SRC_OPTIMAL,
                false,
            ),
            Access::HostRead => (S::HOST, A::HOST_READ, L::GENERAL, false),
            Access::VertexInput => (
                S::VERTEX_INPUT,
                A::VERTEX_ATTRIBUTE_READ | A::INDEX_READ,
                L::UNDEFINED,
                false,
            ),
            Access::ColorAttachmentWrite => (
                S::COLOR_ATTACHMENT_OUTPUT,
                A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
                L::COLOR_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::DepthAttachmentWrite => (
                S::EARLY_FRAGMENT_TESTS | S::LATE_FRAGMENT_TESTS,
                A::DEPTH_STENCIL_ATTACHMENT_WRITE | A::DEPTH_STENCIL_ATTACHMENT_READ,
                L::DEPTH_ATTACHMENT_OPTIMAL,
                true,
            ),
            Access::FragmentSampled => (
                S::FRAGMENT_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
                false,
            ),
            Access::GraphicsStorageRead => (
                S::VERTEX_SHADER | S::FRAGMENT_SHADER,
                A::SHADER_STORAGE_READ,
                L::GENERAL,
                false,
            ),
            Access::ComputeSampled => (
                S::COMPUTE_SHADER,
                A::SHADER_SAMPLED_READ,
                L::SHADER_READ_ONLY_OPTIMAL,
                false,
            ),
            Access::ComputeRead => (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, L::GENERAL, false),
            Access::ComputeWrite => (
                S::COMPUTE_SHADER,
                A::SHADER_STORAGE_WRITE | A::SHADER_STORAGE_READ,
                L::GENERAL,
                true,
            ),
            Access::IndirectRead => (
                S::DRAW_INDIRECT,
                A::INDIRECT_COMMAND_READ,
                L::UNDEFINED,
                false,
            ),
            Access::AccelerationStructureInput => (
                S::ACCELERATION_STRUCTURE_BUILD_KHR,
                A::SHADER_READ,
                L::UNDEFINED,
                false,
            ),
            Access::AccelerationStructureBuild => (
                S::ACCELERATION_STRUCTURE_BUILD_KHR,
                A::ACCELERATION_STRUCTURE_WRITE_KHR | A::ACCELERATION_STRUCTURE_READ_KHR,
                L::UNDEFINED,
                true,
            ),
            Access::AccelerationStructureBuildRead => (
                S::ACCELERATION_STRUCTURE_BUILD_KHR,
                A::ACCELERATION_STRUCTURE_READ_KHR,
                L::UNDEFINED,
                false,
            ),
            Access::ComputeRayQuery => (
                S::COMPUTE_SHADER,
                A::ACCELERATION_STRUCTURE_READ_KHR,
                L::UNDEFINED,
                false,
            ),
            Access::Present => (S::NONE, A::NONE, L::PRESENT_SRC_KHR, false),
        };
        AccessInfo {
            stage,
            access,
            layout,
            writes,
        }
    }
}

/// What a resource has been through since its last write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResourceState {
    /// Current image layout (UNDEFINED for new images and for buffers).
    pub layout: vk::ImageLayout,
    /// Stage and access of the last write, if any since creation.
    pub last_write: Option<(vk::PipelineStageFlags2, vk::AccessFlags2)>,
    /// Stages already synchronised with the last write (or layout change).
    pub visible_stages: vk::PipelineStageFlags2,
    /// Access types already made visible to `visible_stages`.
    pub visible_access: vk::AccessFlags2,
}

impl Default for ResourceState {
    fn default() -> Self {
        Self {
            layout: vk::ImageLayout::UNDEFINED,
            last_write: None,
            visible_stages: vk::PipelineStageFlags2::NONE,
            visible_access: vk::AccessFlags2::NONE,
        }
    }
}

/// One barrier: source and destination scopes and a layout change.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Barrier {
    /// Stages that must finish first.
    pub src_stage: vk::PipelineStageFlags2,
    /// Writes to make available.
    pub src_access: vk::AccessFlags2,
    /// Stages that wait.
    pub dst_stage: vk::PipelineStageFlags2,
    /// Accesses the writes are made visible to.
    pub dst_access: vk::AccessFlags2,
    /// Layout before.
    pub old_layout: vk::ImageLayout,
    /// Layout after.
    pub new_layout: vk::ImageLayout,
}

/// The barrier needed before `next` given the resource's `state` (None when
/// the access is already ordered and visible), and the state after it.
/// `is_image` decides whether layouts matter.
pub fn transition(
    state: ResourceState,
    next: Access,
    is_image: bool,
) -> (Option<Barrier>, ResourceState) {
    let info = next.info();
    let new_layout = if is_image {
        info.layout
    } else {
        vk::ImageLayout::UNDEFINED
    };
    let layout_change = is_image && new_layout != state.layout;
    let (write_stage, write_access) = state
        .last_write
        .unwrap_or((vk::PipelineStageFlags2::NONE, vk::AccessFlags2::NONE));

    if info.writes || layout_change {
        // Writes (and layout transitions, which are writes) wait for the last
        // write and every read since (write-after-read is an execution hazard).
        let barrier = Barrier {
            src_stage: write_stage | state.visible_stages,
            src_access: write_access,
            dst_stage: info.stage,
            dst_access: info.access,
            old_layout: if is_image {
                state.layout
            } else {
                vk::ImageLayout::UNDEFINED
            },
            new_layout,
        };
        let needed =
            layout_change || state.last_write.is_some() || !state.visible_stages.is_empty();
        let after = if info.writes {
            ResourceState {
                layout: new_layout,
                last_write: Some((info.stage, info.access)),
                visible_stages: vk::PipelineStageFlags2::NONE,
                visible_access: vk::AccessFlags2::NONE,
            }
        } else {
            ResourceState {
                layout: new_layout,
                last_write: state.last_write,
                visible_stages: info.stage,
                visible_access: info.access,
            }
        };
        return (needed.then_some(barrier), after);
    }

    // A read in the current layout: needed only if this stage has not yet been
    // made to see the last write.
    let covered =
        state.visible_stages.contains(info.stage) && state.visible_access.contains(info.access);
    if state.last_write.is_none() || covered {
        let mut after = state;
        if state.last_write.is_none() {
            after.visible_stages |= info.stage;
            after.visible_access |= info.access;
        }
        return (None, after);
    }
    let barrier = Barrier {
        // Chain through the earlier readers too: they ordered any layout change.
        src_stage: write_stage | state.visible_stages,
        src_access: write_access,
        dst_stage: info.stage,
        dst_access: info.access,
        old_layout: state.layout,
        new_layout: state.layout,
    };
    let after = ResourceState {
        visible_stages: state.visible_stages | info.stage,
        visible_access: state.visible_access | info.access,
        ..state
    };
    (Some(barrier), after)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_then_read_needs_one_barrier_then_none() {
        let s = ResourceState::default();
        let (b, s) = transition(s, Access::ComputeWrite, true);
        let b = b.expect("first write changes the layout");
        assert_eq!(b.old_layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(b.new_layout, vk::ImageLayout::GENERAL);
        let (b, s) = transition(s, Access::ComputeRead, true);
        let b = b.expect("read after write");
        assert_eq!(
            b.src_access,
            vk::AccessFlags2::SHADER_STORAGE_WRITE | vk::AccessFlags2::SHADER_STORAGE_READ
        );
        assert_eq!(b.dst_stage, vk::PipelineStageFlags2::COMPUTE_SHADER);
        let (b, _) = transition(s, Access::ComputeRead, true);
        assert!(
            b.is_none(),
            "second read in the same stage is already visible"
        );
    }

    #[test]
    fn read_in_new_stage_chains_from_the_write() {
        let (_, s) = transition(ResourceState::default(), Access::ColorAttachmentWrite, true);
        let (b, s) = transition(s, Access::ComputeSampled, true);
        let b = b.unwrap();
        assert_eq!(b.old_layout, vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL);
        assert_eq!(b.new_layout, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
        let (b, _) = transition(s, Access::FragmentSampled, true);
        let b = b.expect("fragment stage has not seen the write yet");
        assert!(b
            .src_stage
            .contains(vk::PipelineStageFlags2::COLOR_ATTACHMENT_OUTPUT));
        assert!(b
            .src_stage
            .contains(vk::PipelineStageFlags2::COMPUTE_SHADER));
        assert_eq!(b.old_layout, b.new_layout);
    }

    #[test]
    fn write_after_read_waits_for_the_readers() {
        let (_, s) = transition(ResourceState::default(), Access::ComputeWrite, false);
        let (_, s) = transition(s, Access::ComputeRead, false);
        let (b, _) = transition(s, Access::TransferWrite, false);
        let b = b.unwrap();
        assert!(b
            .src_stage
            .contains(vk::PipelineStageFlags2::COMPUTE_SHADER));
        assert_eq!(b.dst_stage, vk::PipelineStageFlags2::TRANSFER);
    }

    #[test]
    fn host_written_buffer_needs_no_barrier_for_first_read() {
        let (b, _) = transition(ResourceState::default(), Access::ComputeRead, false);
        assert!(b.is_none(), "queue submission orders host writes");
    }
}
