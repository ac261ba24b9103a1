//! The extent of each ISM point's disc: how wide, and where it ends.
//!
//! A splatted point stands for a disc of its tangent plane
//! (shaders/include/ism_splat.glsl). Discs of `point_radius` (all the discs' area
//! is the scene's) leave holes between them, where occluders leak; wider
//! ones close them, but a wider disc strays from a curved surface, and
//! near the edge of a box, a plinth or a wall's end it reaches past the
//! surface into free space and shadows what lies behind that edge as seen
//! from a VPL (measured: docs/accuracy.md, "ISM discs as wide as their
//! surface allows"). So a point's disc is as wide as its surface stays
//! within [`FLATNESS`] of its plane, from `point_radius` up to
//! [`MAX_DISC_SCALE`] times it, and keeps only the half-plane that stays
//! on its surface: up to the nearest *feature edge* in its plane within
//! reach (an edge with one triangle, or where the surface folds by more
//! than [`FOLD_COS`]), given as an in-plane direction towards it and its
//! distance. Gentle folds (a tessellated sphere, a scan's facets) are not
//! edges: their vertex normals make the surface curved instead.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use crate::scene::Mesh;

/// Adjacent triangles whose normals meet at a cosine below this (a fold
/// of more than 60 degrees: a box's edge, not a tessellated curve) end each
/// other's discs.
pub const FOLD_COS: f32 = 0.5;

/// The widest disc, in point radii: on a flat surface, clipped at its
/// edges (measured: docs/accuracy.md, "ISM discs as wide as their surface
/// allows"; 15/13, about 1.15, rather than 1.25 since the ISM test
/// follows the stored plane, whose cost the narrower discs pay:
/// docs/performance.md). A whole number of 15ths of it (`pack_disc`) is
/// one point radius, so that discs that do not widen keep theirs.
pub const MAX_DISC_SCALE: f32 = 15.0 / 13.0;

/// How far a disc may stray from a curved surface, in point radii: a disc
/// of radius rho on a surface of curvature k strays k rho^2 / 2.
pub const FLATNESS: f32 = 0.1;

/// A point's disc radius in point radii: as wide as a surface of
/// curvature `curvature` (1/m) stays within [`FLATNESS`] of its plane,
/// from 1 to [`MAX_DISC_SCALE`].
pub fn disc_scale(curvature: f32, point_radius: f32) -> f32 {
    let widest = (2.0 * FLATNESS / (curvature * point_radius).max(1e-30)).sqrt();
    widest.clamp(1.0, MAX_DISC_SCALE)
}

/// The curvature (1/m) of a triangle's surface as its vertex normals
/// tell it: the largest turn of the normal per metre along an edge (0 for
/// a flat-shaded triangle).
pub fn curvature(positions: [Vec3; 3], normals: [Vec3; 3]) -> f32 {
    (0..3)
        .map(|k| {
            let (i, j) = (k, (k + 1) % 3);
            let length = (positions[j] - positions[i]).length();
            let turn = (normals[j].normalize_or_zero() - normals[i].normalize_or_zero()).length();
            if length > 0.0 { turn / length } else { 0.0 }
        })
        .fold(0.0, f32::max)
}

/// A mesh's feature edges in object space, in a grid for lookups by
/// position.
pub struct MeshEdges {
    segments: Vec<(Vec3, Vec3)>,
    cell: f32,
    grid: HashMap<[i32; 3], Vec<u32>>,
}

