//! glTF mesh deformation applied once at load: morph targets at their
//! weights (glTF 2.0, section 3.7.2.2) and linear-blend skinning by the
//! joints' world transforms (section 3.7.3). Pure math; the loader reads
//! and checks the accessors.

use glam::{Mat3, Mat4, Vec3, Vec4};

/// Adds `weight` x the displacements `delta` (xyz per vertex, as many as
/// `values`) to `values`.
pub(crate) fn add_displacements(values: &mut [Vec3], delta: &[f32], weight: f32) {
    for (v, d) in values.iter_mut().zip(delta.chunks_exact(3)) {
        *v += weight * Vec3::from_slice(d);
    }
}

/// The same for tangents (their handedness `w` stays).
pub(crate) fn add_tangent_displacements(tangents: &mut [Vec4], delta: &[f32], weight: f32) {
    for (t, d) in tangents.iter_mut().zip(delta.chunks_exact(3)) {
        *t += (weight * Vec3::from_slice(d)).extend(0.0);
    }
}

/// Unit length again after displacements (a vector displaced to nothing
/// keeps `fallback`).
pub(crate) fn renormalize(values: &mut [Vec3], fallback: Vec3) {
    for v in values {
        *v = v.try_normalize().unwrap_or(fallback);
    }
}

/// The vertices' joint influences: `sets` JOINTS_n / WEIGHTS_n pairs, four
/// per set, vertex-major (`joints[v * 4 * sets + k]`). Joints are indices
/// into the skin's joint list, checked against it.
pub(crate) struct Influences<'a> {
    pub sets: usize,
    pub joints: &'a [u32],
    pub weights: &'a [f32],
}

/// Poses vertices (positions, and normals and tangents where present) by
/// linear-blend skinning: each vertex by the weighted mean of its joints'
/// matrices (`joint_matrices[j]` = the joint's world transform x its
/// inverse bind matrix). Weights are divided by their sum, as renderers
/// do with files whose weights do not add up to one; a vertex with no
/// weight stays where it is. Normals go by the inverse transpose of the
/// blended matrix (by the matrix itself where that is singular).
pub(crate) fn skin(
    joint_matrices: &[Mat4],
    influences: &Influences,
    positions: &mut [Vec3],
    normals: &mut [Vec3],
    tangents: &mut [Vec4],
) {
    let per_vertex = 4 * influences.sets;
    for (v, position) in positions.iter_mut().enumerate() {
        let range = v * per_vertex..(v + 1) * per_vertex;
        let mut blended = Mat4::ZERO;
        let mut total = 0.0;
        for (&j, &w) in influences.joints[range.clone()]
            .iter()
            .zip(&influences.weights[range])
        {
            if w > 0.0 {
                blended += joint_matrices[j as usize] * w;
                total += w;
            }
        }
        if total <= 0.0 {
            continue;
        }
        let m = blended * (1.0 / total);
        *position = m.transform_point3(*position);
        let linear = Mat3::from_mat4(m);
        let det = linear.determinant();
        let for_normals = if det.is_normal() {
            linear.inverse().transpose()
        } else {
            linear
        };
        if let Some(n) = normals.get_mut(v) {
            *n = (for_normals * *n).try_normalize().unwrap_or(*n);
        }
        if let Some(t) = tangents.get_mut(v) {
            let xyz = (linear * t.truncate())
                .try_normalize()
                .unwrap_or(t.truncate());
            *t = xyz.extend(t.w);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Quat;

    #[test]
    fn displacements_add_by_weight_and_normals_stay_unit() {
        let mut p = vec![Vec3::ZERO, Vec3::X];
        add_displacements(&mut p, &[0.0, 1.0, 0.0, 2.0, 0.0, 0.0], 0.5);
        assert_eq!(p, vec![Vec3::new(0.0, 0.5, 0.0), Vec3::new(2.0, 0.0, 0.0)]);
        let mut n = vec![Vec3::Z, Vec3::Z];
        add_displacements(&mut n, &[0.0, 0.0, -1.0, 1.0, 0.0, -1.0], 1.0);
        renormalize(&mut n, Vec3::Y);
        assert_eq!(n, vec![Vec3::Y, Vec3::X]);
        let mut t = vec![Vec4::new(1.0, 0.0, 0.0, -1.0)];
        add_tangent_displacements(&mut t, &[0.0, 2.0, 0.0], 0.5);
        assert_eq!(t, vec![Vec4::new(1.0, 1.0, 0.0, -1.0)]);
    }

    #[test]
    fn skinning_blends_joint_matrices_by_normalized_weight() {
        // Joint 0 at rest, joint 1 turned 90 degrees about z and moved up.
        let turn = Mat4::from_rotation_translation(
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::Y,
        );
        let joints = [Mat4::IDENTITY, turn];
        // Vertex 0 on joint 1 alone (weights not summing to one); vertex 1
        // halfway; vertex 2 with no weight.
        let influence = Influences {
            sets: 1,
            joints: &[1, 0, 0, 0, 0, 1, 0, 0, 1, 1, 0, 0],
            weights: &[0.5, 0.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        };
        let mut p = vec![Vec3::X, Vec3::X, Vec3::X];
        let mut n = vec![Vec3::X, Vec3::X, Vec3::X];
        let mut t = vec![Vec4::new(0.0, 1.0, 0.0, -1.0); 3];
        skin(&joints, &influence, &mut p, &mut n, &mut t);
        assert!(p[0].abs_diff_eq(Vec3::new(0.0, 2.0, 0.0), 1e-6), "{}", p[0]);
        assert!(n[0].abs_diff_eq(Vec3::Y, 1e-6), "{}", n[0]);
        assert!(
            t[0].abs_diff_eq(Vec4::new(-1.0, 0.0, 0.0, -1.0), 1e-6),
            "{}",
            t[0]
        );
        // Linear blend: the mean of (1, 0, 0) and (0, 2, 0).
        assert!(p[1].abs_diff_eq(Vec3::new(0.5, 1.0, 0.0), 1e-6), "{}", p[1]);
        assert!((n[1].length() - 1.0).abs() < 1e-6);
        assert_eq!((p[2], n[2]), (Vec3::X, Vec3::X));
    }

    #[test]
    fn skinned_normals_stay_normal_under_non_uniform_scale() {
        // A surface along the diagonal x = y (normal (1, -1, 0) / sqrt 2),
        // stretched 2x along x: the surface runs along (2, 1), its normal
        // along (1, -2).
        let joints = [Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0))];
        let influence = Influences {
            sets: 1,
            joints: &[0, 0, 0, 0],
            weights: &[1.0, 0.0, 0.0, 0.0],
        };
        let mut p = vec![Vec3::ONE];
        let mut n = vec![Vec3::new(1.0, -1.0, 0.0).normalize()];
        skin(&joints, &influence, &mut p, &mut n, &mut []);
        assert!(
            n[0].abs_diff_eq(Vec3::new(1.0, -2.0, 0.0).normalize(), 1e-6),
            "{}",
            n[0]
        );
        assert!(n[0].dot(Vec3::new(2.0, 1.0, 0.0)).abs() < 1e-6);
    }
}
