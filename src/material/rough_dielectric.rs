//! Mitsuba 3's `roughdielectric`: a rough interface between two dielectrics (Walter et al.
//! 2007, "Microfacet Models for Refraction through Rough Surfaces"), as Mitsuba 3 writes it
//! (`src/bsdfs/roughdielectric.cpp`), with the microfacet distributions of
//! [`super::microfacet`] and the dielectric Fresnel term of [`super::fresnel`].
//!
//! In the local shading frame (+z towards the outside, index 1; the inside has relative index
//! `eta`), for `wo` on the side of relative index η (η = `eta` outside, 1/`eta` inside: the
//! index of the side `wi` enters when it refracts, over `wo`'s):
//!
//! - reflection (`wo`, `wi` on one side), m = normalize(wo + wi):
//!   f · |cos θi| = R · F(wo·m) D(m) G1(wo, m) G1(wi, m) / (4 |cos θo|);
//! - refraction (opposite sides), m = ±normalize(wo + η wi) (taken with m.z > 0):
//!   f · |cos θi| = T · s (1 − F) D G1 G1 η² |wo·m| |wi·m| / (|cos θo| (wo·m + η wi·m)²),
//!   s = 1/η² in radiance mode (radiance is compressed into the denser medium) and 1 in
//!   importance mode (Mitsuba's `TransportMode`; Veach 1997, §5.2);
//!
//! both zero unless each direction sees the microfacet from its own side ((v·m) cos θv > 0).
//! R and T are `specular_reflectance` and `specular_transmittance`. Sampling draws m from the
//! normals visible from `wo` (mirrored to the outside), then reflects with probability F(wo·m)
//! and refracts otherwise, so the pdf is D_wo(m) · {F, 1 − F} · |∂m/∂wi|, with the Jacobians
//! 1 / (4 |wi·m|) and η² |wi·m| / (wo·m + η wi·m)². It is two-sided by nature: the frame's +z
//! says which side is the outside, not which side is lit.
//!
//! The symmetries (Veach 1997, §5.2; Walter et al. 2007, eq. 21): with f* the importance-mode
//! BSDF and η_o, η_i the indices of the sides of `wo` and `wi`, f*(wo, wi) / η_i² is symmetric
//! under exchanging the directions, and the radiance-mode BSDF is the adjoint of the
//! importance-mode one, f(wo, wi) = f*(wi, wo), as bidirectional methods need
//! (`adjoint_modes_are_reciprocal` below).

use glam::{Vec2, Vec3};

use super::TransportMode;
use super::fresnel::fresnel_dielectric;
use super::microfacet::Microfacet;

/// The rough dielectric's lobes, in the local shading frame.
#[derive(Clone, Copy, Debug)]
pub struct RoughDielectric {
    /// Interior over exterior index of refraction.
    pub eta: f32,
    /// `specular_reflectance`, `specular_transmittance`.
    pub reflectance: Vec3,
    pub transmittance: Vec3,
    pub microfacet: Microfacet,
}

/// The geometry of a pair of directions at the interface.
struct Half {
    /// Microfacet normal, m.z > 0.
    m: Vec3,
    reflect: bool,
    /// Relative index η of the side `wi` refracts into, over `wo`'s.
    eta: f32,
    /// wo·m and wi·m.
    dot_o: f32,
    dot_i: f32,
}

impl RoughDielectric {
    /// The microfacet normal of `wo` and `wi`, `None` where the BSDF is zero whatever its
    /// values: a direction in the interface's plane, or one that sees the back of m.
    #[inline]
    fn half(&self, wo: Vec3, wi: Vec3) -> Option<Half> {
        let (co, ci) = (wo.z, wi.z);
        if co == 0.0 || ci == 0.0 || co.is_nan() || ci.is_nan() {
            return None;
        }
        let reflect = co * ci > 0.0;
        let eta = if co > 0.0 { self.eta } else { 1.0 / self.eta };
        let m = (wo + wi * if reflect { 1.0 } else { eta }).try_normalize()?;
        let m = if m.z < 0.0 { -m } else { m };
        let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
        (dot_o * co > 0.0 && dot_i * ci > 0.0).then_some(Half { m, reflect, eta, dot_o, dot_i })
    }

