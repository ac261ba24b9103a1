//! glTF node animation: keyframe samplers (step, linear, cubic spline)
//! evaluated at a time, giving the translation, rotation or scale of the
//! nodes they target (glTF 2.0, section 3.11). Pure math; the loader reads
//! the keyframes from the file.

use std::collections::HashMap;

use glam::{Mat3, Mat4, Quat, Vec3, Vec4};

/// How a sampler interpolates between keyframes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Interpolation {
    /// The value of the keyframe at or before the time.
    Step,
    /// Linear (rotations: spherical linear).
    Linear,
    /// Cubic Hermite spline: each keyframe holds an in-tangent, a value and
    /// an out-tangent.
    CubicSpline,
}

/// What a channel animates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Path {
    Translation,
    Rotation,
    Scale,
}

impl Path {
    /// Numbers per value.
    pub fn components(self) -> usize {
        match self {
            Path::Rotation => 4,
            _ => 3,
        }
    }
}

/// Keyframes of one sampler: strictly increasing times and their values
/// (`components` numbers per value; three values per keyframe for cubic
/// splines).
#[derive(Clone, Debug)]
pub(crate) struct Sampler {
    pub times: Vec<f32>,
    pub values: Vec<f32>,
    pub interpolation: Interpolation,
}

impl Sampler {
    /// Checks the keyframes: times finite and strictly increasing, as many
    /// values as keyframes need.
    pub fn check(&self, components: usize) -> std::result::Result<(), String> {
        if self.times.is_empty() {
            return Err("no keyframes".into());
        }
        // (Times are finite: the loader refuses other numbers.)
        if self.times.windows(2).any(|w| w[0] >= w[1]) {
            return Err("keyframe times are not strictly increasing".into());
        }
        let per_key = match self.interpolation {
            Interpolation::CubicSpline => 3 * components,
            _ => components,
        };
        if self.values.len() != self.times.len() * per_key {
            return Err(format!(
                "{} output numbers for {} keyframes of {per_key}",
                self.values.len(),
                self.times.len()
            ));
        }
        Ok(())
    }

    /// The value at time `t` (clamped to the keyframes' span), as up to
    /// four numbers.
    pub fn sample(&self, t: f32, path: Path) -> Vec4 {
        let n = path.components();
        let cubic = self.interpolation == Interpolation::CubicSpline;
        // Keyframe k's value (for cubic splines the middle of its three).
        let value = |k: usize, part: usize| {
            let base = if cubic { (3 * k + part) * n } else { k * n };
            let v = &self.values[base..base + n];
            Vec4::new(v[0], v[1], v[2], if n == 4 { v[3] } else { 0.0 })
        };
        let last = self.times.len() - 1;
        let mid = usize::from(cubic);
        if t <= self.times[0] || last == 0 {
            return value(0, mid);
        }
        if t >= self.times[last] {
            return value(last, mid);
        }
        // The keyframe at or before t.
        let k = self.times.partition_point(|&x| x <= t) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let dt = t1 - t0;
        let s = (t - t0) / dt;
        let result = match self.interpolation {
            Interpolation::Step => value(k, 0),
            Interpolation::Linear if path == Path::Rotation => {
                let q0 = Quat::from_vec4(value(k, 0)).normalize();
                let q1 = Quat::from_vec4(value(k + 1, 0)).normalize();
                Vec4::from(q0.slerp(q1, s))
            }
            Interpolation::Linear => value(k, 0).lerp(value(k + 1, 0), s),
            Interpolation::CubicSpline => {
                // Hermite basis: values at the ends, out-tangent of k and
                // in-tangent of k + 1 scaled by the interval.
                let (s2, s3) = (s * s, s * s * s);
                let (p0, m0) = (value(k, 1), value(k, 2) * dt);
                let (p1, m1) = (value(k + 1, 1), value(k + 1, 0) * dt);
                p0 * (2.0 * s3 - 3.0 * s2 + 1.0)
                    + m0 * (s3 - 2.0 * s2 + s)
                    + p1 * (-2.0 * s3 + 3.0 * s2)
                    + m1 * (s3 - s2)
            }
        };
        if path == Path::Rotation {
            Vec4::from(Quat::from_vec4(result).normalize())
        } else {
            result
        }
    }
}

/// A node's rest pose with animated parts replaced.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PoseOverride {
    pub translation: Option<Vec3>,
    pub rotation: Option<Quat>,
    pub scale: Option<Vec3>,
}

impl PoseOverride {
    /// Sets `path` to `value`.
    pub fn set(&mut self, path: Path, value: Vec4) {
        match path {
            Path::Translation => self.translation = Some(value.truncate()),
            Path::Rotation => self.rotation = Some(Quat::from_vec4(value)),
            Path::Scale => self.scale = Some(value.truncate()),
        }
    }
}

/// A node's local transform: its rest pose (`rest`, decomposed if a
/// matrix) with the animated parts of `pose` replacing its own.
pub(crate) fn local_transform(rest: Mat4, pose: Option<&PoseOverride>) -> Mat4 {
    match pose {
        Some(pose) => {
            let (scale, rotation, translation) = rest.to_scale_rotation_translation();
            Mat4::from_scale_rotation_translation(
                pose.scale.unwrap_or(scale),
                pose.rotation.unwrap_or(rotation),
                pose.translation.unwrap_or(translation),
            )
        }
        None => rest,
    }
}

