//! The host's camera, as SSBC needs it: where each pixel's square lies in
//! the world (to split pixels at creases) and, for a depth input, how to
//! turn depth back into world positions.

use glam::{Mat4, Vec2, Vec3};

use crate::error::{Error, Result};
use crate::passes::ssbc::SsbcCamera;
use crate::scene::Perspective;

/// The camera the host drew its G-buffer with.
#[derive(Clone, Copy, Debug)]
pub enum HostCamera {
    /// A symmetric frustum: pixel centres spread evenly about the optical
    /// axis, which meets the image's centre.
    LookAt {
        /// Eye position (world).
        position: Vec3,
        /// Optical axis.
        forward: Vec3,
        /// The image's up direction (row 0 is the top; made orthogonal to
        /// the axis).
        up: Vec3,
        /// Vertical field of view (radians).
        yfov: f32,
    },
    /// The matrices the host drew with, in Vulkan's conventions: clip x
    /// right, y down (row 0 at y = -1), any depth mapping (0..1, reversed,
    /// infinite far). Any perspective projection with square pixels,
    /// off-centre ones included.
    Matrices {
        /// World to view (a rigid transform, possibly scaled).
        view: Mat4,
        /// View to clip.
        projection: Mat4,
        /// Sub-pixel jitter (pixels, x right, y down) added to where every
        /// point lands: the host drew with `translate(2 jitter / extent) *
        /// projection`. Zero where `projection` already holds it.
        jitter: Vec2,
    },
}

impl HostCamera {
    /// The projection the host drew with, jitter included, for an image of
    /// `extent` (None for [`HostCamera::LookAt`]).
    fn jittered_projection(&self, (w, h): (u32, u32)) -> Option<Mat4> {
        match *self {
            HostCamera::LookAt { .. } => None,
            HostCamera::Matrices {
                projection, jitter, ..
            } => {
                let shift = Vec3::new(2.0 * jitter.x / w as f32, 2.0 * jitter.y / h as f32, 0.0);
                Some(Mat4::from_translation(shift) * projection)
            }
        }
    }

    /// Clip to world, for turning depth into positions (None for
    /// [`HostCamera::LookAt`]).
    pub(crate) fn inverse_view_projection(&self, extent: (u32, u32)) -> Option<Mat4> {
        match *self {
            HostCamera::LookAt { .. } => None,
            HostCamera::Matrices { view, .. } => self
                .jittered_projection(extent)
                .map(|p| (p * view).inverse()),
        }
    }

