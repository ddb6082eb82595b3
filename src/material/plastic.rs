//! Mitsuba 3's `plastic` and `roughplastic`: a diffuse base under a dielectric coating of
//! relative index η (`int_ior / ext_ior`), with Mitsuba's formulas (`src/bsdfs/plastic.cpp`,
//! `roughplastic.cpp`).
//!
//! Smooth (`plastic`): the coating is a delta reflection of weight specular · F(cos θo); the
//! base gives
//!
//!   f · cos θi = ρ / (1 − F̄ᵢ) · (1 − F(cos θo)) (1 − F(cos θi)) / η² · cos θi / π,
//!
//! F̄ᵢ the diffuse Fresnel reflectance of the inside (`fresnel_diffuse_reflectance(1/η)`),
//! or ρ F̄ᵢ in place of F̄ᵢ when `nonlinear`. The coating is sampled with probability
//! F(cos θo) w / (F w + (1 − F)(1 − w)), w = s̄ / (ρ̄ + s̄) from the reflectances' means.
//!
//! Rough (`roughplastic`): the coating is a microfacet lobe specular · F(wo·h) D G1 G1 /
//! (4 cos θo); the base's (1 − F) factors become the coating's transmittance T(cos θ) and
//! F̄ᵢ its internal reflectance, both integrated numerically once per (distribution, α, η)
//! as Mitsuba does ([`RoughPlasticTable`]). The lobe is picked with (1 − T) w against T (1 − w).
//!
//! Local shading frame (normal = +z); the caller checks the hemispheres.

use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::{Mutex, OnceLock};

use glam::{Vec2, Vec3};

use super::fresnel::fresnel_dielectric;
use super::microfacet::{Distribution, Microfacet};
use super::{diffuse, mirror};
use crate::sampling::reuse::{choose, refined};

/// Mitsuba's fit of the diffuse Fresnel reflectance (the reflectance of the interface averaged
/// over the cosine-weighted hemisphere) for relative index `eta`: Egan & Hilgeman (1973)
/// below 1, d'Eon & Irving (2011) above.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        0.919317 + inv * (-3.4793 + inv * (6.75335 + inv * (-7.80989 + inv * (4.98554 + inv * -1.36881))))
    }
}

/// The probability of sampling the specular lobe given the weights of the two lobes (Mitsuba's
/// normalisation).
#[inline]
fn specular_probability(specular: f32, diffuse: f32) -> f32 {
    let sum = specular + diffuse;
    if sum > 0.0 { specular / sum } else { 0.0 }
}

/// ρ / (1 − F̄ᵢ), or ρ / (1 − ρ F̄ᵢ) when nonlinear.
#[inline]
fn base(diffuse: Vec3, internal: f32, nonlinear: bool) -> Vec3 {
    if nonlinear { diffuse / (Vec3::ONE - diffuse * internal) } else { diffuse / (1.0 - internal) }
}

/// The smooth plastic at one point.
#[derive(Clone, Copy, Debug)]
pub struct Plastic {
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub eta: f32,
    /// w = s̄ / (ρ̄ + s̄), of the reflectances' means over the surface.
    pub specular_weight: f32,
    pub nonlinear: bool,
}

impl Plastic {
    /// The probability of sampling the coating for `wo` at cosine `cos_o`.
    #[inline]
    pub fn specular_probability(&self, cos_o: f32) -> f32 {
        let f = fresnel_dielectric(cos_o, self.eta).reflectance;
        specular_probability(f * self.specular_weight, (1.0 - f) * (1.0 - self.specular_weight))
    }

    /// The base's f · cos θi.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let f_o = fresnel_dielectric(wo.z, self.eta).reflectance;
        let f_i = fresnel_dielectric(wi.z, self.eta).reflectance;
        let internal = fresnel_diffuse_reflectance(1.0 / self.eta);
        base(self.diffuse, internal, self.nonlinear)
            * ((1.0 - f_o) * (1.0 - f_i) / (self.eta * self.eta) * FRAC_1_PI * wi.z)
    }

    /// The density of sampling `wi` through the base.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.specular_probability(wo.z)) * diffuse::pdf(wi)
    }

    /// The coating's delta reflection: its direction (about +z), weight and probability.
    #[inline]
    pub fn specular_sample(&self, wo: Vec3) -> (Vec3, Vec3, f32) {
        let f = fresnel_dielectric(wo.z, self.eta).reflectance;
        let p = self.specular_probability(wo.z);
        (mirror::reflect(wo, Vec3::Z), self.specular * (f / p), p)
    }

    /// Chooses the lobe from `u` (its first number refined by `u_lobe`): the coating's
    /// reflection (`Err`: weight, probability) or a base direction (`Ok`).
    #[inline]
    pub fn choose(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Result<Vec3, (Vec3, Vec3, f32)> {
        let (specular, x) = choose(refined(u.x, u_lobe), self.specular_probability(wo.z));
        if specular { Err(self.specular_sample(wo)) } else { Ok(diffuse::sample(Vec2::new(x, u.y))) }
    }
}

