//! The isotropic GGX (Trowbridge–Reitz) microfacet distribution with Smith masking and
//! visible-normal sampling.
//!
//! - D(m) = α² / (π cos⁴θm (α² + tan²θm)²)  (Walter et al. 2007, "Microfacet Models for
//!   Refraction through Rough Surfaces", eq. 33).
//! - G1(v, m) = 2 / (1 + √(1 + α² tan²θv)) when (v·m)(v·n) > 0, else 0 (same paper, eq. 34);
//!   the masking-shadowing term used by the glossy model is the separable G1(wo)·G1(wi), as in
//!   Mitsuba 3's `MicrofacetDistribution::G`.
//! - Visible normals are sampled with Heitz 2018, "Sampling the GGX Distribution of Visible
//!   Normals" (JCGT 7(4)); their density is D_v(m) = G1(v, m) max(0, v·m) D(m) / cos θv.
//!   Mitsuba 3 uses Heitz & d'Eon 2014's slope-space method for the same density.
//!
//! Everything is in the local shading frame (normal = +z). `alpha` is clamped to ≥ 1e-4 so
//! that near-specular roughness (e.g. Ns = 1000 → α ≈ 0.045, or smaller) stays finite in f32.

use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Smallest alpha used; below it D overflows f32 near the peak.
pub const MIN_ALPHA: f32 = 1e-4;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ggx {
    alpha: f32,
}

impl Ggx {
    pub fn new(roughness: f32) -> Self {
        let alpha = if roughness.is_finite() { roughness.max(MIN_ALPHA) } else { 1.0 };
        Ggx { alpha }
    }

    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// Normal distribution D(m) (per unit solid angle of m, projected: ∫ D(m) cos θm dm = 1).
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        // α² / (π (x² + y² + α² z²)²) = 1 / (π α² ((x² + y²)/α² + z²)²)
        let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
        let d = 1.0 / (PI * a2 * t * t);
        if d.is_finite() { d } else { 0.0 }
    }

    /// Smith masking G1(v, m) of the direction `v` for microfacet normal `m`.
    pub fn g1(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) * v.z <= 0.0 {
            return 0.0;
        }
        let xy2 = v.x * v.x + v.y * v.y;
        if xy2 == 0.0 {
            return 1.0;
        }
        let tan2_alpha2 = self.alpha * self.alpha * xy2 / (v.z * v.z);
        2.0 / (1.0 + (1.0 + tan2_alpha2).sqrt())
    }

    /// Samples a microfacet normal from the distribution of normals visible from `v`
    /// (`v.z > 0`), Heitz 2018, listing 1.
    pub fn sample_visible(&self, v: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        // Stretch the view vector to the hemisphere configuration (α = 1).
        let vh = Vec3::new(a * v.x, a * v.y, v.z).normalize();
        // Orthonormal basis around vh (T1 is horizontal).
        let lensq = vh.x * vh.x + vh.y * vh.y;
        let t1 = if lensq > 0.0 { Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt() } else { Vec3::X };
        let t2 = vh.cross(t1);
        // Uniform point on the disk, warped onto the visible half of it.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let p1 = r * phi.cos();
        let p2 = r * phi.sin();
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
        // Project onto the hemisphere and unstretch.
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize_or(Vec3::Z)
    }

    /// Density of [`Ggx::sample_visible`]: G1(v, m) max(0, v·m) D(m) / cos θv.
    pub fn pdf_visible(&self, v: Vec3, m: Vec3) -> f32 {
        if v.z <= 0.0 {
            return 0.0;
        }
        self.g1(v, m) * v.dot(m).max(0.0) * self.d(m) / v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Domain, Sampler};

    /// ∫ D(m) cos θm dm = 1, integrated over cos θm with the substitution that resolves the
    /// peak (midpoint rule in tan θ / α).
    #[test]
    fn projected_area_is_one() {
        for alpha in [1e-3f32, 0.05, 0.3, 1.0] {
            let g = Ggx::new(alpha);
            // m(θ) with tan θ = α t, t ∈ [0, ∞) via t = x/(1-x).
            let n = 200_000;
            let mut sum = 0.0f64;
            for i in 0..n {
                let x = (i as f64 + 0.5) / n as f64;
                let t = x / (1.0 - x);
                let dt_dx = 1.0 / ((1.0 - x) * (1.0 - x));
                let theta = (alpha as f64 * t).atan();
                let dtheta_dt = alpha as f64 / (1.0 + (alpha as f64 * t).powi(2));
                let m = Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
                let integrand = g.d(m) as f64 * theta.cos() * theta.sin() * 2.0 * std::f64::consts::PI;
                sum += integrand * dtheta_dt * dt_dx / n as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "alpha {alpha}: {sum}");
        }
    }

    #[test]
    fn visible_normals_face_the_viewer_and_are_unit() {
        let mut s = Sampler::new(3, 0, Domain::Iteration, 0);
        for alpha in [MIN_ALPHA, 0.05, 0.5, 1.0] {
            let g = Ggx::new(alpha);
            for cos_v in [1.0f32, 0.5, 0.01] {
                let v = Vec3::new((1.0 - cos_v * cos_v).sqrt(), 0.0, cos_v);
                for _ in 0..1000 {
                    let m = g.sample_visible(v, s.next_2d());
                    assert!((m.length() - 1.0).abs() < 1e-4 && m.z >= 0.0);
                    assert!(v.dot(m) >= -1e-4, "{v} {m}");
                    assert!(g.pdf_visible(v, m).is_finite());
                }
            }
        }
    }

    #[test]
    fn g1_limits() {
        let g = Ggx::new(0.3);
        assert_eq!(g.g1(Vec3::Z, Vec3::Z), 1.0);
        let grazing = Vec3::new(1.0, 0.0, 1e-3).normalize();
        assert!(g.g1(grazing, Vec3::Z) < 0.01);
        assert_eq!(g.g1(Vec3::Z, -Vec3::Z), 0.0);
    }
}
