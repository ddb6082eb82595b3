//! Conductors as Mitsuba 3 defines them: `conductor` (a smooth metal, a delta lobe) and
//! `roughconductor` (a microfacet lobe, [`super::microfacet`]), both weighted by the Fresnel
//! reflectance of a complex index of refraction η + i k per channel and by
//! `specular_reflectance`.
//!
//! - Smooth: wi = reflect(wo, n), weight = specular · F(cos θo).
//! - Rough: f · cos θi = specular · F(wo·h) D(h) G1(wo, h) G1(wi, h) / (4 cos θo), sampled by
//!   reflecting `wo` about a sampled normal (Mitsuba's `roughconductor`).
//!
//! [`fresnel_conductor`] is Mitsuba's formula (`fresnel.h`, after K. D. Möller, *Optics*,
//! 1988): the mean of the s- and p-polarised reflectances. Material "none" is η = 0, k = 1,
//! where F = 1 at every angle: a perfect mirror, pir's [`super::Bsdf::Mirror`] and
//! [`super::Bsdf::Glossy`] without albedo.
//!
//! Local shading frame (normal = +z); the caller checks the hemispheres.

use glam::{Vec2, Vec3};

use super::microfacet::Microfacet;

/// A complex index of refraction η + i k per RGB channel, relative to the outside medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComplexIor {
    pub eta: Vec3,
    pub k: Vec3,
}

impl ComplexIor {
    /// Material "none": F = 1 at every angle.
    pub const NONE: ComplexIor = ComplexIor { eta: Vec3::ZERO, k: Vec3::ONE };

    /// F(cos θ) per channel.
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> Vec3 {
        Vec3::new(
            fresnel_conductor(cos_theta, self.eta.x, self.k.x),
            fresnel_conductor(cos_theta, self.eta.y, self.k.y),
            fresnel_conductor(cos_theta, self.eta.z, self.k.z),
        )
    }
}

/// The unpolarised Fresnel reflectance of a conductor of index `eta` + i `k` for incidence
/// cosine `cos_theta_i` (Mitsuba 3's `fresnel_conductor`).
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let c2 = cos_theta_i * cos_theta_i;
    let s2 = 1.0 - c2;
    let s4 = s2 * s2;
    let temp_1 = eta * eta - k * k - s2;
    let a2pb2 = (temp_1 * temp_1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2pb2 + temp_1)).max(0.0).sqrt();
    let term_1 = a2pb2 + c2;
    let term_2 = 2.0 * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a2pb2 * c2 + s4;
    let term_4 = term_2 * s2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    let f = 0.5 * (r_s + r_p);
    if f.is_finite() { f.clamp(0.0, 1.0) } else { 1.0 }
}

/// The rough conductor's lobe.
#[derive(Clone, Copy, Debug)]
pub struct RoughConductor {
    pub specular: Vec3,
    pub ior: ComplexIor,
    pub microfacet: Microfacet,
}

impl RoughConductor {
    /// f · cos θi for `wo`, `wi` (local).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (v, cos_h) = self.microfacet.reflect_eval(wo, wi);
        if v == 0.0 {
            return Vec3::ZERO;
        }
        self.specular * self.ior.reflectance(cos_h) * v
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.microfacet.pdf_reflect(wo, wi)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        if wo.z <= 0.0 {
            return None;
        }
        self.microfacet.sample_reflect(wo, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Material "none" reflects everything at every angle; a dielectric-like index (k = 0)
    /// gives the dielectric Fresnel reflectance ((η − 1)/(η + 1))² at normal incidence; gold's
    /// RGB index reflects more red than blue.
    #[test]
    fn fresnel_limits() {
        for c in [1.0f32, 0.7, 0.2, 0.0] {
            assert!((fresnel_conductor(c, 0.0, 1.0) - 1.0).abs() < 1e-6, "{c}");
        }
        let eta = 1.5f32;
        let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((fresnel_conductor(1.0, eta, 0.0) - r0).abs() < 1e-6);
        let d = super::super::fresnel::fresnel_dielectric(0.5, eta).reflectance;
        assert!((fresnel_conductor(0.5, eta, 0.0) - d).abs() < 1e-5, "{d}");
        // Mitsuba 3 (scalar_rgb) gives these for the living room's copper-like index at
        // normal incidence: ((η−1)² + k²) / ((η+1)² + k²).
        let (e, k) = (0.200438f32, 3.91295f32);
        let exact = ((e - 1.0).powi(2) + k * k) / ((e + 1.0).powi(2) + k * k);
        assert!((fresnel_conductor(1.0, e, k) - exact).abs() < 1e-6);
        assert_eq!(fresnel_conductor(0.0, e, k), 1.0);
    }
}
