//! Bounded VPL lighting `T_b L^` (clamped geometry term, ISM visibility), and
//! `S0 = T Le + T_b L^`, the term the SSBC steps start from.

use std::sync::Arc;

use ash::vk;

use super::gbuffer::GBuffer;
use super::ism::Ism;
use super::{Pass, Recording, SlotSetup};
use crate::error::Result;
use crate::shaders;
use crate::vk::{
    Access, Binding, ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image,
};

/// Relative depth tolerance of the ISM visibility test.
pub const ISM_BIAS: f32 = 0.05;

/// What the pass writes.
pub struct BoundedLighting {
    /// `T_b L^`, the `indirect_bounded` layer.
    pub indirect: Image,
    /// `S0 = T Le + T_b L^`, what the SSBC steps start from.
    pub s0: Image,
}

/// The bounded-indirect compute kernel.
pub struct IndirectBoundedPass {
    kernel: ComputeKernel,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Push {
    size: [u32; 2],
    vpl_count: u32,
    tile: u32,
    tiles_per_row: u32,
    far: f32,
    bound: f32,
    ism_bias: f32,
    point_radius: f32,
}

impl IndirectBoundedPass {
    /// Creates the kernel.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        use vk::DescriptorType as T;
        // G-buffer (3), direct, indirect_bounded (out), s0 (out), VPLs, ISM.
        let mut bindings = vec![T::STORAGE_IMAGE; 6];
        bindings.extend([T::STORAGE_BUFFER, T::STORAGE_IMAGE]);
        let kernel = ComputeKernel::new(
            device,
            shaders::INDIRECT_BOUNDED_COMP,
            &bindings,
            std::mem::size_of::<Push>(),
        )?
        .named("indirect_bounded");
        Ok(Self { kernel })
    }
}

impl Pass for IndirectBoundedPass {
    const NAME: &'static str = "indirect_bounded";
    /// Width and height.
    type Key = (u32, u32);
    type Resources = BoundedLighting;
    /// The G-buffer, the `direct` layer, the ISM atlas and its VPLs.
    type Reads<'a> = (&'a GBuffer, &'a Image, &'a Ism);

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.extent()
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<BoundedLighting> {
        let image = |name| super::radiance_image(setup.device, name, setup.extent());
        Ok(BoundedLighting {
            indirect: image("lighting.indirect_bounded")?,
            s0: image("ssbc.s0")?,
        })
    }

    fn set_layouts(&self, _: &BoundedLighting) -> Vec<&DescriptorSetLayout> {
        vec![self.kernel.set_layout()]
    }

    /// Writes `indirect_bounded` and `s0 = direct + indirect_bounded`.
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (gbuffer, direct, ism): (&GBuffer, &Image, &Ism),
        out: &BoundedLighting,
    ) -> Result<()> {
        let Recording {
            rec,
            profiler,
            view,
            ..
        } = cx;
        let (indirect_bounded, s0) = (&out.indirect, &out.s0);
        let scope = profiler.begin(rec.cmd, "indirect_bounded");
        for input in [
            &gbuffer.position,
            &gbuffer.normal,
            &gbuffer.albedo,
            direct,
            &ism.pyramid,
        ] {
            rec.use_image(input, Access::ComputeRead);
        }
        rec.use_buffer(&ism.vpls, Access::ComputeRead);
        rec.use_image(indirect_bounded, Access::ComputeWrite);
        rec.use_image(s0, Access::ComputeWrite);
        rec.flush_barriers();
        let (w, h) = gbuffer.extent();
        let push = Push {
            size: [w, h],
            vpl_count: ism.vpl_count,
            tile: ism.tile,
            tiles_per_row: ism.tiles_per_row,
            far: ism.far,
            bound: view.bound,
            ism_bias: ISM_BIAS,
            point_radius: ism.point_radius,
        };
        let [position, normal, albedo] = gbuffer.storage_bindings();
        let bindings = [
            position,
            normal,
            albedo,
            Binding::storage(direct),
            Binding::storage(indirect_bounded),
            Binding::storage(s0),
            Binding::StorageBuffer(&ism.vpls),
            Binding::StorageImage(ism.pyramid.mip_views[0]),
        ];
        self.kernel
            .dispatch_2d(rec.cmd, pool, &bindings, bytemuck::bytes_of(&push), (w, h))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