    /// What SSBC's kernels need of the camera for an image of `extent`, or
    /// an error naming what SSBC cannot use (an orthographic, mirrored,
    /// skewed or non-square-pixel projection, or non-finite values).
    pub(crate) fn ssbc(&self, extent: (u32, u32)) -> Result<SsbcCamera> {
        let h = extent.1;
        let bad =
            |why: &str| Error::InvalidParameter(format!("SSBC post-process: the camera {why}"));
        match *self {
            HostCamera::LookAt {
                position,
                forward,
                up,
                yfov,
            } => {
                let up = up.reject_from(forward);
                let finite = position.is_finite()
                    && forward.is_finite()
                    && up.is_finite()
                    && up.length_squared() > 0.0
                    && yfov.is_finite();
                if !finite || yfov <= 0.0 || yfov >= std::f32::consts::PI {
                    return Err(bad(
                        "needs finite position and axis, an up vector not along the axis and a field of view in (0, pi)",
                    ));
                }
                Ok(SsbcCamera {
                    position,
                    forward: forward.normalize(),
                    up: up.normalize(),
                    pixel_side: 2.0 * (yfov * 0.5).tan() / h as f32,
                    principal: Vec2::ZERO,
                })
            }
            HostCamera::Matrices { view, .. } => {
                let projection = self.jittered_projection(extent).unwrap_or(Mat4::NAN);
                let p = Perspective::of(view, projection, extent).map_err(|why| bad(&why))?;
                Ok(SsbcCamera {
                    position: p.position,
                    forward: p.forward,
                    up: p.up,
                    pixel_side: p.pixel_side,
                    principal: p.principal,
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;
    use glam::camera::rh::proj::vulkan;
    use glam::Vec4Swizzles;

    /// ssbc's own camera from a host's matrices: the same camera, its
    /// off-centre axis as the jitter.
    #[test]
    fn a_camera_from_matrices_is_the_camera_with_its_jitter() {
        let (w, h) = (160, 120);
        let mut camera = Camera::look_at(Vec3::new(0.9, 1.1, 1.6), Vec3::new(-0.4, 0.5, -0.6), 0.9);
        camera.jitter = Vec2::new(-0.3, 0.45);
        let projection = camera.jittered_projection(w, h, 0.1, 50.0);
        let back = Camera::from_matrices(camera.view(), projection, w, h).unwrap();
        assert!(back.position.distance(camera.position) < 1e-5);
        assert!(back.forward.distance(camera.forward) < 1e-5);
        assert!(back.up.distance(camera.up) < 1e-5);
        assert!((back.yfov - camera.yfov).abs() < 1e-5);
        assert!(
            back.jitter.distance(camera.jitter) < 1e-3,
            "{}",
            back.jitter
        );
        let flat = vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0);
        let err = Camera::from_matrices(camera.view(), flat, w, h)
            .unwrap_err()
            .to_string();
        assert!(err.contains("not a perspective"), "{err}");
    }
    use glam::camera::rh::view::look_to_mat4;

    #[test]
    fn matrices_give_the_look_at_camera() {
        let (w, h) = (160, 120);
        let eye = Vec3::new(0.9, 1.1, 1.6);
        let forward = (Vec3::new(-0.4, 0.5, -0.6) - eye).normalize();
        let yfov = 50f32.to_radians();
        let look = HostCamera::LookAt {
            position: eye,
            forward,
            up: Vec3::Y,
            yfov,
        }
        .ssbc((w, h))
        .unwrap();
        let view = look_to_mat4(eye, forward, Vec3::Y);
        let aspect = w as f32 / h as f32;
        for projection in [
            vulkan::perspective(yfov, aspect, 0.1, 100.0),
            vulkan::perspective(yfov, aspect, 100.0, 0.1), // reversed Z
            vulkan::perspective_infinite_reverse(yfov, aspect, 0.1),
            vulkan::perspective_infinite(yfov, aspect, 0.05),
        ] {
            for jitter in [Vec2::ZERO, Vec2::new(0.3, -0.45)] {
                let m = HostCamera::Matrices {
                    view,
                    projection,
                    jitter,
                }
                .ssbc((w, h))
                .unwrap();
                assert!(m.position.distance(look.position) < 1e-5);
                assert!(m.forward.distance(look.forward) < 1e-5, "{m:?} {look:?}");
                assert!(m.up.distance(look.up) < 1e-5, "{m:?} {look:?}");
                assert!((m.pixel_side / look.pixel_side - 1.0).abs() < 1e-5);
                // Content moved by the jitter: the axis with it.
                assert!(
                    m.principal.distance(jitter) < 1e-3,
                    "{:?} vs {jitter:?}",
                    m.principal
                );
            }
        }
    }

    #[test]
    fn depth_turns_back_into_the_point() {
        let (w, h) = (64, 48);
        let view = look_to_mat4(Vec3::new(0.0, 1.0, 3.0), -Vec3::Z, Vec3::Y);
        let projection = vulkan::perspective_infinite_reverse(0.9, 4.0 / 3.0, 0.1);
        let camera = HostCamera::Matrices {
            view,
            projection,
            jitter: Vec2::new(0.25, 0.25),
        };
        let point = Vec3::new(0.3, 0.7, -1.0);
        let clip = Mat4::from_translation(Vec3::new(0.5 / w as f32, 0.5 / h as f32, 0.0))
            * projection
            * view
            * point.extend(1.0);
        let ndc = clip.xyz() / clip.w;
        let back = camera.inverse_view_projection((w, h)).unwrap() * ndc.extend(1.0);
        assert!((back.xyz() / back.w).distance(point) < 1e-5);
    }

    #[test]
    fn unusable_projections_are_named() {
        let view = Mat4::IDENTITY;
        let cases = [
            (
                vulkan::orthographic(-1.0, 1.0, -1.0, 1.0, 0.1, 10.0),
                "not a perspective",
            ),
            (vulkan::perspective(0.9, 2.0, 0.1, 10.0), "not square"),
            (
                Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))
                    * vulkan::perspective(0.9, 1.0, 0.1, 10.0),
                "mirrors",
            ),
            (Mat4::NAN, "finite"),
        ];
        for (projection, why) in cases {
            let err = HostCamera::Matrices {
                view,
                projection,
                jitter: Vec2::ZERO,
            }
            .ssbc((64, 64))
            .unwrap_err()
            .to_string();
            assert!(err.contains(why), "{err} (expected {why})");
        }
    }
}
