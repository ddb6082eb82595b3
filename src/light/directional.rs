//! A directional light (Mitsuba 3's `directional`): irradiance `irradiance` (W/m²) on a
//! surface facing it, arriving along one direction from infinitely far. A delta light (in
//! direction) at infinity.

use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct DirectionalLight {
    /// The unit direction the light travels in.
    pub direction: Vec3,
    pub irradiance: Vec3,
}

impl DirectionalLight {
    /// Emitted power into a scene of bounding-sphere radius `radius` (mean over the channels):
    /// E π r², the flux through the sphere's cross-section (pbrt's and Mitsuba's convention).
    pub fn power(&self, radius: f32) -> f64 {
        let r = radius as f64;
        std::f64::consts::PI * r * r * (self.irradiance.element_sum() as f64 / 3.0)
    }
}
