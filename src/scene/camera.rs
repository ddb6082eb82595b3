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
        let forward = (self.target - self.eye).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        let tan_half = (self.fov_deg.to_radians() * 0.5).tan();
        let aspect = self.width as f32 / self.height as f32;
        let sx = (2.0 * film.x / self.width as f32 - 1.0) * tan_half * aspect;
        let sy = (1.0 - 2.0 * film.y / self.height as f32) * tan_half;
        Ray::new(self.eye, (forward + right * sx + up * sy).normalize())
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
