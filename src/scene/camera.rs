//! Cameras: pinhole cameras and their view and projection matrices.

use super::*;

/// A perspective camera (looks along `forward`).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Eye position.
    pub position: Vec3,
    /// Unit viewing direction.
    pub forward: Vec3,
    /// Unit up vector (orthogonal to forward).
    pub up: Vec3,
    /// Vertical field of view in radians.
    pub yfov: f32,
    /// This frame's sub-pixel jitter (pixels, x right, y down): where every
    /// point lands moves by it, as in a TAA engine's jittered projection
    /// (`translate(2 jitter / extent) * projection`). Zero by default; a
    /// change of jitter alone is no camera move for temporal history.
    pub jitter: Vec2,
}

impl Camera {
    /// A camera at `eye` looking at `target`.
    pub fn look_at(eye: Vec3, target: Vec3, yfov: f32) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
        let up = right.cross(forward).normalize();
        Self {
            position: eye,
            forward,
            up,
            yfov,
            jitter: Vec2::ZERO,
        }
    }

    /// The default view of a scene without a camera: looking down 40° from
    /// the front right (30° off +Z), placed so that the eight corners of
    /// `bounds` fill an image of aspect `aspect` (w/h) with a 45° vertical
    /// field of view as tightly as the perspective allows (5% margin). A
    /// raised three-quarter view shows a large plane or a flat interior from
    /// above rather than edge-on; fitting the corners (rather than the
    /// bounding sphere, around its centre) fills the image with wide, flat
    /// or tall scenes.
    pub fn framing(bounds: &Bounds, aspect: f32) -> Self {
        let (azimuth, elevation) = (30f32.to_radians(), 40f32.to_radians());
        let yfov = 45f32.to_radians();
        let to_eye = Vec3::new(
            azimuth.sin() * elevation.cos(),
            elevation.sin(),
            azimuth.cos() * elevation.cos(),
        );
        let view = Self::look_at(to_eye, Vec3::ZERO, yfov);
        let (forward, up) = (view.forward, view.up);
        let right = forward.cross(up);
        let margin = 0.95;
        let tan_y = (yfov * 0.5).tan() * margin;
        let tan_x = (yfov * 0.5).tan() * aspect.clamp(0.1, 10.0) * margin;
        // In the camera's basis (right r, up u, forward f) a corner p is in
        // the frustum of an eye e when |p_r - e_r| <= (p_f - e_f) tan_x, and
        // likewise for u. Each pair of side planes touching the corners fixes
        // e_f and the offset across; the farther e_f of the two pairs wins.
        let corners = (0..8).map(|k| {
            let pick = |bit: u32, lo: f32, hi: f32| if k & bit == 0 { lo } else { hi };
            Vec3::new(
                pick(1, bounds.min.x, bounds.max.x),
                pick(2, bounds.min.y, bounds.max.y),
                pick(4, bounds.min.z, bounds.max.z),
            )
        });
        let fit = |axis: Vec3, tan: f32| {
            let (mut plus, mut minus) = (f32::MIN, f32::MIN);
            for p in corners.clone() {
                let (across, along) = (p.dot(axis), p.dot(forward));
                plus = plus.max(across - along * tan);
                minus = minus.max(-across - along * tan);
            }
            (-(plus + minus) / (2.0 * tan), (plus - minus) * 0.5)
        };
        let ((f_x, r), (f_y, u)) = (fit(right, tan_x), fit(up, tan_y));
        // Never at or in front of the nearest corner for a flat or
        // point-sized scene.
        let nearest = corners.map(|p| p.dot(forward)).fold(f32::MAX, f32::min);
        let back = f_x.min(f_y).min(nearest - bounds.radius() * 0.1 - 1e-3);
        Self {
            position: right * r + up * u + forward * back,
            forward,
            up,
            yfov,
            jitter: Vec2::ZERO,
        }
    }

    /// World-to-view matrix (right-handed, looking down -Z).
    pub fn view(&self) -> Mat4 {
        glam::camera::rh::view::look_to_mat4(self.position, self.forward, self.up)
    }

    /// Vulkan projection (+Y down in NDC) for `aspect` = w/h, with reversed
    /// depth: 1 at `near`, 0 at `far` (float depth is most precise near 0,
    /// where perspective needs it most).
    pub fn projection(&self, aspect: f32, near: f32, far: f32) -> Mat4 {
        glam::camera::rh::proj::vulkan::perspective(self.yfov, aspect, far, near)
    }

    /// [`Camera::projection`] for a `width` x `height` image with the
    /// camera's [`Camera::jitter`].
    pub fn jittered_projection(&self, width: u32, height: u32, near: f32, far: f32) -> Mat4 {
        let (w, h) = (width as f32, height as f32);
        let shift = 2.0 * self.jitter / Vec2::new(w, h);
        Mat4::from_translation(shift.extend(0.0)) * self.projection(w / h, near, far)
    }

    /// The same camera with its jitter left out (what temporal history
    /// compares to tell a camera move).
    pub fn without_jitter(&self) -> Self {
        Self {
            jitter: Vec2::ZERO,
            ..self.clone()
        }
    }

    /// Unit world-space direction through the centre of pixel (`x`, `y`) of a
    /// `width` x `height` image: the same pixel grid the rasterizer samples
    /// (with the camera's jitter).
    pub fn pixel_ray(&self, x: f32, y: f32, width: u32, height: u32) -> Vec3 {
        let aspect = width as f32 / height as f32;
        let t = (self.yfov * 0.5).tan();
        let ndc_x = 2.0 * (x + 0.5 - self.jitter.x) / width as f32 - 1.0;
        let ndc_y = 2.0 * (y + 0.5 - self.jitter.y) / height as f32 - 1.0;
        let right = self.forward.cross(self.up).normalize();
        (self.forward + right * (ndc_x * t * aspect) - self.up * (ndc_y * t)).normalize()
    }
}

/// The aspect (w/h) the default camera frames the scene for: that of the
/// CLI's default size (1024x768). Wider images show more around the scene;
/// narrower ones fit its height and may cut its sides.
pub const DEFAULT_ASPECT: f32 = 4.0 / 3.0;
