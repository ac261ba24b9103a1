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

/// What a host's view and projection matrices say of a pinhole camera for
/// a `width` x `height` image.
#[derive(Clone, Copy, Debug)]
pub struct Perspective {
    /// Eye position.
    pub position: Vec3,
    /// Unit optical axis.
    pub forward: Vec3,
    /// Unit up direction of the image (row 0 is the top).
    pub up: Vec3,
    /// Pixel side on the image plane at distance 1.
    pub pixel_side: f32,
    /// Where the optical axis meets the image, from its centre, in pixels
    /// (x right, y down): a jitter or an off-centre frustum.
    pub principal: Vec2,
}

impl Perspective {
    /// The camera of `view` and `projection` (Vulkan clip space: x right, y
    /// down, any depth mapping) for an image of `extent`, or why it is not
    /// one ssbc can use: non-finite, orthographic, mirrored, skewed or with
    /// pixels that are not square.
    pub fn of(
        view: Mat4,
        projection: Mat4,
        (w, h): (u32, u32),
    ) -> std::result::Result<Self, String> {
        if !view.is_finite() || !projection.is_finite() || view.determinant() == 0.0 {
            return Err("matrices must be finite, the view invertible".into());
        }
        // A ray through clip (x, y) has, in view space, a direction d with
        // row0.d = x row3.d and row1.d = y row3.d:
        // d = (r0 - x r3) x (r1 - y r3) = C - y A - x B, affine in x, y.
        let [r0, r1, r3] = [0, 1, 3].map(|i| projection.row(i).truncate());
        let (c, a, b) = (r0.cross(r1), r0.cross(r3), r3.cross(r1));
        // In pixel coordinates u = (x + 1) w / 2, v = (y + 1) h / 2.
        let mut rays = [c + a + b, -b * (2.0 / w as f32), -a * (2.0 / h as f32)];
        let centre = rays[0] + rays[1] * (0.5 * w as f32) + rays[2] * (0.5 * h as f32);
        if centre.dot(r3) < 0.0 {
            rays = rays.map(|r| -r); // the ray in front (clip w > 0)
        }
        let world = view.inverse();
        let [r0w, du, dv] = rays.map(|r| world.transform_vector3(r));
        let axis = du.cross(dv);
        if axis.length_squared() <= 0.0 || !axis.is_finite() {
            return Err("projection is not a perspective one (orthographic or degenerate)".into());
        }
        let forward = axis.normalize();
        if r0w.dot(forward) <= 0.0 {
            return Err("projection mirrors the image".into());
        }
        // Rays scaled to unit length along the axis.
        let scale = r0w.dot(forward).recip();
        let (r0w, du, dv) = (r0w * scale, du * scale, dv * scale);
        let s = du.length();
        if (dv.length() / s - 1.0).abs() > 1e-3 {
            return Err(format!(
                "projection's pixels are not square ({:.4} wide per high)",
                s / dv.length()
            ));
        }
        if du.dot(dv).abs() > 1e-3 * s * s {
            return Err("projection is skewed".into());
        }
        // The axis meets the image where r0 + u du + v dv = forward.
        let to_axis = forward - r0w;
        let axis_at = Vec2::new(
            to_axis.dot(du) / (s * s),
            to_axis.dot(dv) / dv.length_squared(),
        );
        Ok(Self {
            position: world.transform_point3(Vec3::ZERO),
            forward,
            up: -dv.normalize(),
            pixel_side: s,
            principal: axis_at - 0.5 * Vec2::new(w as f32, h as f32),
        })
    }
}

impl Camera {
    /// The camera a host engine's view and projection matrices describe
    /// (Vulkan clip space: x right, y down; reversed or infinite Z, an
    /// off-centre or jittered frustum) for a `width` x `height` image: the
    /// optical axis's offset from the image's centre becomes
    /// [`Camera::jitter`]. A projection ssbc cannot draw (orthographic,
    /// mirrored, skewed, non-square pixels) is an error naming why.
    pub fn from_matrices(view: Mat4, projection: Mat4, width: u32, height: u32) -> Result<Self> {
        let p = Perspective::of(view, projection, (width, height))
            .map_err(|why| Error::InvalidParameter(format!("camera matrices: the {why}")))?;
        Ok(Self {
            position: p.position,
            forward: p.forward,
            up: p.up,
            yfov: 2.0 * (0.5 * p.pixel_side * height as f32).atan(),
            jitter: p.principal,
        })
    }
}

/// The aspect (w/h) the default camera frames the scene for: that of the
/// CLI's default size (1024x768). Wider images show more around the scene;
/// narrower ones fit its height and may cut its sides.
pub const DEFAULT_ASPECT: f32 = 4.0 / 3.0;
