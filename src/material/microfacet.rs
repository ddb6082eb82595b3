//! Isotropic microfacet distributions as Mitsuba 3 defines them (`mitsuba/render/microfacet.h`):
//! GGX and Beckmann, Smith's separable masking G1(wo) G1(wi), and how pir samples them.
//!
//! - GGX: D(m) = 1 / (π α² ((x² + y²)/α² + z²)²), G1 = 2 / (1 + √(1 + α² tan²θ)) — the same
//!   numbers as [`super::ggx::Ggx`], which keeps the glossy material's own code.
//! - Beckmann: D(m) = exp(−tan²θm / α²) / (π α² cos⁴θm); G1 by Mitsuba's rational fit of
//!   a = 1 / (α tan θ): (3.535 a + 2.181 a²) / (1 + 2.276 a + 2.577 a²) below a = 1.6, else 1
//!   (Walter et al. 2007, eq. 27; < 0.35 % from the exact Smith term).
//! - G1(v, m) = 0 where v sees the back of the microfacet ((v·m)(v·n) ≤ 0), 1 at normal
//!   incidence. α is clamped to ≥ 1e-4 as Mitsuba does.
//!
//! Sampling: the normals visible from `wo`, density G1(wo, m) max(0, wo·m) D(m) / cos θo, as
//! Mitsuba's `sample_visible`: GGX by Heitz 2018, Beckmann by Mitsuba's numerical inversion of
//! the visible slopes (Jakob's improvement of Heitz & d'Eon 2014). Beckmann's visible density
//! uses the exact Smith term, G1 = 1 / (1 + Λ), Λ(a) = (e^(−a²) / (a √π) − erfc a) / 2, which
//! is the density the inversion draws; its evaluation keeps Mitsuba's rational fit.
//!
//! Local shading frame (normal = +z).

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

use super::ggx::{Ggx, MIN_ALPHA};

/// Which distribution of microfacet normals.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Distribution {
    Ggx,
    Beckmann,
}

impl Distribution {
    /// Mitsuba's name of it.
    pub fn name(self) -> &'static str {
        match self {
            Distribution::Ggx => "ggx",
            Distribution::Beckmann => "beckmann",
        }
    }
}

/// A distribution of microfacet normals with its roughness α.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: Distribution,
    pub alpha: f32,
}

impl Microfacet {
    pub fn new(kind: Distribution, alpha: f32) -> Self {
        let alpha = if alpha.is_finite() { alpha.max(MIN_ALPHA) } else { 1.0 };
        Microfacet { kind, alpha }
    }

    /// D(m), per unit solid angle of m, projected: ∫ D(m) cos θm dm = 1.
    #[inline]
    pub fn d(&self, m: Vec3) -> f32 {
        match self.kind {
            Distribution::Ggx => Ggx::new(self.alpha).d(m),
            Distribution::Beckmann => {
                if m.z <= 0.0 {
                    return 0.0;
                }
                let a2 = self.alpha * self.alpha;
                let z2 = m.z * m.z;
                let d = (-(m.x * m.x + m.y * m.y) / (a2 * z2)).exp() / (PI * a2 * z2 * z2);
                if d.is_finite() && d * m.z > 1e-20 { d } else { 0.0 }
            }
        }
    }

