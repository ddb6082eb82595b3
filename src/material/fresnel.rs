//! Exact unpolarised Fresnel reflectance of a smooth dielectric interface.
//!
//! The same formulation as Mitsuba 3's `fresnel(cos_theta_i, eta)` (`mitsuba/render/fresnel.h`),
//! itself the textbook result (e.g. Born & Wolf, *Principles of Optics*, §1.5; pbrt-v4 §9.5):
//! the average of the s- and p-polarised reflectances.
//!
//! Conventions:
//! - `eta` = η_inside / η_outside of the interface (the material's `ior` against 1.0).
//! - `cos_theta_i` is the cosine between the incident direction (pointing away from the
//!   surface) and the normal that points to the OUTSIDE; a negative value means the incident
//!   direction lies inside the material.
//! - The returned `cos_theta_t` has the opposite sign to `cos_theta_i` (the transmitted
//!   direction lies on the other side) and is 0 under total internal reflection (F = 1).

/// The result of [`fresnel_dielectric`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Fresnel {
    /// Unpolarised reflectance F ∈ [0, 1].
    pub reflectance: f32,
    /// Signed cosine of the transmitted direction (opposite sign to `cos_theta_i`).
    pub cos_theta_t: f32,
    /// Relative index η_t / η_i of the interface as crossed from the incident side.
    pub eta_it: f32,
    /// Its reciprocal η_i / η_t.
    pub eta_ti: f32,
}

/// Fresnel reflectance for incidence cosine `cos_theta_i` on an interface of relative index
/// `eta` (inside over outside).
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> Fresnel {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };

    // Snell: sin²θt = sin²θi · (ηi/ηt)².
    let cos_i = cos_theta_i.abs().min(1.0);
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
    if cos_t_sqr <= 0.0 {
        // Total internal reflection.
        return Fresnel { reflectance: 1.0, cos_theta_t: 0.0, eta_it, eta_ti };
    }
    let cos_t = cos_t_sqr.sqrt();

    let reflectance = if eta == 1.0 {
        0.0
    } else if cos_i == 0.0 {
        1.0
    } else {
        let a_s = (cos_i - eta_it * cos_t) / (cos_i + eta_it * cos_t);
        let a_p = (cos_t - eta_it * cos_i) / (cos_t + eta_it * cos_i);
        (0.5 * (a_s * a_s + a_p * a_p)).clamp(0.0, 1.0)
    };
    let cos_theta_t = if outside { -cos_t } else { cos_t };
    Fresnel { reflectance, cos_theta_t, eta_it, eta_ti }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form_from_both_sides() {
        for eta in [1.1f32, 1.333, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            let out = fresnel_dielectric(1.0, eta);
            let inn = fresnel_dielectric(-1.0, eta);
            assert!((out.reflectance - r0).abs() < 1e-6, "{eta}: {}", out.reflectance);
            assert!((inn.reflectance - r0).abs() < 1e-6);
            assert_eq!(out.cos_theta_t, -1.0);
            assert_eq!(inn.cos_theta_t, 1.0);
            assert_eq!(out.eta_it, eta);
            assert_eq!(inn.eta_it, 1.0 / eta);
        }
    }

    #[test]
    fn total_internal_reflection_beyond_critical_angle() {
        let eta = 1.5f32;
        let sin_c = 1.0 / eta;
        let cos_c = (1.0 - sin_c * sin_c).sqrt();
        // Just beyond the critical angle (smaller cosine), from inside.
        let f = fresnel_dielectric(-(cos_c - 1e-3), eta);
        assert_eq!(f.reflectance, 1.0);
        // Just inside it: partial transmission, reflectance high but below 1.
        let f = fresnel_dielectric(-(cos_c + 1e-3), eta);
        assert!(f.reflectance < 1.0 && f.reflectance > 0.3, "{}", f.reflectance);
        // From outside there is never TIR.
        assert!(fresnel_dielectric(1e-3, eta).reflectance < 1.0);
    }

    #[test]
    fn grazing_and_index_matched_limits() {
        assert_eq!(fresnel_dielectric(0.0, 1.5).reflectance, 1.0);
        assert_eq!(fresnel_dielectric(0.7, 1.0).reflectance, 0.0);
        // Reflectance grows monotonically towards grazing incidence (eta > 1, outside),
        // apart from the dip towards Brewster's angle which is in the p-component only.
        let r_45 = fresnel_dielectric(std::f32::consts::FRAC_1_SQRT_2, 1.5).reflectance;
        let r_85 = fresnel_dielectric(85f32.to_radians().cos(), 1.5).reflectance;
        assert!(r_85 > r_45 && r_45 > 0.04 && r_45 < 0.06);
    }
}