/// Samples of T(cos θ) over cos θ ∈ [0, 1] (Mitsuba's `MI_ROUGH_TRANSMITTANCE_RES`).
pub const TRANSMITTANCE_RES: usize = 64;

/// The rough coating's integrals for one (distribution, α, η): T(cos θ) of light entering it
/// from outside, and the internal reflectance F̄ᵢ of light inside (Mitsuba's
/// `eval_transmittance` and `eval_reflectance` over visible normals).
#[derive(Debug, PartialEq)]
pub struct RoughPlasticTable {
    pub microfacet: Microfacet,
    pub eta: f32,
    pub transmittance: [f32; TRANSMITTANCE_RES],
    pub internal: f32,
}

impl RoughPlasticTable {
    /// The table of these parameters, computed once per process and shared (materials with
    /// the same coating share one).
    pub fn get(kind: Distribution, alpha: f32, eta: f32) -> &'static RoughPlasticTable {
        type Key = (Distribution, u32, u32);
        static TABLES: OnceLock<Mutex<HashMap<Key, &'static RoughPlasticTable>>> = OnceLock::new();
        let key = (kind, alpha.to_bits(), eta.to_bits());
        let tables = TABLES.get_or_init(Default::default);
        if let Some(t) = tables.lock().unwrap_or_else(|e| e.into_inner()).get(&key) {
            return t;
        }
        // Computed outside the lock (a few milliseconds); a race computes it twice.
        let table: &'static RoughPlasticTable = Box::leak(Box::new(Self::compute(kind, alpha, eta)));
        tables.lock().unwrap_or_else(|e| e.into_inner()).entry(key).or_insert(table)
    }

    fn compute(kind: Distribution, alpha: f32, eta: f32) -> RoughPlasticTable {
        let microfacet = Microfacet::new(kind, alpha);
        let mus: Vec<f32> =
            (0..TRANSMITTANCE_RES).map(|i| (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6)).collect();
        let mut transmittance = [0.0; TRANSMITTANCE_RES];
        for (t, &mu) in transmittance.iter_mut().zip(&mus) {
            *t = coating_integral(&microfacet, mu, eta, false);
        }
        let internal =
            mus.iter().map(|&mu| coating_integral(&microfacet, mu, 1.0 / eta, true) * mu).sum::<f32>()
                / TRANSMITTANCE_RES as f32
                * 2.0;
        RoughPlasticTable { microfacet, eta, transmittance, internal }
    }

    /// T(cos θ) by linear interpolation of the table (Mitsuba's `lerp_gather`).
    #[inline]
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        let x = cos_theta.clamp(0.0, 1.0) * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x as usize).min(TRANSMITTANCE_RES - 2);
        let w = x - i as f32;
        (1.0 - w) * self.transmittance[i] + w * self.transmittance[i + 1]
    }
}

/// ∫ over the normals visible from wi (cos θi = `mu`) of the Fresnel reflectance (`reflect`)
/// or transmittance at relative index `eta`, times the masking of the scattered direction:
/// Mitsuba's `eval_reflectance` / `eval_transmittance`. The normals are drawn from pir's own
/// [`Microfacet::sample`] on a midpoint grid and weighed by the visible density over it.
fn coating_integral(mf: &Microfacet, mu: f32, eta: f32, reflect: bool) -> f32 {
    const N: usize = 96;
    let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut sum = 0.0f64;
    for a in 0..N {
        for b in 0..N {
            let u = Vec2::new((a as f32 + 0.5) / N as f32, (b as f32 + 0.5) / N as f32);
            let m = mf.sample(wi, u);
            let p = mf.pdf(wi, m);
            if p.is_nan() || p <= 0.0 {
                continue;
            }
            // The visible density over the sampling density (1 for GGX's visible sampling).
            let visible = mf.g1(wi, m) * wi.dot(m).max(0.0) * mf.d(m) / wi.z;
            let ratio = visible / p;
            let c = wi.dot(m);
            let f = fresnel_dielectric(c, eta);
            let value = if reflect {
                let wo = 2.0 * c * m - wi;
                if wo.z <= 0.0 { 0.0 } else { f.reflectance * mf.g1(wo, m) }
            } else {
                // Refracted about m: tangential part scaled by η_i/η_t, normal part cos θt.
                let wt = -f.eta_ti * (wi - c * m) + f.cos_theta_t * m;
                if wt.z * wi.z >= 0.0 { 0.0 } else { (1.0 - f.reflectance) * mf.g1(wt, m) }
            };
            if (value * ratio).is_finite() {
                sum += (value * ratio) as f64;
            }
        }
    }
    (sum / (N * N) as f64) as f32
}

