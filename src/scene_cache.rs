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
use glam::Vec3;
use crate::settings::RenderSettings;
use crate::timings::CpuSpan;
use crate::vk::Device;

/// What a VPL set was traced for: lights and objects versions, VPL
/// settings, interleaving pattern side.
type VplKey = (u64, u64, VplSettings, u32);

/// VPLs traced for one version of the lights and one set of settings, in
/// the order of their interleaving subsets.
pub struct VplCache {
    key: VplKey,
    /// The VPLs and the light paths that made them.
    pub set: VplSet,
    /// The same, as the GPU reads them.
    pub gpu: Vec<GpuVpl>,
    /// Where each interleaving subset starts in `set.vpls` (and `gpu`), and
    /// where the last ends.
    pub subsets: Vec<u32>,
    /// Each VPL's coarse ray-cast ISM layer, in the same order
    /// ([`ism_rays::coarse_depths`]); empty until a frame splats ISMs.
    pub ism_base: Vec<ism_rays::LayerBlock>,
    /// Where each VPL's corner rays stopped, what `ism_base` was made of
    /// ([`ism_rays::corner_depths`]); None until a frame splats ISMs.
    ism_corners: Option<Vec<ism_rays::Corner>>,
    /// The scene's bounds and which objects were visible (a hash) when
    /// traced.
    traced_in: (Bounds, u64),
    /// Changes whenever the VPLs do (passes compare it with what they hold).
    pub version: u64,
}

/// Most blocks of ISM points: VPLs share blocks beyond this many (a VPL
/// needs a well-spread subset of the scene's points, not its own; from
/// different places, VPLs sharing one splat it differently). Sampling time
/// and memory then stop growing with the VPL count (measured: docs/accuracy.md, "Tuned constants").
pub const MAX_POINT_BLOCKS: usize = 256;

/// The ISM layer's corner rays of `vpls` (timed as `ism_rays`), keeping
/// those of the `earlier` VPLs' (if cast, and within the same bounds)
/// whose rays cross none of the `moved` boxes.
fn ism_layer(
    (bvh, bounds): (&SceneBvh, &Bounds),
    vpls: &[vpl::Vpl],
    earlier: Option<&VplCache>,
    moved: &[Bounds],
    spans: &mut Vec<CpuSpan>,
) -> Vec<ism_rays::Corner> {
    let miss = 4.0 * bounds.radius().max(1e-3);
    CpuSpan::time(spans, "ism_rays", || {
        let known = earlier
            .filter(|v| 4.0 * v.traced_in.0.radius().max(1e-3) == miss)
            .and_then(|v| {
                Some(ism_rays::KnownCorners {
                    vpls: &v.set.vpls,
                    depths: v.ism_corners.as_ref()?,
                    moved,
                })
            });
        ism_rays::corner_depths(bvh, vpls, miss, known)
    })
}

/// A hash of how many objects there are and which are visible.
fn visibility_hash(scene: &Scene) -> u64 {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    scene.objects().len().hash(&mut h);
    for o in scene.objects() {
        o.visible.hash(&mut h);
    }
    h.finish()
}

/// Blocks of ISM points for `vpls` VPLs: one each, up to [`MAX_POINT_BLOCKS`].
pub fn point_blocks(vpls: usize) -> usize {
    vpls.clamp(1, MAX_POINT_BLOCKS)
}

/// ISM points for one number of blocks, points per block and seed, and
/// one set of visible objects.
pub struct PointsCache {
    /// (blocks, points per block, seed, visible objects' hash), or zeros
    /// where the frame splats no points.
    key: (usize, u32, u64, u64),
    /// The points.
    pub points: IsmPoints,
    /// Changes whenever the points do.
    pub version: u64,
}

