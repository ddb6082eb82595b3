//! The pinhole camera of the scene format: vertical field of view, image y downwards, pixel
//! (0, 0) top-left, right = normalize(forward × up).

use glam::{Vec2, Vec3};

use crate::geometry::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub eye: Vec3,
    pub target: Vec3,
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    pub width: u32,
    pub height: u32,
}

impl Camera {
    /// The same camera at another resolution (the field of view stays vertical).
    pub fn with_resolution(mut self, width: u32, height: u32) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// The ray through the image-plane position `film` (in pixels: x to the right, y down,
    /// `(0, 0)` the top-left corner of pixel (0, 0)). The direction is unit length.
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        self.rays().generate_ray(film)
    }

    /// The camera's basis and scales computed once, for generating many rays.
    pub fn rays(&self) -> CameraRays {
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        CameraRays {
            eye: self.eye,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (self.fov_deg.to_radians() * 0.5).tan(),
            aspect: self.width as f32 / self.height as f32,
            width: self.width as f32,
            height: self.height as f32,
        }
    }
}

/// A [`Camera`] prepared for generating rays: its basis and the tangent of half its field of
/// view, which do not change from ray to ray. [`CameraRays::generate_ray`] is
/// [`Camera::generate_ray`], operation for operation.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    eye: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f32,
    aspect: f32,
    width: f32,
    height: f32,
}

impl CameraRays {
    /// See [`Camera::generate_ray`].
    #[inline]
    pub fn generate_ray(&self, film: Vec2) -> Ray {
        let sx = (2.0 * film.x / self.width - 1.0) * self.tan_half * self.aspect;
        let sy = (1.0 - 2.0 * film.y / self.height) * self.tan_half;
        Ray::new(self.eye, (self.forward + self.right * sx + self.up * sy).normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cam() -> Camera {
        Camera {
            eye: Vec3::new(0.0, 1.0, 3.9),
            target: Vec3::new(0.0, 1.0, 0.0),
            up: Vec3::Y,
            fov_deg: 40.0,
            width: 200,
            height: 100,
        }
    }

    #[test]
    fn centre_looks_at_target_and_axes_follow_the_spec() {
        let c = cam();
        let r = c.generate_ray(Vec2::new(100.0, 50.0));
        assert!((r.dir - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
        // Image x grows to the right of the viewer: forward (-z) × up (+y) = +x.
        let right = c.generate_ray(Vec2::new(200.0, 50.0));
        assert!(right.dir.x > 0.0);
        // Image y grows downwards.
        let top = c.generate_ray(Vec2::new(100.0, 0.0));
        assert!(top.dir.y > 0.0);
        // The vertical field of view spans the image height.
        let angle = top.dir.angle_between(r.dir).to_degrees();
        assert!((angle - 20.0).abs() < 1e-3, "{angle}");
        // The horizontal extent follows the aspect ratio.
        let tan_h = (right.dir.x / -right.dir.z).abs();
        assert!((tan_h - 2.0 * (20.0f32).to_radians().tan()).abs() < 1e-5);
    }
}
