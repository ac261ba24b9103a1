//! Deterministic low-discrepancy sampling: Halton sequences with a seeded
//! Cranley–Patterson rotation, and the warps light tracing needs.

use glam::{Vec2, Vec3};

/// The first 32 primes: one Halton base per dimension.
const PRIMES: [u32; 32] = [
    2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53, 59, 61, 67, 71, 73, 79, 83, 89, 97,
    101, 103, 107, 109, 113, 127, 131,
];

/// Number of dimensions available.
pub const DIMENSIONS: usize = PRIMES.len();

/// Radical inverse of `index` in `base`.
pub fn radical_inverse(mut index: u64, base: u32) -> f64 {
    let b = base as u64;
    let inv = 1.0 / base as f64;
    let (mut result, mut f) = (0.0, inv);
    while index > 0 {
        result += (index % b) as f64 * f;
        index /= b;
        f *= inv;
    }
    result
}

/// A 64-bit mixing hash (SplitMix64 finaliser).
pub fn hash64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A Halton sequence randomised per dimension by a seeded rotation.
#[derive(Clone, Debug)]
pub struct Halton {
    offsets: [f64; DIMENSIONS],
}

impl Halton {
    /// The sequence for `seed`.
    pub fn new(seed: u64) -> Self {
        let mut offsets = [0.0; DIMENSIONS];
        for (d, o) in offsets.iter_mut().enumerate() {
            *o = (hash64(seed ^ hash64(d as u64)) >> 11) as f64 / (1u64 << 53) as f64;
        }
        Self { offsets }
    }

    /// Sample `index`, dimension `dim` (dimensions past the table wrap with a
    /// hash so paths never run out).
    pub fn sample(&self, index: u64, dim: usize) -> f32 {
        let d = dim % DIMENSIONS;
        let mut v = radical_inverse(index, PRIMES[d]) + self.offsets[d];
        if dim >= DIMENSIONS {
            v += (hash64(index ^ ((dim as u64) << 40)) >> 11) as f64 / (1u64 << 53) as f64;
        }
        let v = v.fract() as f32;
        v.min(1.0 - f32::EPSILON)
    }
}

/// An orthonormal basis (t, b) around unit `n`.
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    // Duff et al. 2017, "Building an Orthonormal Basis, Revisited".
    // Same branch as orthonormal_basis in shaders/include/octahedral.glsl (n.z = -0.0 counts as +).
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-weighted direction around `n` (pdf cos / pi).
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let (t, b) = basis(n);
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - u.x).max(0.0).sqrt()).normalize()
}

/// Uniform direction on the sphere (pdf 1 / 4pi).
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction in the cone of half-angle acos(`cos_max`) around `axis`
/// (pdf 1 / (2pi (1 - cos_max))).
pub fn uniform_cone(axis: Vec3, cos_max: f32, u: Vec2) -> Vec3 {
    let cos_t = 1.0 - u.x * (1.0 - cos_max);
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let (t, b) = basis(axis);
    (t * (sin_t * phi.cos()) + b * (sin_t * phi.sin()) + axis * cos_t).normalize()
}

/// Uniform point on the unit disk (concentric mapping).
pub fn uniform_disk(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (
            o.y,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y),
        )
    };
    Vec2::new(theta.cos(), theta.sin()) * r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halton_is_deterministic_and_stratified() {
        let a = Halton::new(7);
        let b = Halton::new(7);
        let c = Halton::new(8);
        assert_eq!(a.sample(10, 3), b.sample(10, 3));
        assert_ne!(a.sample(10, 3), c.sample(10, 3));
        // 1024 samples of dimension 0 fall 1 per bin of width 1/1024 (base 2).
        let mut bins = vec![0; 1024];
        for i in 0..1024 {
            bins[(a.sample(i, 0) * 1024.0) as usize] += 1;
        }
        assert!(bins.iter().all(|&n| n == 1));
    }

    #[test]
    fn cosine_samples_have_mean_cosine_two_thirds() {
        let h = Halton::new(1);
        let n = Vec3::new(0.3, 0.4, 0.866).normalize();
        let mean: f32 = (0..4096)
            .map(|i| cosine_hemisphere(n, Vec2::new(h.sample(i, 0), h.sample(i, 1))).dot(n))
            .sum::<f32>()
            / 4096.0;
        assert!((mean - 2.0 / 3.0).abs() < 2e-3, "{mean}");
    }
}