    /// f(wo, wi) · |cos θi| (`wo`, `wi` local, either side).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        let Some(h) = self.half(wo, wi) else { return Vec3::ZERO };
        let mf = &self.microfacet;
        let dg = mf.d(h.m) * mf.g1(wo, h.m) * mf.g1(wi, h.m);
        let f = fresnel_dielectric(h.dot_o, self.eta).reflectance;
        let v = if h.reflect {
            f * dg / (4.0 * wo.z.abs())
        } else {
            let scale = match mode {
                TransportMode::Radiance => 1.0 / (h.eta * h.eta),
                TransportMode::Importance => 1.0,
            };
            let den = h.dot_o + h.eta * h.dot_i;
            (scale * (1.0 - f) * dg * h.eta * h.eta * h.dot_o * h.dot_i / (wo.z * den * den)).abs()
        };
        if !v.is_finite() {
            return Vec3::ZERO;
        }
        v * if h.reflect { self.reflectance } else { self.transmittance }
    }

    /// The solid-angle density with which [`RoughDielectric::sample`] returns `wi`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = self.half(wo, wi) else { return 0.0 };
        let up = if wo.z < 0.0 { -wo } else { wo };
        let f = fresnel_dielectric(h.dot_o, self.eta).reflectance;
        let (choice, jacobian) = if h.reflect {
            (f, 1.0 / (4.0 * h.dot_i))
        } else {
            let den = h.dot_o + h.eta * h.dot_i;
            (1.0 - f, h.eta * h.eta * h.dot_i / (den * den))
        };
        let p = self.microfacet.pdf(up, h.m) * choice * jacobian.abs();
        if p.is_finite() { p.max(0.0) } else { 0.0 }
    }

    /// A direction for `wo` (either side): a visible microfacet normal from `u`, then
    /// reflection with probability F by `u_lobe`, refraction otherwise. `None` in the
    /// interface's plane, where nothing is left of the direction, or where it is masked.
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let co = wo.z;
        if co == 0.0 || co.is_nan() {
            return None;
        }
        let up = if co < 0.0 { -wo } else { wo };
        let m = self.microfacet.sample(up, u);
        let dot_o = wo.dot(m);
        let fr = fresnel_dielectric(dot_o, self.eta);
        let wi = if u_lobe < fr.reflectance {
            2.0 * dot_o * m - wo
        } else {
            // Mitsuba's `refract`: the tangential part scaled by η_i/η_t and flipped.
            m * (dot_o * fr.eta_ti + fr.cos_theta_t) - wo * fr.eta_ti
        };
        // A direction that leaves m on the wrong side of the macrosurface (a reflection below
        // it, a refraction back above it) is masked, G1(wi, m) = 0, as Mitsuba weighs it: it
        // would otherwise be evaluated as the other lobe, about another normal.
        let wi = wi.try_normalize()?;
        (wi.dot(m) * wi.z > 0.0).then_some(wi)
    }

    /// Whether anything leaves the surface at all (some reflectance or transmittance).
    pub fn is_black(&self) -> bool {
        !(self.reflectance.max_element() > 0.0 || self.transmittance.max_element() > 0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::super::microfacet::Distribution;
    use super::*;
    use crate::sampling::{Domain, Sampler, uniform_cone};

    fn lobes() -> [RoughDielectric; 4] {
        let white = Vec3::ONE;
        let lobe = |eta, kind, alpha| RoughDielectric {
            eta,
            reflectance: white,
            transmittance: white,
            microfacet: Microfacet::new(kind, alpha),
        };
        [
            lobe(1.5, Distribution::Ggx, 0.1),
            lobe(1.5, Distribution::Ggx, 0.5),
            lobe(1.33, Distribution::Beckmann, 0.2),
            lobe(2.4, Distribution::Beckmann, 0.6),
        ]
    }

    /// The radiance BSDF is the importance BSDF of the reversed pair, f(wo, wi) = f*(wi, wo),
    /// and f*(wo, wi) / η_i² = f*(wi, wo) / η_o² (η_o, η_i the indices of `wo`'s and `wi`'s
    /// sides). Here f is eval / |cos θi|, f* the importance-mode one.
    #[test]
    fn adjoint_modes_are_reciprocal() {
        let mut rng = Sampler::new(3, 0, Domain::Iteration, 0);
        let mut refractions = 0;
        for lobe in lobes() {
            for _ in 0..4000 {
                let (wo, wi) = (uniform_cone(rng.next_2d(), -1.0), uniform_cone(rng.next_2d(), -1.0));
                // Near grazing 1 − F loses its digits in f32 (F ≈ 0.98 ± 2e-4 from the two
                // sides: 1 % of the refracted value; Mitsuba's rounding too).
                let grazing = lobe
                    .half(wo, wi)
                    .is_some_and(|h| fresnel_dielectric(h.dot_o, lobe.eta).reflectance > 0.5);
                if wo.z.abs().min(wi.z.abs()) < 0.1 || grazing {
                    continue;
                }
                let index = |w: Vec3| if w.z > 0.0 { 1.0 } else { lobe.eta };
                let (eo, ei) = (index(wo), index(wi));
                let f = lobe.eval(wo, wi, TransportMode::Radiance) / wi.z.abs();
                let f_adj_rev = lobe.eval(wi, wo, TransportMode::Importance) / wo.z.abs();
                let f_adj = lobe.eval(wo, wi, TransportMode::Importance) / wi.z.abs();
                let tol = |a: Vec3| 1e-3 * a.abs().max_element() + 1e-6;
                assert!((f - f_adj_rev).abs().max_element() <= tol(f), "{wo} {wi}: {f} {f_adj_rev}");
                assert!(
                    (f_adj / (ei * ei) - f_adj_rev / (eo * eo)).abs().max_element() <= tol(f_adj / (ei * ei))
                );
                if wo.z * wi.z < 0.0 && f != Vec3::ZERO {
                    refractions += 1;
                }
            }
        }
        assert!(refractions > 1000, "{refractions}");
    }
}
