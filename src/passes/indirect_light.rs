//! Indirect light as layers of their own, made from the frame's images on
//! request (frames that hand out every output, `RenderSettings::
//! output_layers`, or a GPU frame that asks for one); otherwise nothing is
//! allocated for them:
//! - [`Layer::IndirectBounded`], `S0` less the direct light, after the
//!   bounded lighting and before SSBC sums its residuals into `S0`;
//! - [`Layer::Indirect`], the final image less the direct light, for a
//!   host that lights directly itself and adds ssbc's indirect light.

use std::sync::Arc;

use super::{Pass, Recording, SlotSetup};
use crate::error::{Error, Result};
use crate::layer::Layer;
use crate::shaders::indirect_light_comp;
use crate::vk::{ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image, ImageDesc, Work};

/// What the pass writes: its layer.
pub struct IndirectLight {
    /// The image less the direct light, alpha the image's.
    pub radiance: Image,
}

/// The one image the pass allocates at `extent` (for the memory estimate).
pub fn desc(extent: (u32, u32)) -> ImageDesc {
    super::radiance_desc(extent)
}

/// The subtraction kernel, for one of the two layers.
pub struct IndirectLightPass {
    kernel: ComputeKernel<indirect_light_comp::Interface>,
    layer: Layer,
}

impl IndirectLightPass {
    /// Creates the kernel for `layer` (`IndirectBounded` or `Indirect`).
    pub fn new(device: &Arc<Device>, layer: Layer) -> Result<Self> {
        if !matches!(layer, Layer::IndirectBounded | Layer::Indirect) {
            return Err(Error::InvalidParameter(format!(
                "internal: no indirect-light pass makes {layer}"
            )));
        }
        Ok(Self {
            kernel: ComputeKernel::new(device)?,
            layer,
        })
    }

    /// Its timestamp scope and resource name.
    fn name(&self) -> &'static str {
        match self.layer {
            Layer::IndirectBounded => "indirect_bounded_layer",
            _ => "indirect_light",
        }
    }
}

impl Pass for IndirectLightPass {
    const NAME: &'static str = "indirect_light";
    /// Width and height.
    type Key = (u32, u32);
    type Resources = IndirectLight;
    /// The image (S0, or the final image after history) and the direct
    /// light.
    type Reads<'a> = (&'a Image, &'a Image);

    fn label(&self) -> String {
        self.name().to_string()
    }

    fn key(&self, setup: &SlotSetup<'_>) -> (u32, u32) {
        setup.extent()
    }

    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<IndirectLight> {
        let name = format!("lighting.{}", self.name());
        let radiance = Image::new(setup.device, &name, desc(setup.extent()))?;
        Ok(IndirectLight { radiance })
    }

    fn layers<'r>(&self, out: &'r IndirectLight) -> Vec<(Layer, &'r Image)> {
        vec![(self.layer, &out.radiance)]
    }

    fn set_layouts(&self, _: &IndirectLight) -> Vec<&DescriptorSetLayout> {
        vec![self.kernel.set_layout()]
    }

    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (image, direct): (&Image, &Image),
        out: &IndirectLight,
    ) -> Result<()> {
        let Recording { rec, profiler, .. } = cx;
        let scope = profiler.begin(rec.cmd, self.name());
        let (w, h) = (out.radiance.desc.width, out.radiance.desc.height);
        let push = indirect_light_comp::Push { size: [w, h] };
        let bindings = indirect_light_comp::Bindings {
            image,
            direct,
            indirect: &out.radiance,
        };
        self.kernel
            .dispatch(rec, pool, &bindings, &push, Work::pixels((w, h)))?;
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}
