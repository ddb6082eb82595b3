//! Mitsuba 3's `thindielectric`: a thin dielectric sheet (a window pane) of index η, two
//! internal surfaces, no refraction of the ray: light is reflected about the normal with
//! probability R or passes straight through with T = 1 − R, where R sums the interreflections
//! inside the sheet, R = r (1 + T_r² / (1 − r²)) = 2r / (1 + r) for the single-interface
//! Fresnel reflectance r = F(|cos θo|). Both lobes are delta; each is sampled with its own
//! probability, so the weight is the lobe's reflectance or transmittance factor alone
//! (`specular_reflectance`, `specular_transmittance`). Two-sided.

use glam::Vec3;

use super::fresnel::fresnel_dielectric;
use super::mirror::reflect;

/// The sheet's reflectance R for incidence cosine `cos_o` (either side) and index `eta`.
pub fn reflectance(cos_o: f32, eta: f32) -> f32 {
    let r = fresnel_dielectric(cos_o.abs(), eta).reflectance;
    r * 2.0 / (1.0 + r)
}

/// Reflection (`true`, about the unit normal `n`) or transmission of `wo`, chosen by `u_lobe`:
/// the direction and the lobe's probability.
pub fn sample(n: Vec3, eta: f32, wo: Vec3, u_lobe: f32) -> Option<(Vec3, bool, f32)> {
    let cos_o = wo.dot(n);
    if cos_o == 0.0 || !cos_o.is_finite() {
        return None;
    }
    let r = reflectance(cos_o, eta);
    if u_lobe < r { Some((reflect(wo, n), true, r)) } else { (r < 1.0).then_some((-wo, false, 1.0 - r)) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At normal incidence and η = 1.5 a pane reflects 2r/(1+r) with r = 0.04: about 7.7 %;
    /// nothing at η = 1; everything at grazing incidence.
    #[test]
    fn pane_reflectance() {
        assert!((reflectance(1.0, 1.5) - 0.08 / 1.04).abs() < 1e-5);
        assert_eq!(reflectance(0.6, 1.0), 0.0);
        assert_eq!(reflectance(0.0, 1.5), 1.0);
        assert_eq!(reflectance(-0.5, 1.5), reflectance(0.5, 1.5));
    }
}
