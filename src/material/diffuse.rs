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
#[inline(always)]
pub fn sample(u: Vec2) -> Vec3 {
    cosine_hemisphere(u)
}

/// [`eval`] and [`pdf`] at once from cos θi alone (`cos_i > 0`, the caller's check): the
/// lobe needs no other coordinate of `wi`, so its callers skip the rest of the shading-frame
/// change. The values are bit for bit those of the two functions. The pdf is zero for a black
/// albedo, which the sampler never draws from.
#[inline]
pub fn eval_pdf_cos(albedo: Vec3, cos_i: f32) -> (Vec3, f32) {
    let c = FRAC_1_PI * cos_i.max(0.0);
    (albedo * c, if albedo.max_element() > 0.0 && c.is_finite() { c } else { 0.0 })
}