/// The scene's CPU products and GPU copy.
pub struct SceneCache {
    /// The versions the cache was built from (geometry, objects and
    /// materials) and last used with (lights, camera).
    pub versions: SceneVersions,
    /// Bounds of the visible objects.
    pub bounds: Bounds,
    /// Per object, the (transform, visibility) its bounds are for, and its
    /// exact world bounds (None while hidden).
    object_bounds: Vec<(glam::Mat4, bool, Option<Bounds>)>,
    /// Ray casting, for light tracing.
    pub bvh: SceneBvh,
    /// Geometry, materials and textures on the GPU.
    pub gpu_scene: GpuScene,
    vpls: Option<VplCache>,
    /// World boxes where objects were and are, for every move since the
    /// VPLs were traced (what their light paths and corner rays must not
    /// cross to be kept).
    moved_since_vpls: Vec<Bounds>,
    points: Option<PointsCache>,
    /// The set before `points`, kept while its key may come back: a still
    /// view's frames splat more points than a moving view's
    /// (`settings::CONVERGING_POINTS_PER_VPL`), and the viewer alternates
    /// them each time the view stops and moves.
    previous_points: Option<PointsCache>,
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
            let gpu_scene = CpuSpan::time(spans, "scene_upload", || {
                GpuScene::upload(device, scene, crate::gpu_scene::FRAME_SLOTS)
            })?;
            let mut built = SceneCache {
                versions,
                bounds: Bounds {
                    min: Vec3::ZERO,
                    max: Vec3::ZERO,
                },
                object_bounds: Vec::new(),
                bvh,
                gpu_scene,
                vpls: None,
                moved_since_vpls: Vec::new(),
                points: None,
                previous_points: None,
            };
            built.update_bounds(scene);
            *cache = Some(built);
        }
        let cache = cache.as_mut().expect("built above");
        if cache.versions.objects != versions.objects {
            // Objects moved, appeared or vanished: the meshes' BVHs and GPU
            // copies stay; the top level, bounds and draws follow them.
            CpuSpan::time(spans, "objects_moved", || {
                cache.bvh = cache.bvh.try_moved(scene)?;
                let moved = cache.update_bounds(scene);
                cache.moved_since_vpls.extend(moved);
                cache.gpu_scene.set_objects(scene);
                Ok::<_, crate::Error>(())
            })?;
            cache.versions.objects = versions.objects;
        }
        cache.versions.lights = versions.lights;
        cache.versions.camera = versions.camera;
        let side = settings.pattern_side();
        let vpl_key = (versions.lights, versions.objects, settings.vpl.clone(), side);
        if !cache.vpls.as_ref().is_some_and(|v| v.key == vpl_key) {
            cache.trace_vpls(scene, settings, vpl_key, spans)?;
        }
        // Traced ISM texels and exact visibility need neither points nor
        // the ray-cast layer (nor the CPU time they take).
        let splats = settings.visibility.splats_points();
        if splats && cache.vpls().ism_corners.is_none() {
            cache.cast_ism_layer(spans);
        }
        let blocks = point_blocks(cache.vpls().set.vpls.len());
        // Points move with their objects; an object shown again needs its own.
        let shown = visibility_hash(scene);
        let points_key = if splats {
            (blocks, settings.points_per_vpl, settings.vpl.seed, shown)
        } else {
            (0, 0, 0, 0)
        };
        let current = |p: &Option<PointsCache>| p.as_ref().is_some_and(|p| p.key == points_key);
        if !current(&cache.points) && current(&cache.previous_points) {
            std::mem::swap(&mut cache.points, &mut cache.previous_points);
        }
        if !current(&cache.points) {
            let points = if splats {
                CpuSpan::time(spans, "point_sampling", || {
                    sample_points(
                        scene,
                        blocks,
                        settings.points_per_vpl as usize,
                        settings.vpl.seed,
                    )
                })
            } else {
                IsmPoints::none()
            };
            cache.previous_points = cache.points.replace(PointsCache {
                points,
                key: points_key,
                version: next_version(),
            });
        }
        Ok(cache)
    }

    /// Traces the VPLs for `key` (lights, objects, VPL settings, pattern
    /// side), with their ISM ray layers, reusing an earlier set's paths
    /// where nothing moved across them.
    fn trace_vpls(
        &mut self,
        scene: &Scene,
        settings: &RenderSettings,
        vpl_key: VplKey,
        spans: &mut Vec<CpuSpan>,
    ) -> Result<()> {
        let side = vpl_key.3;
        let shown = visibility_hash(scene);
        let directional = scene
            .lights
            .iter()
            .any(|l| matches!(l.kind, crate::scene::LightKind::Directional));
        // The paths and corner rays of VPLs traced for the same lights
        // and settings, before objects moved, are kept where they
        // cross none of the moved boxes (a directional light's paths
        // start on a disk the size of the scene's bounds).
        let earlier = self.vpls.as_ref().filter(|v| {
            (v.key.0, &v.key.2, v.key.3) == (vpl_key.0, &vpl_key.2, vpl_key.3)
                && v.traced_in.1 == shown
                && (!directional || v.traced_in.0 == self.bounds)
        });
        let moved = &self.moved_since_vpls;
        let mut set = CpuSpan::time(spans, "vpl_generation", || {
            let reuse = earlier.map(|v| vpl::Reuse { set: &v.set, moved });
            vpl::generate_with(scene, &self.bvh, &settings.vpl, &self.bounds, reuse)
        })?;
        let subsets = vpl::interleave(&mut set.vpls, side * side);
        // Each VPL splats the block of points its identity picks (so
        // its ISM does not change with the paths traced before it).
        let count = set.vpls.len() as u32;
        let blocks = point_blocks(count as usize) as u64;
        let block = |v: &vpl::Vpl| (v.identity_hash() % blocks) as u32;
        let gpu = set.vpls.iter().zip(0..);
        let corners = settings.visibility.splats_points().then(|| {
            ism_layer(
                (&self.bvh, &self.bounds),
                &set.vpls,
                earlier,
                moved,
                spans,
            )
        });
        self.vpls = Some(VplCache {
            ism_base: corners.as_deref().map(ism_rays::blocks).unwrap_or_default(),
            ism_corners: corners,
            traced_in: (self.bounds, shown),
            gpu: gpu
                .map(|(v, i)| GpuVpl::new(v, i, count, block(v)))
                .collect(),
            set,
            subsets,
            key: vpl_key,
            version: next_version(),
        });
        self.moved_since_vpls.clear();
        Ok(())
    }

    /// Casts the ISM layer's corner rays of VPLs traced by a frame that
    /// did not splat ISMs.
    fn cast_ism_layer(&mut self, spans: &mut Vec<CpuSpan>) {
        let vpls = self.vpls.as_ref().expect("traced before");
        let corners = ism_layer((&self.bvh, &self.bounds), &vpls.set.vpls, None, &[], spans);
        let vpls = self.vpls.as_mut().expect("traced before");
        vpls.ism_base = ism_rays::blocks(&corners);
        vpls.ism_corners = Some(corners);
        // The ISM pass uploads the layer with the VPLs.
        vpls.version = next_version();
    }

    /// Brings each object's world bounds up to its transform (only moved,
    /// shown or hidden objects are measured again) and their union.
    /// Returns the boxes where those objects were and are, grown by a
    /// margin (rays start a little off surfaces and behind their origins).
    fn update_bounds(&mut self, scene: &Scene) -> Vec<Bounds> {
        let objects = scene.objects();
        let mut moved = Vec::new();
        self.object_bounds.truncate(objects.len());
        for (i, o) in objects.iter().enumerate() {
            let held = self.object_bounds.get(i);
            if held.is_some_and(|h| h.0 == o.transform && h.1 == o.visible) {
                continue;
            }
            let placement = crate::scene::Placement::new(o);
            let bounds = scene.meshes()[o.mesh]
                .vertices
                .iter()
                .map(|v| placement.transform.transform_point3(v.position.into()))
                .map(|p| Bounds { min: p, max: p })
                .reduce(Bounds::union)
                .filter(|_| o.visible);
            moved.extend(held.and_then(|h| h.2));
            moved.extend(bounds);
            let entry = (o.transform, o.visible, bounds);
            match self.object_bounds.get_mut(i) {
                Some(h) => *h = entry,
                None => self.object_bounds.push(entry),
            }
        }
        self.bounds = self
            .object_bounds
            .iter()
            .filter_map(|b| b.2)
            .reduce(Bounds::union)
            .unwrap_or_else(|| scene.bounds());
        moved
            .into_iter()
            .map(|b| {
                let margin = Vec3::splat(1e-3 * (1.0 + b.min.abs().max(b.max.abs()).max_element()));
                Bounds {
                    min: b.min - margin,
                    max: b.max + margin,
                }
            })
            .collect()
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
