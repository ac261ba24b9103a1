//! Imperfect shadow maps (Ritschel et al. 2008): each VPL's depth tile of
//! one atlas, mapping its hemisphere by projected solid angle (`ism_map` in
//! shaders/include/ism.glsl), starts from a coarse ray-cast layer (`ism_base`, see
//! [`crate::cpu::ism_rays`]), and the VPL splats its own subset of scene
//! points into it (`ism_splat`). The layer leaves no empty texels, so there
//! is no pull-push (it filled the holes between points with the farthest of
//! their neighbours, which is where occluders near a VPL leaked); a texel
//! between two nearer texels of one plane, which no disc of that surface
//! reached, takes their plane (`ism_fill`). In tiles finer than 32 texels
//! the tile starts empty and the fill combines the splat with the layer
//! ([`ism_rays::layer_slack`]). With `Visibility::Traced`
//! (ray queries) every texel instead holds what its own centre ray meets
//! (`ism_traced`): no points, no layer, no fill.

use std::sync::Arc;

use ash::vk;

use super::{Pass, Recording, SlotSetup};
use crate::cpu::ism_rays;
use crate::error::{Error, Result};
use crate::gpu_scene::SlotScene;
use crate::gpu_types::GpuVpl;
use crate::settings::Visibility;
use crate::shaders::{
    ism_base_comp, ism_fill_back_comp, ism_fill_comp, ism_points_comp, ism_splat_back_comp,
    ism_splat_comp, ism_traced_comp,
};
use crate::vk::{
    Buffer, BufferView, ComputeKernel, DescriptorPool, DescriptorSetLayout, Device, Image,
    ImageDesc, Work,
};

/// Texels of a row (half of them of one parity) each invocation of the hole
/// fill visits: an invocation's overhead and its loads were most of that
/// pass (cornell 320x240: 20.5 ms at one texel an invocation, 11.6 at runs
/// of 8, 9.8 at 16; docs/performance.md). Tiles are powers of two from 4.
const FILL_RUN: u32 = 16;

/// The ISM pipelines.
pub struct IsmPass {
    place: ComputeKernel<ism_points_comp::Interface>,
    base: ComputeKernel<ism_base_comp::Interface>,
    splat: ComputeKernel<ism_splat_comp::Interface>,
    fill: ComputeKernel<ism_fill_comp::Interface>,
    /// The same, with back-face maps.
    splat_back: ComputeKernel<ism_splat_back_comp::Interface>,
    fill_back: ComputeKernel<ism_fill_back_comp::Interface>,
    /// Every texel traced, where the device has ray queries.
    traced: Option<ComputeKernel<ism_traced_comp::Interface>>,
}

/// One frame's ISM atlas and inputs.
pub struct Ism {
    /// The atlas: per texel the nearest distance divided by `far` and that
    /// surface's normal, or how squarely it faces the VPL (r32ui,
    /// `ism_pack` in shaders/include/ism.glsl), what lighting reads.
    pub atlas: Image,
    /// The VPLs (`GpuVpl`), in the order of their interleaving subsets;
    /// viewed as RGBA32F texels (five per VPL, `VPL_TEXELS`) by the gathers.
    pub vpls: BufferView,
    /// Where each interleaving subset starts in `vpls`, and where the last
    /// ends (`u32`).
    pub subsets: Buffer,
    /// Number of interleaving subsets.
    pub subset_count: u32,
    /// Blocks of scene points, `points_per_vpl` each (VPLs share blocks),
    /// in their objects' space.
    pub points: Buffer,
    /// Each point's surface normal in its object's space (`u32`,
    /// [`crate::cpu::points::pack_normal`]).
    pub point_normals: Buffer,
    /// Each point's disc, in its object's space (`u32`,
    /// [`crate::cpu::points::IsmPoints::discs`]).
    pub point_discs: Buffer,
    /// The same points placed in world space for this frame's objects.
    pub world_points: Buffer,
    /// Their discs turned with them (`u32`).
    pub world_discs: Buffer,
    /// The (points, objects) versions `world_points` holds, once a frame
    /// ssbc submits placed them (placing is skipped while they hold).
    placed: std::cell::Cell<Option<(u64, u64)>>,
    /// Each VPL's coarse ray-cast layer (`BASE_GRID`²
    /// [`ism_rays::LayerBlock`]s per VPL).
    pub base_depths: Buffer,
    /// The (VPL, points) versions the buffers hold.
    versions: (u64, u64),
    /// Number of VPLs.
    pub vpl_count: u32,
    /// Points per VPL.
    pub points_per_vpl: u32,
    /// Tile side in texels (a power of two).
    pub tile: u32,
    /// Whether the atlas's lower half holds back-face maps
    /// ([`RenderSettings::ism_back_faces`](crate::RenderSettings::ism_back_faces)).
    pub back_faces: bool,
    /// Tiles per atlas row.
    pub tiles_per_row: u32,
    /// Distances are stored divided by this (m).
    pub far: f32,
    /// World radius one splatted point stands for.
    pub point_radius: f32,
    /// The relative depth tolerance of the ISM test for this atlas's
    /// texels ([`super::indirect_bounded::ism_bias`]).
    pub relative_bias: f32,
}