    /// Smith's masking G1(v, m).
    #[inline]
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        match self.kind {
            Distribution::Ggx => Ggx::new(self.alpha).g1(v, m),
            Distribution::Beckmann => {
                if v.dot(m) * v.z <= 0.0 {
                    return 0.0;
                }
                let xy2 = self.alpha * self.alpha * (v.x * v.x + v.y * v.y);
                if xy2 == 0.0 {
                    return 1.0;
                }
                let a = (v.z * v.z / xy2).sqrt();
                if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) }
            }
        }
    }

    /// A microfacet normal for the direction `wo` (`wo.z > 0`).
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Vec3 {
        match self.kind {
            Distribution::Ggx => Ggx::new(self.alpha).sample_visible(wo, u),
            Distribution::Beckmann => {
                let a = self.alpha;
                // Stretch wo to the configuration of α = 1, sample the slopes there, rotate
                // and unstretch them.
                let w = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize_or(Vec3::Z);
                let sin2 = w.x * w.x + w.y * w.y;
                let (sin_phi, cos_phi) = if sin2 <= 4.0 * f32::EPSILON {
                    (0.0, 1.0)
                } else {
                    let inv = 1.0 / sin2.sqrt();
                    ((w.y * inv).clamp(-1.0, 1.0), (w.x * inv).clamp(-1.0, 1.0))
                };
                let s = beckmann_visible_slopes(w.z, u);
                let sx = (cos_phi * s.x - sin_phi * s.y) * a;
                let sy = (sin_phi * s.x + cos_phi * s.y) * a;
                Vec3::new(-sx, -sy, 1.0).normalize_or(Vec3::Z)
            }
        }
    }

    /// The density of [`Microfacet::sample`] drawing `m` for `wo`.
    #[inline]
    pub fn pdf(&self, wo: Vec3, m: Vec3) -> f32 {
        match self.kind {
            Distribution::Ggx => Ggx::new(self.alpha).pdf_visible(wo, m),
            Distribution::Beckmann => {
                if wo.z <= 0.0 {
                    return 0.0;
                }
                self.smith_exact(wo, m) * wo.dot(m).max(0.0) * self.d(m) / wo.z
            }
        }
    }

    /// Beckmann's exact Smith masking 1 / (1 + Λ(a)), a = 1 / (α tan θ): the density of the
    /// visible normals that [`Microfacet::sample`] draws.
    fn smith_exact(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy2 = self.alpha * self.alpha * (v.x * v.x + v.y * v.y);
        if xy2 == 0.0 {
            return 1.0;
        }
        let a = (v.z * v.z / xy2).sqrt() as f64;
        if a > 8.0 {
            return 1.0;
        }
        let lambda = ((-a * a).exp() / (a * std::f64::consts::PI.sqrt()) - erfc(a)) / 2.0;
        (1.0 / (1.0 + lambda)) as f32
    }

    /// The density of a reflection about a sampled normal: `wi` given `wo`, both above the
    /// horizon, h their half vector (the Jacobian 1 / (4 |wo·h|)).
    #[inline]
    pub fn pdf_reflect(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = (wo + wi).try_normalize() else { return 0.0 };
        let p = self.pdf(wo, h) / (4.0 * wo.dot(h).abs());
        if p.is_finite() { p } else { 0.0 }
    }

    /// Samples a reflected direction for `wo`: `None` below the horizon.
    #[inline]
    pub fn sample_reflect(&self, wo: Vec3, u: Vec2) -> Option<Vec3> {
        let m = self.sample(wo, u);
        let wi = 2.0 * wo.dot(m) * m - wo;
        (wi.z > 0.0 && wi.is_finite()).then_some(wi)
    }

    /// D(h) G1(wo, h) G1(wi, h) / (4 cos θo) for the half vector h of `wo` and `wi`: the
    /// reflection lobe's f · cos θi without its Fresnel factor, which is returned apart with
    /// wo·h for the caller. Zero (and 0) where either is below the horizon.
    #[inline]
    pub fn reflect_eval(&self, wo: Vec3, wi: Vec3) -> (f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (0.0, 0.0);
        }
        let Some(h) = (wo + wi).try_normalize() else { return (0.0, 0.0) };
        let v = self.d(h) * self.g1(wo, h) * self.g1(wi, h) / (4.0 * wo.z);
        (if v.is_finite() { v } else { 0.0 }, wo.dot(h))
    }
}

/// The slopes of a Beckmann microfacet visible from a direction of cosine `cos_i` (α = 1,
/// the direction in the xz-plane): Mitsuba's `sample_visible_11`, a Newton inversion of the
/// visible slopes' cumulative distribution in the erf domain.
fn beckmann_visible_slopes(cos_i: f32, u: Vec2) -> Vec2 {
    const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
    let cos_i = (cos_i as f64).clamp(1e-7, 1.0);
    let tan_i = (1.0 - cos_i * cos_i).max(0.0).sqrt() / cos_i;
    let cot_i = 1.0 / tan_i;
    let maxval = erf(cot_i);
    let (ux, uy) = ((u.x as f64).clamp(1e-6, 1.0 - 1e-6), (u.y as f64).clamp(1e-6, 1.0 - 1e-6));
    let mut x = maxval - (maxval + 1.0) * erf((-ux.ln()).sqrt());
    let ux = ux * (1.0 + maxval + INV_SQRT_PI * tan_i * (-cot_i * cot_i).exp());
    for _ in 0..3 {
        let slope = erfinv(x);
        let value = 1.0 + x + INV_SQRT_PI * tan_i * (-slope * slope).exp() - ux;
        let derivative = 1.0 - slope * tan_i;
        x -= value / derivative;
    }
    Vec2::new(erfinv(x) as f32, erfinv(2.0 * uy - 1.0) as f32)
}

/// erf(x) to about 1e-7 (Abramowitz & Stegun 7.1.26 refined: W. J. Cody's rational form is
/// overkill here; the inversion's Newton steps absorb the error).
fn erf(x: f64) -> f64 {
    if x.is_infinite() {
        return x.signum();
    }
    1.0 - erfc(x)
}

/// erfc(x), Numerical Recipes' Chebyshev fit (relative error < 1.2e-7 everywhere).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let r = t
        * (-z * z - 1.265_512_23
            + t * (1.000_023_68
                + t * (0.374_091_96
                    + t * (0.096_784_18
                        + t * (-0.186_288_06
                            + t * (0.278_868_07
                                + t * (-1.135_203_98
                                    + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77)))))))))
            .exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// erf⁻¹(x) for x in (−1, 1): Giles' approximation (2010), as Mitsuba 3's `erfinv`. Newton
