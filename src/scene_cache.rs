//! What is kept while a scene's surfaces do not change: its bounds, BVH and
//! GPU copy; the VPLs traced for one version of its lights; the ISM points
//! for one VPL count. Each part is redone only when what it depends on
//! changed ([`SceneVersions`]).

use std::sync::Arc;

use crate::cpu::bvh::SceneBvh;
use crate::cpu::ism_rays;
use crate::cpu::points::{sample_points, IsmPoints};
use crate::cpu::vpl::{self, VplSet, VplSettings};
use crate::error::Result;
use crate::gpu_scene::GpuScene;
use crate::gpu_types::GpuVpl;
use crate::resident::{next_version, SceneVersions};
use crate::scene::{Bounds, Scene};
use crate::settings::RenderSettings;
use crate::timings::CpuSpan;
use crate::vk::Device;

/// VPLs traced for one version of the lights and one set of settings, in
/// the order of their interleaving subsets.
pub struct VplCache {
    key: (u64, VplSettings, u32),
    /// The VPLs and the light paths that made them.
    pub set: VplSet,
    /// The same, as the GPU reads them.
    pub gpu: Vec<GpuVpl>,
    /// Where each interleaving subset starts in `set.vpls` (and `gpu`), and
    /// where the last ends.
    pub subsets: Vec<u32>,
    /// Each VPL's coarse ray-cast ISM layer, in the same order
    /// ([`ism_rays::coarse_depths`]).
    pub ism_base: Vec<f32>,
    /// Changes whenever the VPLs do (passes compare it with what they hold).
    pub version: u64,
}

/// Most blocks of ISM points: VPLs share blocks beyond this many (a VPL
/// needs a well-spread subset of the scene's points, not its own; from
/// different places, VPLs sharing one splat it differently). Sampling time
/// and memory then stop growing with the VPL count (5120 VPLs x 1024
/// points were 84 MiB and 248 ms on the CPU per immediate-mode frame).
pub const MAX_POINT_BLOCKS: usize = 256;

/// Blocks of ISM points for `vpls` VPLs: one each, up to [`MAX_POINT_BLOCKS`].
pub fn point_blocks(vpls: usize) -> usize {
    vpls.clamp(1, MAX_POINT_BLOCKS)
}

/// ISM points for one number of blocks, points per block and seed.
pub struct PointsCache {
    key: (usize, u32, u64),
    /// The points.
    pub points: IsmPoints,
    /// Changes whenever the points do.
    pub version: u64,
}

/// The scene's CPU products and GPU copy.
pub struct SceneCache {
    /// The versions the cache was built from (geometry and materials) and
    /// last used with (lights, camera).
    pub versions: SceneVersions,
    /// Bounds of the scene's geometry.
    pub bounds: Bounds,
    /// Ray casting, for light tracing.
    pub bvh: SceneBvh,
    /// Geometry, materials and textures on the GPU.
    pub gpu_scene: GpuScene,
    vpls: Option<VplCache>,
    points: Option<PointsCache>,
}

impl SceneCache {
    /// Brings `cache` up to `versions`: BVH and GPU copy when geometry or
    /// materials changed, VPLs when lights did too, ISM points when
    /// geometry, materials or their count changed. Each stage that runs is
    /// timed into `spans`.
    pub fn update<'c>(
        cache: &'c mut Option<SceneCache>,
        device: &Arc<Device>,
        scene: &Scene,
        versions: SceneVersions,
        settings: &RenderSettings,
        spans: &mut Vec<CpuSpan>,
    ) -> Result<&'c mut SceneCache> {
        // Earlier frames that recorded texture copies have been submitted.
        if let Some(cache) = cache.as_mut() {
            cache.gpu_scene.release_staging();
        }
        let same_surfaces = |c: &SceneCache| {
            c.versions.geometry == versions.geometry && c.versions.materials == versions.materials
        };
        if !cache.as_ref().is_some_and(same_surfaces) {
            scene.validate()?;
            *cache = None;
            let bvh = CpuSpan::time(spans, "bvh_build", || SceneBvh::new(scene));
            let gpu_scene =
                CpuSpan::time(spans, "scene_upload", || GpuScene::upload(device, scene))?;
            *cache = Some(SceneCache {
                versions,
                bounds: scene.bounds(),
                bvh,
                gpu_scene,
                vpls: None,
                points: None,
            });
        }
        let cache = cache.as_mut().expect("built above");
        cache.versions.lights = versions.lights;
        cache.versions.camera = versions.camera;
        let side = settings.pattern_side();
        let vpl_key = (versions.lights, settings.vpl.clone(), side);
        if !cache.vpls.as_ref().is_some_and(|v| v.key == vpl_key) {
            let mut set = CpuSpan::time(spans, "vpl_generation", || {
                vpl::generate(scene, &cache.bvh, &settings.vpl)
            })?;
            let subsets = vpl::interleave(&mut set.vpls, side * side);
            // Each VPL splats the block of points its identity picks (so
            // its ISM does not change with the paths traced before it).
            let count = set.vpls.len() as u32;
            let blocks = point_blocks(count as usize) as u64;
            let block = |v: &vpl::Vpl| (v.identity_hash() % blocks) as u32;
            let gpu = set.vpls.iter().zip(0..);
            let miss = 4.0 * cache.bounds.radius().max(1e-3);
            let ism_base = CpuSpan::time(spans, "ism_rays", || {
                ism_rays::coarse_depths(&cache.bvh, &set.vpls, miss)
            });
            cache.vpls = Some(VplCache {
                ism_base,
                gpu: gpu
                    .map(|(v, i)| GpuVpl::new(v, i, count, block(v)))
                    .collect(),
                set,
                subsets,
                key: vpl_key,
                version: next_version(),
            });
        }
        let blocks = point_blocks(cache.vpls().set.vpls.len());
        let points_key = (blocks, settings.points_per_vpl, settings.vpl.seed);
        if cache.points.as_ref().is_none_or(|p| p.key != points_key) {
            let points = CpuSpan::time(spans, "point_sampling", || {
                sample_points(
                    scene,
                    blocks,
                    settings.points_per_vpl as usize,
                    settings.vpl.seed,
                )
            });
            cache.points = Some(PointsCache {
                points,
                key: points_key,
                version: next_version(),
            });
        }
        Ok(cache)
    }

    /// The VPLs (traced by [`SceneCache::update`]).
    pub fn vpls(&self) -> &VplCache {
        self.vpls.as_ref().expect("VPLs are traced with the cache")
    }

    /// The ISM points (sampled by [`SceneCache::update`]).
    pub fn points(&self) -> &PointsCache {
        self.points
            .as_ref()
            .expect("points are sampled with the cache")
    }

    /// Length of the bounds' diagonal (m).
    pub fn diagonal(&self) -> f32 {
        2.0 * self.bounds.radius()
    }
}