/// The ISM atlas's texels across and down: whole rows of `tile`-texel
/// tiles for `vpl_count` VPLs, twice with `back_faces`: the lower half
/// holds each tile's back-face map (`ism_back_texel` in
/// shaders/include/ism.glsl). Not checked against the device.
fn atlas_extent(vpl_count: u32, tile: u32, back_faces: bool) -> (u64, u64) {
    let tiles_per_row = crate::gpu_types::ism_tiles_per_row(vpl_count);
    let rows = vpl_count.max(1).div_ceil(tiles_per_row);
    let maps = if back_faces { 2 } else { 1 };
    (
        tiles_per_row as u64 * tile as u64,
        maps * rows as u64 * tile as u64,
    )
}

/// The ISM atlas for `vpl_count` VPLs with `tile`-texel tiles (and their
/// back-face maps), as allocated (TRANSFER_SRC: diagnostics read it back).
pub(crate) fn atlas_desc(vpl_count: u32, tile: u32, back_faces: bool) -> ImageDesc {
    let (w, h) = atlas_extent(vpl_count, tile, back_faces);
    let usage = vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC;
    ImageDesc::new_2d(vk::Format::R32_UINT, w as u32, h as u32, usage)
}

/// The extent of the ISM atlas for `vpl_count` tiles of `tile` texels
/// (and their back-face maps); an error if the device cannot make an image
/// that large.
pub(crate) fn check_atlas(
    device: &Device,
    vpl_count: u32,
    tile: u32,
    back_faces: bool,
) -> Result<(u32, u32)> {
    let (w, h) = atlas_extent(vpl_count, tile, back_faces);
    let max = device.limits().max_image_dimension2_d as u64;
    if w > max || h > max {
        return Err(Error::InvalidParameter(format!(
            "ISM atlas of {w}x{h} texels ({vpl_count} VPLs x {tile}^2) exceeds the device limit \
             of {max}; use fewer VPLs or a smaller ism_tile"
        )));
    }
    Ok((w as u32, h as u32))
}

impl IsmPass {
    /// Creates the kernels.
    pub fn new(device: &Arc<Device>) -> Result<Self> {
        Ok(Self {
            place: ComputeKernel::new(device)?,
            base: ComputeKernel::new(device)?,
            splat: ComputeKernel::new(device)?,
            fill: ComputeKernel::new(device)?,
            splat_back: ComputeKernel::new(device)?,
            fill_back: ComputeKernel::new(device)?,
            traced: match device.ray_queries() {
                Some(_) => Some(ComputeKernel::new(device)?),
                None => None,
            },
        })
    }
}