impl MeshEdges {
    /// The feature edges of `mesh`, in grid cells of side `cell` (object
    /// space; the reach of the lookups is best at most a cell).
    pub fn new(mesh: &Mesh, cell: f32) -> Self {
        let cell = if cell.is_finite() && cell > 0.0 { cell } else { 1.0 };
        // Vertices welded by position: glTF splits them where normals or
        // texture coordinates differ, which a box's edges always do.
        let mut ids: HashMap<[u32; 3], u32> = HashMap::new();
        let welded: Vec<u32> = mesh
            .vertices
            .iter()
            .map(|v| {
                let key = v.position.map(|c| (c + 0.0).to_bits());
                let next = ids.len() as u32;
                *ids.entry(key).or_insert(next)
            })
            .collect();
        let position = |i: u32| Vec3::from(mesh.vertices[i as usize].position);
        let mut edges: HashMap<(u32, u32), (Vec3, Vec3, Vec<Vec3>)> = HashMap::new();
        for tri in mesh.indices.chunks_exact(3) {
            let [a, b, c] = [tri[0], tri[1], tri[2]].map(position);
            let normal = (b - a).cross(c - a).normalize_or_zero();
            if normal == Vec3::ZERO {
                continue;
            }
            for k in 0..3 {
                let (i, j) = (tri[k], tri[(k + 1) % 3]);
                let (wi, wj) = (welded[i as usize], welded[j as usize]);
                if wi == wj {
                    continue;
                }
                let key = (wi.min(wj), wi.max(wj));
                edges
                    .entry(key)
                    .or_insert_with(|| (position(i), position(j), Vec::new()))
                    .2
                    .push(normal);
            }
        }
        let segments: Vec<(Vec3, Vec3)> = edges
            .into_values()
            .filter(|(_, _, normals)| {
                normals.len() != 2 || normals[0].dot(normals[1]) < FOLD_COS
            })
            .map(|(a, b, _)| (a, b))
            .collect();
        let mut grid: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        let to_cell = |p: Vec3| (p / cell).floor().as_ivec3();
        for (s, &(a, b)) in segments.iter().enumerate() {
            // Every cell the segment passes through, by steps of half a cell.
            let steps = ((b - a).length() / (0.5 * cell)).ceil().min(1e6) as u32;
            let mut last = None;
            for k in 0..=steps {
                let c = to_cell(a.lerp(b, k as f32 / steps.max(1) as f32)).to_array();
                if last != Some(c) {
                    grid.entry(c).or_default().push(s as u32);
                    last = Some(c);
                }
            }
        }
        Self {
            segments,
            cell,
            grid,
        }
    }

    /// The feature edges in the plane of a triangle (corners `corners`,
    /// unit normal `n`) that come within `reach` of it: those its points'
    /// discs may meet ([`MeshEdges::clip`]).
    pub fn near_triangle(&self, corners: [Vec3; 3], n: Vec3, reach: f32) -> Vec<u32> {
        let lo = corners[0].min(corners[1]).min(corners[2]) - Vec3::splat(reach);
        let hi = corners[0].max(corners[1]).max(corners[2]) + Vec3::splat(reach);
        let (lo, hi) = ((lo / self.cell).floor(), (hi / self.cell).floor());
        // A triangle far larger than the cells: its points' discs keep
        // their whole extent rather than search that many cells. (Counted
        // in floats: cell indices of a huge or non-finite extent saturate
        // in integers, whose difference wraps.)
        let cells = hi - lo + Vec3::ONE;
        if !cells.is_finite() || cells.element_product() > 4096.0 {
            return Vec::new();
        }
        let (lo, hi) = (lo.as_ivec3(), hi.as_ivec3());
        let p = corners[0];
        let in_plane = 1e-3 * reach + 1e-6 * p.abs().max_element();
        let mut near = Vec::new();
        for x in lo.x..=hi.x {
            for y in lo.y..=hi.y {
                for z in lo.z..=hi.z {
                    for &s in self.grid.get(&[x, y, z]).into_iter().flatten() {
                        let (a, b) = self.segments[s as usize];
                        if n.dot(a - p).abs() <= in_plane && n.dot(b - p).abs() <= in_plane {
                            near.push(s);
                        }
                    }
                }
            }
        }
        near.sort_unstable();
        near.dedup();
        near
    }

