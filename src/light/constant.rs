//! A constant environment (Mitsuba 3's `constant`): radiance `radiance` arriving from every
//! direction at infinity. Sampled uniformly over the sphere of directions, as Mitsuba does.

use glam::{Vec2, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub struct ConstantLight {
    pub radiance: Vec3,
}

/// The solid-angle density of a uniform direction: 1 / 4π.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * std::f32::consts::PI);

/// A uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

impl ConstantLight {
    /// Emitted power into a scene of bounding-sphere radius `radius` (mean over the channels):
    /// 4π L · π r², pbrt's convention for infinite lights.
    pub fn power(&self, radius: f32) -> f64 {
        let r = radius as f64;
        let pi = std::f64::consts::PI;
        4.0 * pi * pi * r * r * (self.radiance.element_sum() as f64 / 3.0)
    }
}