/// One animated property of a node.
#[derive(Clone, Debug)]
pub(crate) struct Channel {
    pub node: usize,
    pub path: Path,
    pub sampler: Sampler,
}

/// A node of the scene's tree as posing needs it.
#[derive(Clone, Debug)]
pub(crate) struct PoseNode {
    /// Its glTF index.
    pub node: usize,
    /// Its parent's position in [`NodeAnimation::nodes`] (parents come first).
    pub parent: Option<usize>,
    /// Its local rest transform.
    pub rest: Mat4,
}

/// A glTF file's first animation with the node tree it moves, kept with
/// the scene: objects are posed at any time without reading the file again
/// ([`super::Scene::pose`]).
#[derive(Clone, Debug, Default)]
pub struct NodeAnimation {
    pub(crate) nodes: Vec<PoseNode>,
    pub(crate) channels: Vec<Channel>,
}

/// The animated parts of every node a channel targets, at time `t`.
pub(crate) fn poses_at(channels: &[Channel], t: f32) -> HashMap<usize, PoseOverride> {
    let mut poses: HashMap<usize, PoseOverride> = HashMap::new();
    for c in channels {
        poses
            .entry(c.node)
            .or_default()
            .set(c.path, c.sampler.sample(t, c.path));
    }
    poses
}

impl NodeAnimation {
    /// Each node's world transform at time `t` (seconds, clamped to the
    /// keyframes), by glTF node index.
    pub fn node_transforms(&self, t: f32) -> HashMap<usize, Mat4> {
        let poses = poses_at(&self.channels, t);
        let mut world: Vec<Mat4> = Vec::with_capacity(self.nodes.len());
        for n in &self.nodes {
            let parent = n.parent.map_or(Mat4::IDENTITY, |p| world[p]);
            world.push(parent * local_transform(n.rest, poses.get(&n.node)));
        }
        self.nodes.iter().map(|n| n.node).zip(world).collect()
    }
}

/// Whether `m` collapses space (a zero scale: glTF's way to hide a node).
pub(crate) fn collapses(m: &Mat4) -> bool {
    Mat3::from_mat4(*m).determinant().abs() < 1e-18 || !m.is_finite()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(times: &[f32], values: &[f32], interpolation: Interpolation) -> Sampler {
        Sampler {
            times: times.to_vec(),
            values: values.to_vec(),
            interpolation,
        }
    }

    #[test]
    fn step_linear_and_clamping() {
        let values = [0.0, 0.0, 0.0, 2.0, 4.0, 6.0];
        let lin = sampler(&[1.0, 3.0], &values, Interpolation::Linear);
        assert!(lin.check(3).is_ok());
        assert_eq!(
            lin.sample(2.0, Path::Translation).truncate(),
            Vec3::new(1.0, 2.0, 3.0)
        );
        assert_eq!(lin.sample(-5.0, Path::Translation).truncate(), Vec3::ZERO);
        assert_eq!(
            lin.sample(9.0, Path::Translation).truncate(),
            Vec3::new(2.0, 4.0, 6.0)
        );
        let step = sampler(&[1.0, 3.0], &values, Interpolation::Step);
        assert_eq!(step.sample(2.9, Path::Translation).truncate(), Vec3::ZERO);
        assert_eq!(
            step.sample(3.0, Path::Translation).truncate(),
            Vec3::new(2.0, 4.0, 6.0)
        );
    }

    #[test]
    fn rotations_are_spherical_and_unit() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let values: Vec<f32> = a.to_array().into_iter().chain(b.to_array()).collect();
        let s = sampler(&[0.0, 1.0], &values, Interpolation::Linear);
        let half = Quat::from_vec4(s.sample(0.5, Path::Rotation));
        assert!(half.abs_diff_eq(Quat::from_rotation_y(std::f32::consts::FRAC_PI_4), 1e-6));
    }

    /// A cubic spline with zero tangents eases in and out (smoothstep);
    /// with the tangents of a straight line it is that line.
    #[test]
    fn cubic_splines_are_hermite() {
        let flat = [
            0.0, 0.0, 0.0, /* value */ 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, //
            0.0, 0.0, 0.0, /* value */ 1.0, 1.0, 1.0, 0.0, 0.0, 0.0,
        ];
        let s = sampler(&[0.0, 2.0], &flat, Interpolation::CubicSpline);
        assert!(s.check(3).is_ok());
        let v = s.sample(0.5, Path::Scale).x;
        assert!((v - (3.0 * 0.0625 - 2.0 * 0.015625)).abs() < 1e-6, "{v}");
        let line = [
            0.5, 0.5, 0.5, 0.0, 0.0, 0.0, 0.5, 0.5, 0.5, //
            0.5, 0.5, 0.5, 1.0, 1.0, 1.0, 0.5, 0.5, 0.5,
        ];
        let s = sampler(&[0.0, 2.0], &line, Interpolation::CubicSpline);
        assert!((s.sample(1.5, Path::Translation).x - 0.75).abs() < 1e-6);
    }

    #[test]
    fn bad_keyframes_are_refused() {
        let bad = sampler(&[1.0, 1.0], &[0.0; 6], Interpolation::Linear);
        assert!(bad.check(3).unwrap_err().contains("increasing"));
        let short = sampler(&[0.0, 1.0], &[0.0; 6], Interpolation::CubicSpline);
        assert!(short.check(3).is_err());
    }
}