    /// The half-plane of the disc of radius `reach` around `p` (on a
    /// surface of unit normal `n`) that stays on the surface: the unit
    /// in-plane direction towards the nearest of the feature edges `near`
    /// ([`MeshEdges::near_triangle`] of its triangle) within `reach`, and
    /// its distance; `None` where no edge is that near.
    pub fn clip(&self, near: &[u32], p: Vec3, n: Vec3, reach: f32) -> Option<(Vec3, f32)> {
        let mut best: Option<(Vec3, f32)> = None;
        for &s in near {
            let (a, b) = self.segments[s as usize];
            let ab = b - a;
            let t = ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0);
            let v = a + ab * t - p;
            let v = v - n * n.dot(v);
            let d = v.length();
            if d > 1e-7 && d < reach && best.is_none_or(|(_, e)| d < e) {
                best = Some((v / d, d));
            }
        }
        best
    }
}

/// A point's disc in 32 bits for the GPU (`ism_unpack_clip_dir`,
/// `ism_clip_distance` and `ism_disc_radius` in shaders/include/ism.glsl),
/// both lengths as fractions of `reach` ([`MAX_DISC_SCALE`] point radii):
/// its clip's in-plane direction, octahedral, 10 bits a coordinate; its
/// radius `scale` point radii in 15ths of the reach (4 bits); and in the
/// top 8 bits the clip's distance in 255ths of the reach, rounded up (1-255:
/// the disc keeps a sliver past the edge rather than leave one uncovered;
/// 0: no clip).
pub fn pack_disc(clip: Option<(Vec3, f32)>, reach: f32, scale: f32) -> u32 {
    let radius = (scale / MAX_DISC_SCALE * 15.0).round().clamp(1.0, 15.0) as u32;
    let Some((dir, distance)) = clip else {
        return radius << 20;
    };
    let code = (distance / reach * 255.0).ceil().clamp(1.0, 255.0) as u32;
    let Some(e) = super::points::octahedral(dir) else {
        return radius << 20;
    };
    let q = ((e * 0.5 + 0.5).clamp(Vec2::ZERO, Vec2::ONE) * 1023.0).round();
    code << 24 | radius << 20 | (q.x as u32) << 10 | q.y as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Vertex;

    /// A closed axis-aligned box of `size` at the origin, each face its own
    /// four vertices (as glTF exporters split them).
    fn split_box(size: Vec3) -> Mesh {
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        let h = size * 0.5;
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                let n = Vec3::AXES[axis] * sign;
                let (u, v) = (Vec3::AXES[(axis + 1) % 3], Vec3::AXES[(axis + 2) % 3]);
                let base = vertices.len() as u32;
                for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    let p = (n + u * su + v * sv) * h;
                    vertices.push(Vertex {
                        position: p.to_array(),
                        normal: n.to_array(),
                        ..Default::default()
                    });
                }
                let quad = if sign > 0.0 { [0, 1, 2, 0, 2, 3] } else { [0, 2, 1, 0, 3, 2] };
                indices.extend(quad.map(|k| base + k));
            }
        }
        Mesh { vertices, indices }
    }

    #[test]
    fn a_huge_or_non_finite_triangle_searches_no_cells() {
        // Cell indices of a 1e30 m triangle saturate in integers, and their
        // difference wrapped to a small box: the search then ran over 2^32
        // cells a side (a hostile scene hung the loader's point sampling).
        let edges = MeshEdges::new(&split_box(Vec3::ONE), 0.2);
        let huge = [Vec3::new(-1e30, -1e30, 0.0), Vec3::new(1e30, -1e30, 0.0), Vec3::new(0.0, 1e30, 0.0)];
        assert!(edges.near_triangle(huge, Vec3::Z, 1.0).is_empty());
        let top = [Vec3::new(-0.5, 0.5, -0.5), Vec3::new(0.5, 0.5, -0.5), Vec3::new(0.5, 0.5, 0.5)];
        assert!(edges.near_triangle(top, Vec3::Y, f32::INFINITY).is_empty());
        assert!(edges.near_triangle(top, Vec3::Y, f32::NAN).is_empty());
    }

    #[test]
    fn a_point_near_a_box_edge_is_clipped_at_it() {
        let edges = MeshEdges::new(&split_box(Vec3::ONE), 0.2);
        // The top face's triangles: their plane's four edges, not the
        // sides' edges nor the diagonal.
        let top = [Vec3::new(-0.5, 0.5, -0.5), Vec3::new(0.5, 0.5, -0.5), Vec3::new(0.5, 0.5, 0.5)];
        let near = edges.near_triangle(top, Vec3::Y, 0.3);
        assert_eq!(near.len(), 4);
        // On the top face, 5 cm from its +x edge, 40 cm from the others.
        let (dir, d) = edges.clip(&near, Vec3::new(0.45, 0.5, 0.1), Vec3::Y, 0.2).expect("a clip");
        assert!((dir - Vec3::X).length() < 1e-5, "{dir}");
        assert!((d - 0.05).abs() < 1e-5, "{d}");
        // The middle of a face: no edge within reach.
        assert!(edges.clip(&near, Vec3::new(0.0, 0.5, 0.0), Vec3::Y, 0.2).is_none());
    }

    #[test]
    fn a_tessellated_curve_has_no_edges() {
        // A 12-sided prism's sides fold by 30 degrees: only its rims count.
        let mut vertices = Vec::new();
        let mut indices = Vec::new();
        for k in 0..12u32 {
            let a = k as f32 * std::f32::consts::TAU / 12.0;
            for y in [0.0, 1.0] {
                vertices.push(Vertex {
                    position: [a.cos(), y, a.sin()],
                    ..Default::default()
                });
            }
            let (i, j) = (2 * k, 2 * ((k + 1) % 12));
            indices.extend([i, i + 1, j + 1, i, j + 1, j]);
        }
        let mesh = Mesh { vertices, indices };
        let edges = MeshEdges::new(&mesh, 0.3);
        let corners = [0, 1, 2].map(|k| Vec3::from(mesh.vertices[mesh.indices[k] as usize].position));
        let n = (corners[1] - corners[0]).cross(corners[2] - corners[0]).normalize();
        let near = edges.near_triangle(corners, n, 0.4);
        let p = (corners[0] + corners[2]) * 0.5;
        assert!(edges.clip(&near, p, n, 0.4).is_none(), "a fold of 30 degrees");
        // Near the open rim, clipped at it.
        let (dir, d) = edges.clip(&near, p + Vec3::Y * 0.4, n, 0.4).expect("the rim");
        assert!((dir - Vec3::Y).length() < 1e-4 && (d - 0.1).abs() < 1e-4, "{dir} {d}");
    }

    #[test]
    fn discs_pack_to_32_bits() {
        assert_eq!(pack_disc(None, 1.0, MAX_DISC_SCALE), 15 << 20, "no clip, widest");
        let bits = pack_disc(Some((Vec3::new(0.6, 0.0, -0.8), 0.5)), 2.0, 1.0);
        assert_eq!(bits >> 24, 64, "0.25 of the reach, rounded up");
        assert_eq!((bits >> 20) & 15, (15.0 / MAX_DISC_SCALE).round() as u32);
    }

    #[test]
    fn discs_widen_on_flat_surfaces_only() {
        let flat = [Vec3::Y; 3];
        let p = [Vec3::ZERO, Vec3::X, Vec3::Z];
        assert_eq!(curvature(p, flat), 0.0);
        assert_eq!(disc_scale(0.0, 0.1), MAX_DISC_SCALE);
        // A sphere of radius 0.2 m, normals along the positions.
        let sphere = p.map(|q| (q * 0.05 + Vec3::Y * 0.2).normalize());
        let points = sphere.map(|n| n * 0.2);
        let k = curvature(points, sphere);
        assert!((k - 5.0).abs() < 0.2, "{k}");
        // Points 9 cm wide on it stray 2 cm: they keep their radius.
        assert_eq!(disc_scale(k, 0.09), 1.0);
        // On a gentle curve of 10 m radius they widen fully.
        assert_eq!(disc_scale(0.1, 0.09), MAX_DISC_SCALE);
    }
}
