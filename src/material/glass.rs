//! A smooth dielectric interface of index `ior` against 1.0 (the scene format's `glass`,
//! Mitsuba 3's `dielectric`): reflection with the exact unpolarised Fresnel reflectance F
//! ([`super::fresnel`]), refraction with 1 − F, no absorption.
//!
//! Sampling follows Mitsuba 3's `SmoothDielectric::sample`: reflection is chosen with
//! probability F and refraction with 1 − F, so the weights are F/F = 1 and (1−F)/(1−F) = 1,
//! times (η_i/η_t)² for refraction in radiance mode (radiance is compressed into the denser
//! medium; importance is not). Here i is the side of `wo` and t the side `wi` enters.
//!
//! The side is decided with the SHADING normal: `wo·n > 0` means `wo` is outside (in the
//! medium of index 1) and the light enters the glass. Beyond the critical angle from inside,
//! F = 1 (total internal reflection) and the sample is always a reflection.

use glam::Vec3;

use super::TransportMode;
use super::fresnel::fresnel_dielectric;
use super::mirror::reflect;

/// A sampled glass interaction (before the importance shading-normal correction).
pub struct GlassSample {
    pub wi: Vec3,
    /// Scalar weight (the same for every channel).
    pub weight: f32,
    /// Discrete probability of the chosen lobe (F or 1 − F).
    pub prob: f32,
    /// Relative index crossed: η_t / η_i for refraction, 1 for reflection.
    pub eta: f32,
}

/// Chooses reflection or refraction of `wo` at an interface with unit normal `n` (pointing to
/// the outside, index 1) and relative index `ior`.
pub fn sample(n: Vec3, ior: f32, wo: Vec3, u_lobe: f32, mode: TransportMode) -> Option<GlassSample> {
    let cos_i = wo.dot(n);
    if cos_i == 0.0 || !cos_i.is_finite() || ior.is_nan() || ior <= 0.0 {
        return None;
    }
    let f = fresnel_dielectric(cos_i, ior);
    let r = f.reflectance;
    if u_lobe < r {
        return Some(GlassSample { wi: reflect(wo, n), weight: 1.0, prob: r, eta: 1.0 });
    }
    let t = 1.0 - r;
    if t <= 0.0 {
        return None;
    }
    // Tangential component scales by η_i/η_t and flips; the normal component is cos θt.
    let wi = (-f.eta_ti * (wo - cos_i * n) + f.cos_theta_t * n).try_normalize()?;
    let weight = match mode {
        TransportMode::Radiance => f.eta_ti * f.eta_ti,
        TransportMode::Importance => 1.0,
    };
    Some(GlassSample { wi, weight, prob: t, eta: f.eta_it })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An interface between equal indices (Mitsuba's `dielectric` with `int_ior` = `ext_ior`)
    /// never reflects and lets every direction through unchanged, with weight 1, from either
    /// side and in both transport modes.
    #[test]
    fn an_index_matched_interface_is_crossed_unchanged() {
        let n = Vec3::Z;
        for wo in [Vec3::new(0.3, -0.2, 0.9), Vec3::new(-0.6, 0.1, -0.4), Vec3::new(0.99, 0.0, 0.05)] {
            let wo = wo.normalize();
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                for u in [0.0, 0.5, 0.999] {
                    let s = sample(n, 1.0, wo, u, mode).unwrap();
                    assert!((s.wi + wo).length() < 1e-6, "{wo} -> {}", s.wi);
                    assert_eq!((s.weight, s.prob, s.eta), (1.0, 1.0, 1.0));
                }
            }
        }
    }
}