/// steps on [`erf`] (whose own error is about 1e-7) changed no slope by more than 3e-8 and
/// cost two exponentials each, a tenth of a Beckmann sample's time: the test
/// `erfinv_inverts_erf` holds it to erf's accuracy.
fn erfinv(x: f64) -> f64 {
    let x = x.clamp(-1.0 + 1e-15, 1.0 - 1e-15);
    let w = -((1.0 - x) * (1.0 + x)).ln();
    if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.810_226_36e-08;
        for c in [
            3.432_739_39e-07,
            -3.523_387_7e-06,
            -4.391_506_54e-06,
            0.000_218_580_87,
            -0.001_253_725_03,
            -0.004_177_681_64,
            0.246_640_727,
            1.501_409_41,
        ] {
            p = c + p * w;
        }
        p * x
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_257;
        for c in [
            0.000_100_950_558,
            0.001_349_343_22,
            -0.003_673_428_44,
            0.005_739_507_73,
            -0.007_622_461_3,
            0.009_438_870_47,
            1.001_674_06,
            2.832_976_82,
        ] {
            p = c + p * w;
        }
        p * x
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Domain, Sampler, uniform_cone};

    /// erf⁻¹ inverts erf to erf's own accuracy (about 1e-7) over (−1, 1), odd.
    #[test]
    fn erfinv_inverts_erf() {
        let mut worst = 0.0f64;
        for i in 1..400_000 {
            let x = -1.0 + 2.0 * i as f64 / 400_000.0;
            let y = erfinv(x);
            worst = worst.max((erf(y) - x).abs());
            assert_eq!(erfinv(-x), -y, "{x}");
        }
        assert!(worst < 3e-7, "{worst}");
    }

    /// ∫ D(m) cos θm dm = 1 for both kinds (midpoint rule in θ with a fine grid near 0).
    #[test]
    fn projected_area_is_one() {
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.01f32, 0.1, 0.5, 1.0] {
                let mf = Microfacet::new(kind, alpha);
                let n = 400_000;
                let mut sum = 0.0f64;
                for i in 0..n {
                    // θ = atan(α t), t = x / (1 − x): resolves the peak.
                    let x = (i as f64 + 0.5) / n as f64;
                    let t = x / (1.0 - x);
                    let dt = 1.0 / ((1.0 - x) * (1.0 - x)) / n as f64;
                    let theta = (alpha as f64 * t).atan();
                    let dtheta = alpha as f64 / (1.0 + (alpha as f64 * t).powi(2)) * dt;
                    let m = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
                    sum += mf.d(m) as f64 * theta.cos() * theta.sin() * 2.0 * std::f64::consts::PI * dtheta;
                }
                assert!((sum - 1.0).abs() < 3e-3, "{kind:?} alpha {alpha}: {sum}");
            }
        }
    }

    /// The reflection density integrates to the probability that the reflected direction
    /// stays above the horizon, and the sampled directions' histogram over the hemisphere
    /// follows it: the density of every sampled direction, averaged, estimates the integral
    /// of its square, checked against a uniform estimate of the same.
    #[test]
    fn reflection_density_matches_sampling() {
        let mut s = Sampler::new(11, 0, Domain::Iteration, 0);
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            for alpha in [0.15f32, 0.5] {
                let mf = Microfacet::new(kind, alpha);
                for cos_o in [0.9f32, 0.4] {
                    let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                    let n = 200_000;
                    // P(above horizon) by sampling, and ∫ pdf over the hemisphere uniformly.
                    let mut kept = 0usize;
                    let mut mean_pdf_sampled = 0.0f64;
                    for _ in 0..n {
                        if let Some(wi) = mf.sample_reflect(wo, s.next_2d()) {
                            kept += 1;
                            mean_pdf_sampled += mf.pdf_reflect(wo, wi) as f64;
                        }
                    }
                    let (mut integral, mut integral_sq) = (0.0f64, 0.0f64);
                    for _ in 0..n {
                        let wi = uniform_cone(s.next_2d(), 0.0);
                        let p = mf.pdf_reflect(wo, wi) as f64;
                        integral += p * 2.0 * std::f64::consts::PI / n as f64;
                        integral_sq += p * p * 2.0 * std::f64::consts::PI / n as f64;
                    }
                    let frac = kept as f64 / n as f64;
                    assert!((integral - frac).abs() < 0.02, "{kind:?} {alpha} {cos_o}: {integral} vs {frac}");
                    let e = mean_pdf_sampled / n as f64;
                    assert!(
                        (e - integral_sq).abs() < 0.05 * integral_sq,
                        "{kind:?} {alpha} {cos_o}: {e} vs {integral_sq}"
                    );
                }
            }
        }
    }

    #[test]
    fn beckmann_masking_limits() {
        let mf = Microfacet::new(Distribution::Beckmann, 0.3);
        assert_eq!(mf.g1(Vec3::Z, Vec3::Z), 1.0);
        let grazing = Vec3::new(1.0, 0.0, 1e-3).normalize();
        assert!(mf.g1(grazing, Vec3::Z) < 0.02);
        assert_eq!(mf.g1(Vec3::Z, -Vec3::Z), 0.0);
        // Continuous at a = 1.6 (to the fit's accuracy).
        let at = |a: f32| {
            let tan = 1.0 / (0.3 * a);
            mf.g1(Vec3::new(tan, 0.0, 1.0).normalize(), Vec3::Z)
        };
        assert!((at(1.5999) - at(1.6001)).abs() < 5e-3);
    }
}
