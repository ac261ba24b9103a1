//! Tangents for normal mapping: per triangle from its UVs, accumulated
//! per vertex, with the bitangent's handedness.

use super::*;

/// The tangent (along +u) of a triangle, orthogonal to `n`, with the
/// bitangent's handedness in w; zero where the UVs are degenerate.
pub(super) fn triangle_tangent(p: &[Vec3; 3], uv: &[[f32; 2]; 3], n: Vec3) -> Vec4 {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let (du1, dv1) = (uv[1][0] - uv[0][0], uv[1][1] - uv[0][1]);
    let (du2, dv2) = (uv[2][0] - uv[0][0], uv[2][1] - uv[0][1]);
    let det = du1 * dv2 - du2 * dv1;
    if det.abs() < 1e-12 {
        return Vec4::ZERO;
    }
    let t = (e1 * dv2 - e2 * dv1) / det;
    let b = (e2 * du1 - e1 * du2) / det;
    let t = (t - n * n.dot(t)).normalize_or_zero();
    t.extend(handedness(n, t, b))
}

/// The bitangent sign glTF's TANGENT.w holds: `cross(n, t) * w` points
/// along -v, image-up (glTF's v runs down the image, a normal map's green
/// channel up it), so w is -1 where `cross(n, t)` runs along +v (`dp_dv`).
pub(super) fn handedness(n: Vec3, t: Vec3, dp_dv: Vec3) -> f32 {
    if n.cross(t).dot(dp_dv) > 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// Per-vertex tangents: triangle tangents (weighted by area through the
/// unnormalised UV derivatives) summed per vertex and made orthogonal to its
/// normal.
pub(super) fn vertex_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[[f32; 2]],
    indices: &[u32],
) -> Vec<Vec4> {
    let mut t_sum = vec![Vec3::ZERO; positions.len()];
    let mut b_sum = vec![Vec3::ZERO; positions.len()];
    let uv = |i: usize| uvs.get(i).copied().unwrap_or([0.0; 2]);
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        let (e1, e2) = (positions[b] - positions[a], positions[c] - positions[a]);
        let (du1, dv1) = (uv(b)[0] - uv(a)[0], uv(b)[1] - uv(a)[1]);
        let (du2, dv2) = (uv(c)[0] - uv(a)[0], uv(c)[1] - uv(a)[1]);
        let det = du1 * dv2 - du2 * dv1;
        if det.abs() < 1e-12 {
            continue;
        }
        let t = (e1 * dv2 - e2 * dv1) / det;
        let bt = (e2 * du1 - e1 * du2) / det;
        for v in [a, b, c] {
            t_sum[v] += t;
            b_sum[v] += bt;
        }
    }
    (0..positions.len())
        .map(|i| {
            let n = normals[i];
            let t = (t_sum[i] - n * n.dot(t_sum[i])).normalize_or_zero();
            t.extend(handedness(n, t, b_sum[i]))
        })
        .collect()
}
