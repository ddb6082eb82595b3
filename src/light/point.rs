//! A point light (Mitsuba 3's `point`): radiant intensity `intensity` (W/sr) in every
//! direction from one position. A delta light: it can be sampled but never hit.

use glam::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity (W/sr) per channel.
    pub intensity: Vec3,
}

impl PointLight {
    /// Radiant intensity towards the unit direction `w` leaving the light.
    #[inline]
    pub fn intensity_towards(&self, _w: Vec3) -> Vec3 {
        self.intensity
    }

    /// Emitted power (mean over the channels): 4π I.
    pub fn power(&self) -> f64 {
        4.0 * std::f64::consts::PI * (self.intensity.element_sum() as f64 / 3.0)
    }
}