impl Pass for IsmPass {
    const NAME: &'static str = "ism";
    /// The atlas depends on the VPLs, the points, the far plane and the tile.
    const VIEW_INDEPENDENT: bool = true;
    /// (VPL version, points version, far plane bits, tile side, how
    /// visibility is tested: exact draws no atlas, traced traces it,
    /// back-face maps).
    type Key = (u64, u64, u32, u32, Visibility, bool);
    /// The atlas and the VPLs and points it is splatted from.
    type Resources = Ism;
    /// The frame slot's scene (its objects: points move with them; its
    /// top level, where the texels are traced) and its objects' version.
    type Reads<'a> = (SlotScene<'a>, u64);

    fn key(&self, setup: &SlotSetup<'_>) -> Self::Key {
        let cache = setup.cache;
        (
            cache.vpls().version,
            cache.points().version,
            cache.diagonal().to_bits(),
            setup.settings.ism_tile,
            setup.settings.visibility,
            setup.settings.ism_back_face_maps(),
        )
    }

    /// Allocates the atlas for the VPLs with `ism_tile`-texel tiles.
    fn prepare(&self, setup: &SlotSetup<'_>) -> Result<Ism> {
        let device = setup.device;
        let (vpls, points) = (&setup.cache.vpls().gpu, &setup.cache.points().points);
        let (tile, far) = (setup.settings.ism_tile, setup.cache.diagonal());
        if !tile.is_power_of_two() || !(4..=1024).contains(&tile) {
            return Err(Error::InvalidParameter(format!(
                "ISM tile size {tile} must be a power of two in 4..=1024"
            )));
        }
        let vpl_count = vpls.len() as u32;
        let tiles_per_row = crate::gpu_types::ism_tiles_per_row(vpl_count);
        let back_faces = setup.settings.ism_back_face_maps();
        check_atlas(device, vpl_count, tile, back_faces)?;
        let points_per_vpl = points.points_per_block as u32;
        let desc = atlas_desc(vpl_count, tile, back_faces);
        let atlas = match setup.region(super::transient::Tenancy::Ism) {
            Some(mut region) => Image::new_aliased(device, "ism.atlas", desc, &mut region)?,
            None => Image::new(device, "ism.atlas", desc)?,
        };
        let vpl_data = if vpls.is_empty() {
            vec![GpuVpl::default()]
        } else {
            vpls.to_vec()
        };
        let (point_data, normal_data, disc_data) = if points.positions.is_empty() {
            (vec![[0.0f32; 4]], vec![0u32], vec![0u32])
        } else {
            (
                points.positions.clone(),
                points.normals.clone(),
                points.discs.clone(),
            )
        };
        let subsets = &setup.cache.vpls().subsets;
        let base_data = base_layer(setup);
        let vpls = Buffer::with_data(
            device,
            "vpls",
            &vpl_data,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::UNIFORM_TEXEL_BUFFER,
        )?;
        Ok(Ism {
            vpls: BufferView::new(device, vpls, vk::Format::R32G32B32A32_SFLOAT, 16, "vpls texels")?,
            atlas,
            subsets: Buffer::with_data(
                device,
                "vpls.subsets",
                subsets,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            subset_count: subsets.len() as u32 - 1,
            versions: (setup.cache.vpls().version, setup.cache.points().version),
            points: Buffer::with_data(
                device,
                "ism.points",
                &point_data,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            point_normals: Buffer::with_data(
                device,
                "ism.point_normals",
                &normal_data,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            point_discs: Buffer::with_data(
                device,
                "ism.point_discs",
                &disc_data,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            placed: std::cell::Cell::new(None),
            world_points: Buffer::new(
                device,
                "ism.world_points",
                (point_data.len() * 16) as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?,
            world_discs: Buffer::new(
                device,
                "ism.world_discs",
                (point_data.len() * 4) as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?,
            base_depths: Buffer::with_data(
                device,
                "ism.base_depths",
                base_data,
                vk::BufferUsageFlags::STORAGE_BUFFER,
            )?,
            vpl_count,
            points_per_vpl,
            tile,
            back_faces,
            tiles_per_row,
            far,
            point_radius: points.point_radius,
            relative_bias: super::indirect_bounded::ism_bias(setup.settings.visibility),
        })
    }

    /// Rewrites the VPLs (and the points, if they changed) in place when
    /// their counts and the tile match.
    fn update(&self, ism: &mut Ism, setup: &SlotSetup<'_>) -> Result<bool> {
        let (cached_vpls, cached_points) = (setup.cache.vpls(), setup.cache.points());
        let (vpls, points) = (&cached_vpls.gpu, &cached_points.points);
        let (tile, far) = (setup.settings.ism_tile, setup.cache.diagonal());
        let points_per_vpl = points.points_per_block as u32;
        if ism.tile != tile
            || ism.back_faces != setup.settings.ism_back_face_maps()
            || ism.vpl_count != vpls.len() as u32
            || ism.subset_count as usize + 1 != cached_vpls.subsets.len()
            || ism.points_per_vpl != points_per_vpl
            || (points.positions.len().max(1) * 16) as u64 != ism.points.size
            || std::mem::size_of_val(base_layer(setup)) as u64 != ism.base_depths.size
        {
            return Ok(false);
        }
        if !vpls.is_empty() && ism.versions.0 != cached_vpls.version {
            ism.vpls.buffer.write(0, bytemuck::cast_slice(vpls))?;
            ism.subsets
                .write(0, bytemuck::cast_slice(&cached_vpls.subsets))?;
            ism.base_depths
                .write(0, bytemuck::cast_slice(&cached_vpls.ism_base))?;
        }
        if !points.positions.is_empty() && ism.versions.1 != cached_points.version {
            ism.points
                .write(0, bytemuck::cast_slice(&points.positions))?;
            ism.point_normals
                .write(0, bytemuck::cast_slice(&points.normals))?;
            ism.point_discs
                .write(0, bytemuck::cast_slice(&points.discs))?;
        }
        ism.versions = (cached_vpls.version, cached_points.version);
        ism.far = far;
        ism.point_radius = points.point_radius;
        ism.relative_bias = super::indirect_bounded::ism_bias(setup.settings.visibility);
        Ok(true)
    }

    /// A placing, a base and a splat set, a fill set per parity (those of
    /// the builds with back-face maps where the atlas has them), and a
    /// traced set where the device has ray queries.
    fn set_layouts(&self, ism: &Ism) -> Vec<&DescriptorSetLayout> {
        let (splat, fill) = match ism.back_faces {
            true => (self.splat_back.set_layout(), self.fill_back.set_layout()),
            false => (self.splat.set_layout(), self.fill.set_layout()),
        };
        let mut layouts = vec![
            self.place.set_layout(),
            self.base.set_layout(),
            splat,
            fill,
            fill,
        ];
        layouts.extend(self.traced.as_ref().map(|k| k.set_layout()));
        layouts
    }

    /// Writes every VPL's tile (nothing without VPLs).
    fn record(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        (scene, objects_version): (SlotScene<'_>, u64),
        ism: &Ism,
    ) -> Result<()> {
        // Exact visibility reads the VPLs, not the atlas.
        if ism.vpl_count == 0 || cx.settings.visibility == Visibility::Exact {
            return Ok(());
        }
        if cx.settings.visibility == Visibility::Traced {
            return self.record_traced(cx, pool, scene, ism);
        }
        let objects = scene.objects;
        let Recording {
            rec,
            profiler,
            reuse,
            ..
        } = cx;
        // The points where their objects are now (unless the slot's frame
        // before, which ran, placed these points for these objects).
        let placing = (ism.versions.1, objects_version);
        if !(*reuse && ism.placed.get() == Some(placing)) {
            let scope = profiler.begin(rec.cmd, "ism_points");
            let count = (ism.points.size / 16) as u32;
            let bindings = ism_points_comp::Bindings {
                points: &ism.points,
                objects,
                world_points: &ism.world_points,
                normals: &ism.point_normals,
                discs: &ism.point_discs,
                world_discs: &ism.world_discs,
            };
            let push = ism_points_comp::Push { count };
            self.place
                .dispatch(rec, pool, &bindings, &push, Work::Threads([count, 1, 1]))?;
            profiler.end(rec.cmd, scope);
            // A host's command buffer may never run: nothing it places is kept.
            ism.placed.set(reuse.then_some(placing));
        }
        // Splat: start every VPL's tile from its ray-cast layer (tiles past
        // the last VPL are never read) and atomicMin every point's distance.
        let scope = profiler.begin(rec.cmd, "ism_splat");
        let push = ism_base_comp::Push {
            vpl_count: ism.vpl_count,
            tile: ism.tile,
            grid: ism_rays::BASE_GRID,
            depth_scale: 1.0 / ism.far,
            back_faces: ism.back_faces.into(),
            deferred: (ism_rays::layer_slack(ism.tile) > 0.0).into(),
        };
        let bindings = ism_base_comp::Bindings {
            ism_depth: &ism.atlas,
            vpls: &ism.vpls.buffer,
            base: &ism.base_depths,
        };
        // One invocation per (block, VPL).
        let side = ism.tile / (ism.tile / ism_rays::BASE_GRID).max(1);
        let texels = Work::Threads([side * side, ism.vpl_count, 1]);
        let part = profiler.begin(rec.cmd, "ism_splat/layer");
        self.base.dispatch(rec, pool, &bindings, &push, texels)?;
        profiler.end(rec.cmd, part);
        // The splat and the fill, with or without back-face maps (two
        // builds of one shader each: the front map alone pays nothing).
        macro_rules! splat_and_fill {
            ($splat:expr, $splat_mod:ident, $fill:expr, $fill_mod:ident) => {{
                let push = $splat_mod::Push {
                    vpl_count: ism.vpl_count,
                    points_per_vpl: ism.points_per_vpl,
                    tile: ism.tile,
                    tiles_per_row: ism.tiles_per_row,
                    depth_scale: 1.0 / ism.far,
                    point_radius: ism.point_radius,
                    disc_reach: crate::cpu::point_discs::MAX_DISC_SCALE * ism.point_radius,
                };
                let bindings = $splat_mod::Bindings {
                    ism_depth: &ism.atlas,
                    vpls: &ism.vpls.buffer,
                    points: &ism.world_points,
                    discs: &ism.world_discs,
                };
                // One invocation per (point, VPL).
                let points = Work::Threads([ism.points_per_vpl, ism.vpl_count, 1]);
                let part = profiler.begin(rec.cmd, "ism_splat/points");
                $splat.dispatch(rec, pool, &bindings, &push, points)?;
                profiler.end(rec.cmd, part);
                // Fill one-texel holes, one checkerboard parity after the other.
                let part = profiler.begin(rec.cmd, "ism_splat/fill");
                let bindings = $fill_mod::Bindings {
                    ism_depth: &ism.atlas,
                    vpls: &ism.vpls.buffer,
                    layer: &ism.base_depths,
                };
                for parity in 0..2 {
                    let run = ism.tile.min(FILL_RUN);
                    let push = $fill_mod::Push {
                        vpl_count: ism.vpl_count,
                        tile: ism.tile,
                        parity,
                        run,
                        far: ism.far,
                        point_radius: ism.point_radius,
                        grid: ism_rays::BASE_GRID,
                        layer_slack: ism_rays::layer_slack(ism.tile),
                    };
                    // One invocation per (run of a row, VPL).
                    let texels = Work::Threads([ism.tile * ism.tile / run, ism.vpl_count, 1]);
                    $fill.dispatch(rec, pool, &bindings, &push, texels)?;
                }
                profiler.end(rec.cmd, part);
            }};
        }
        if ism.back_faces {
            splat_and_fill!(self.splat_back, ism_splat_back_comp, self.fill_back, ism_fill_back_comp);
        } else {
            splat_and_fill!(self.splat, ism_splat_comp, self.fill, ism_fill_comp);
        }
        profiler.end(rec.cmd, scope);
        Ok(())
    }
}

// ism_traced.comp reads a hit triangle's corners as 32-bit words, the
// position first.
const _: () = assert!(std::mem::size_of::<crate::scene::Vertex>() % 4 == 0);
const _: () = assert!(std::mem::offset_of!(crate::scene::Vertex, position) == 0);

impl IsmPass {
    /// Traces every texel's centre ray (`Visibility::Traced`).
    fn record_traced(
        &self,
        cx: &mut Recording<'_, '_>,
        pool: &DescriptorPool,
        scene: SlotScene<'_>,
        ism: &Ism,
    ) -> Result<()> {
        let missing = || Error::InvalidParameter("traced ISM texels need ray queries".into());
        let kernel = self.traced.as_ref().ok_or_else(missing)?;
        let scene_tlas = scene.top_level.ok_or_else(missing)?;
        let scope = cx.profiler.begin(cx.rec.cmd, "ism_traced");
        let push = ism_traced_comp::Push {
            vpl_count: ism.vpl_count,
            tile: ism.tile,
            vertex_words: (std::mem::size_of::<crate::scene::Vertex>() / 4) as u32,
            depth_scale: 1.0 / ism.far,
        };
        let bindings = ism_traced_comp::Bindings {
            ism_depth: &ism.atlas,
            vpls: &ism.vpls.buffer,
            scene_tlas,
            objects: scene.objects,
            vertices: &scene.scene.vertices,
            indices: &scene.scene.indices,
            mesh_ranges: &scene.scene.mesh_ranges,
        };
        // One invocation per (texel, VPL).
        let texels = Work::Threads([ism.tile * ism.tile, ism.vpl_count, 1]);
        kernel.dispatch(cx.rec, pool, &bindings, &push, texels)?;
        cx.profiler.end(cx.rec.cmd, scope);
        Ok(())
    }
}

/// The VPLs' ray-cast layers, or one block when there are no VPLs (a buffer
/// is never empty).
fn base_layer<'a>(setup: &'a SlotSetup<'_>) -> &'a [ism_rays::LayerBlock] {
    const NONE: [ism_rays::LayerBlock; 1] = [ism_rays::LayerBlock::NONE];
    let base = &setup.cache.vpls().ism_base;
    if base.is_empty() {
        &NONE
    } else {
        base
    }
}