/// The rough plastic at one point.
#[derive(Clone, Copy, Debug)]
pub struct RoughPlastic {
    pub diffuse: Vec3,
    pub specular: Vec3,
    pub specular_weight: f32,
    pub nonlinear: bool,
    pub table: &'static RoughPlasticTable,
}

impl RoughPlastic {
    #[inline]
    pub fn specular_probability(&self, cos_o: f32) -> f32 {
        let t = self.table.transmittance(cos_o);
        specular_probability((1.0 - t) * self.specular_weight, t * (1.0 - self.specular_weight))
    }

    /// f · cos θi of both lobes.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let t = self.table;
        let mut value = Vec3::ZERO;
        let (v, cos_h) = t.microfacet.reflect_eval(wo, wi);
        if v > 0.0 {
            value += self.specular * (fresnel_dielectric(cos_h, t.eta).reflectance * v);
        }
        let (t_o, t_i) = (t.transmittance(wo.z), t.transmittance(wi.z));
        value
            + base(self.diffuse, t.internal, self.nonlinear)
                * (FRAC_1_PI / (t.eta * t.eta) * wi.z * t_o * t_i)
    }

    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p = self.specular_probability(wo.z);
        p * self.table.microfacet.pdf_reflect(wo, wi) + (1.0 - p) * diffuse::pdf(wi)
    }

    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if wo.z <= 0.0 {
            return None;
        }
        let (specular, x) = choose(refined(u.x, u_lobe), self.specular_probability(wo.z));
        let u = Vec2::new(x, u.y);
        if specular { self.table.microfacet.sample_reflect(wo, u) } else { Some(diffuse::sample(u)) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The diffuse Fresnel fits: 0 at η = 1 (to the fits' accuracy) and Mitsuba's value for
    /// the inside of η = 1.5.
    #[test]
    fn diffuse_fresnel() {
        assert!(fresnel_diffuse_reflectance(1.0).abs() < 2e-3);
        // d'Eon & Irving for η = 1.5 from outside: about 0.0918; from inside (1/1.5) about 0.596.
        assert!(
            (fresnel_diffuse_reflectance(1.5) - 0.0918).abs() < 2e-3,
            "{}",
            fresnel_diffuse_reflectance(1.5)
        );
        let inside = fresnel_diffuse_reflectance(1.0 / 1.5);
        assert!((inside - 0.596).abs() < 0.01, "{inside}");
    }

    /// The rough coating's transmittance tends to the smooth one (1 − F) as α → 0, the internal
    /// reflectance to the diffuse Fresnel fit, and both kinds of normals agree at moderate α.
    #[test]
    fn rough_coating_tends_to_smooth() {
        let eta = 1.5;
        let t = RoughPlasticTable::compute(Distribution::Ggx, 0.01, eta);
        for (i, mu) in [0.3f32, 0.6, 0.95].into_iter().enumerate() {
            let smooth = 1.0 - fresnel_dielectric(mu, eta).reflectance;
            assert!((t.transmittance(mu) - smooth).abs() < 0.01, "{i}: {} vs {smooth}", t.transmittance(mu));
        }
        let fdr = fresnel_diffuse_reflectance(1.0 / eta);
        assert!((t.internal - fdr).abs() < 0.03, "{} vs {fdr}", t.internal);
        let (g, b) = (
            RoughPlasticTable::compute(Distribution::Ggx, 0.2, eta),
            RoughPlasticTable::compute(Distribution::Beckmann, 0.2, eta),
        );
        for mu in [0.2f32, 0.5, 0.9] {
            assert!(
                (g.transmittance(mu) - b.transmittance(mu)).abs() < 0.05,
                "{mu}: {} {}",
                g.transmittance(mu),
                b.transmittance(mu)
            );
        }
    }

    /// White furnace: with a white base and coating, the rough plastic reflects at most what
    /// it receives, and not much less at normal incidence.
    #[test]
    fn rough_plastic_albedo_is_bounded() {
        let table = RoughPlasticTable::get(Distribution::Ggx, 0.3, 1.5);
        let p = RoughPlastic {
            diffuse: Vec3::ONE,
            specular: Vec3::ONE,
            specular_weight: 0.5,
            nonlinear: false,
            table,
        };
        let n = 400;
        for cos_o in [1.0f32, 0.5, 0.1] {
            let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
            // ∫ f cos dω by the cosine-weighted midpoint grid: mean of eval / (cos/π).
            let mut sum = 0.0f64;
            for a in 0..n {
                for b in 0..n {
                    let wi =
                        diffuse::sample(Vec2::new((a as f32 + 0.5) / n as f32, (b as f32 + 0.5) / n as f32));
                    sum += (p.eval(wo, wi).x / diffuse::pdf(wi)) as f64;
                }
            }
            let albedo = sum / (n * n) as f64;
            assert!(albedo <= 1.01 && albedo > 0.6, "cos {cos_o}: {albedo}");
        }
    }
}
