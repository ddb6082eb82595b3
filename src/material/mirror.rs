//! Perfect specular reflection about the shading normal, weighted by `specular` (the scene
//! format's `mirror`; Mitsuba 3's `conductor` with material "none" and
//! `specular_reflectance` = specular).
//!
//! wi = 2 (wo·n) n − wo. As a delta lobe it has no density: `sample` reports pdf 1 (the
//! probability of the only lobe) and weight = specular.

use glam::Vec3;

/// The mirror direction of `wo` about the unit normal `n`.
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}
