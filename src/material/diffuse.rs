//! The Lambertian lobe: f = albedo / π, sampled with a cosine-weighted hemisphere
//! (Malley's method, pdf = cos θi / π), as Mitsuba 3's `diffuse`.
//!
//! Local shading frame (normal = +z); the caller has checked that `wo` and `wi` are above the
//! shading and geometric surfaces. `eval` includes the cosine: albedo · cos θi / π.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use crate::sampling::cosine_hemisphere;

/// albedo / π · cos θi (zero for `wi` below the shading horizon).
pub fn eval(albedo: Vec3, wi: Vec3) -> Vec3 {
    albedo * (FRAC_1_PI * wi.z.max(0.0))
}

/// Solid-angle density of [`sample`]: cos θi / π.
pub fn pdf(wi: Vec3) -> f32 {
    FRAC_1_PI * wi.z.max(0.0)
}

/// A cosine-distributed direction about +z.
pub fn sample(u: Vec2) -> Vec3 {
    cosine_hemisphere(u)
}
