//! The scene format's `glossy` material: a Lambertian lobe plus a GGX microfacet lobe without
//! Fresnel,
//!
//!   f(wo, wi) = albedo / π + specular · D(h) G1(wo, h) G1(wi, h) / (4 cos θo cos θi),
//!
//! h = normalize(wo + wi). This is Mitsuba 3's `blendbsdf` of `diffuse` and `roughconductor`
//! (material "none", distribution "ggx", `sample_visible` true) with the reflectances rescaled
//! by the blend weight; see [`super::ggx`] for D, G1 and the citations.
//!
//! Sampling is a one-sample mixture: the specular lobe with probability
//! p_s = mean(specular) / (mean(specular) + mean(albedo)), the cosine lobe otherwise. The
//! lobe is chosen by the point's first number, whose rest places the direction (sample reuse,
//! [`crate::sampling::reuse`]), so that stratified points stay stratified within each lobe. The
//! specular lobe samples a visible normal m (Heitz 2018) and reflects `wo` about it, so its
//! density is D_wo(h) / (4 |wo·h|) = G1(wo, h) D(h) / (4 cos θo); the returned pdf is the
//! mixture's. Directions reflected below the horizon are rejected (the sample fails), so the
//! pdf integrates to slightly less than 1 at grazing incidence and high roughness.
//!
//! Local shading frame (normal = +z); the caller checks the hemispheres.

use glam::{Vec2, Vec3};

use super::{diffuse, ggx::Ggx};
use crate::sampling::reuse::{choose, refined};

#[derive(Clone, Copy, Debug)]
pub struct Glossy {
    albedo: Vec3,
    specular: Vec3,
    ggx: Ggx,
    /// Probability of sampling the specular lobe.
    p_spec: f32,
}

fn mean(v: Vec3) -> f32 {
    (v.x + v.y + v.z).max(0.0) / 3.0
}

impl Glossy {
    pub fn new(albedo: Vec3, specular: Vec3, roughness: f32) -> Self {
        let (wd, ws) = (mean(albedo), mean(specular));
        let p_spec = if ws + wd > 0.0 { ws / (ws + wd) } else { 0.0 };
        Glossy { albedo, specular, ggx: Ggx::new(roughness), p_spec }
    }

    /// True when the material reflects nothing.
    pub fn is_black(&self) -> bool {
        mean(self.albedo) + mean(self.specular) <= 0.0
    }

    /// f · cos θi for `wo`, `wi` both above the horizon.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let mut value = diffuse::eval(self.albedo, wi);
        if let Some(h) = (wo + wi).try_normalize() {
            let d = self.ggx.d(h);
            let g = self.ggx.g1(wo, h) * self.ggx.g1(wi, h);
            // cos θi cancels against the cosine factor of eval.
            let spec = d * g / (4.0 * wo.z);
            if spec.is_finite() {
                value += self.specular * spec;
            }
        }
        value
    }

    /// Density of the specular lobe alone.
    fn pdf_spec(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(h) = (wo + wi).try_normalize() else { return 0.0 };
        let p = self.ggx.g1(wo, h) * self.ggx.d(h) / (4.0 * wo.z);
        if p.is_finite() { p } else { 0.0 }
    }

    /// Mixture density of [`Glossy::sample`].
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let mut p = 0.0;
        if self.p_spec > 0.0 {
            p += self.p_spec * self.pdf_spec(wo, wi);
        }
        if self.p_spec < 1.0 {
            p += (1.0 - self.p_spec) * diffuse::pdf(wi);
        }
        p
    }

    /// [`Glossy::eval`], [`Glossy::pdf`] and the reverse density `pdf(wi, wo)` at once, each
    /// bit for bit what its own call gives: the half vector, D and the two G1 are shared
    /// (a bidirectional connection needs all three; the half vector of `wi + wo` is that of
    /// `wo + wi`, since each sum is rounded once).
    pub fn eval_pdfs(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32, f32) {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return (Vec3::ZERO, 0.0, 0.0);
        }
        let mut value = diffuse::eval(self.albedo, wi);
        let (mut pdf, mut rev) = (0.0, 0.0);
        if let Some(h) = (wo + wi).try_normalize() {
            let d = self.ggx.d(h);
            let (g_o, g_i) = (self.ggx.g1(wo, h), self.ggx.g1(wi, h));
            let spec = d * (g_o * g_i) / (4.0 * wo.z);
            if spec.is_finite() {
                value += self.specular * spec;
            }
            if self.p_spec > 0.0 {
                let finite = |p: f32| if p.is_finite() { p } else { 0.0 };
                pdf += self.p_spec * finite(g_o * d / (4.0 * wo.z));
                rev += self.p_spec * finite(g_i * d / (4.0 * wi.z));
            }
        }
        if self.p_spec < 1.0 {
            pdf += (1.0 - self.p_spec) * diffuse::pdf(wi);
            rev += (1.0 - self.p_spec) * diffuse::pdf(wo);
        }
        (value, pdf, rev)
    }

    /// Samples `wi` (local) from the mixture; `None` when the reflected direction falls below
    /// the horizon or the material is black.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if wo.z <= 0.0 || self.is_black() {
            return None;
        }
        // The lobe from the point's first number, `u_lobe` refining it (sample reuse).
        let (specular, x) = choose(refined(u.x, u_lobe), self.p_spec);
        let u = Vec2::new(x, u.y);
        let wi = if specular {
            let m = self.ggx.sample_visible(wo, u);
            2.0 * wo.dot(m) * m - wo
        } else {
            diffuse::sample(u)
        };
        (wi.z > 0.0).then_some(wi)
    }
}
