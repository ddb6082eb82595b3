//! A glossy receiver's BSDF as the sampled gathers weigh their lights: the light tree's
//! importance ([`super::tree_gather`]) and the resampled gather's estimate ([`super::lanes`]).
//!
//! The scene format's `glossy` BSDF is ρ_d/π plus a GGX lobe without Fresnel,
//! ρ_s D(h) G1(ω_o) G1(ω_i) / (4 cos θ_o cos θ_i) ([`crate::material::glossy`]). Its specular part
//! of f · cos θ_i is at most ρ_s D(h) / (4 cos θ_o) (G1 ≤ 1), and for ω_i at angle θ from the
//! mirror direction r of ω_o (about the shading normal n) the half vector h lies at least θ/2
//! from n: ω_i = −H_h ω_o and r = −H_n ω_o (H the reflection through the plane normal to h or
//! n), so r = H_n H_h ω_i, a rotation by 2∠(h, n), which moves no direction by more than that
//! angle. D decreases away from n, so ρ_s D(θ/2) / (4 cos θ_o) bounds the specular part of
//! f · cos θ_i towards ω_i (per channel mean; exact in the plane of incidence up to G1). D of a
//! half angle is in closed form, cos² (θ/2) = (1 + cos θ)/2: no trigonometry.
//!
//! A rough conductor (Mitsuba's `roughconductor`) is the same lobe with a Fresnel factor of
//! at most 1 and no diffuse part, so the bound holds for its GGX lobes with ρ_s its specular
//! reflectance; its Beckmann lobes take the GGX bound of their α as a shape (the same peak,
//! wider tails), which is all a draw needs.
//!
//! Which lights the sampled gathers draw is all this shapes, never the value they add: any
//! positive weighting of the lights that can contribute leaves the estimates unbiased.

use std::f32::consts::PI;

use glam::Vec3;

use crate::material::Bsdf;
use crate::material::ggx::Ggx;

/// How much a light-tree node's angular radius θ_b widens the lobe it is weighed by:
/// α' = α + [`SPREAD`] · tan(θ_b / 2) (chosen among 0.25, 0.5 and 1 by the relative MSE of
/// `pir-clamp` and `pir-vsl --gather tree` on the glossy scenes, four seeds each:
/// `docs/measurements.md`).
pub const SPREAD: f32 = 0.25;

/// The smallest cos θ_o the lobe's scale ρ_s / (π cos θ_o) takes. With it the scale stays
/// below 3.2e3 and the bound below 1e11 (α at `Ggx`'s floor of 1e-4) per unit of the light's
/// geometry term over cos θ_x, so a receiver's estimates cannot overflow (and drop a light
/// that contributes) at grazing ω_o, where G1(ω_o) takes the lobe itself to zero.
const COS_O_FLOOR: f32 = 1e-4;

/// A glossy receiver's lobe: its mirror direction, roughness and reflectances.
#[derive(Clone, Copy, Debug)]
pub struct Lobe {
    /// The unit mirror direction of ω_o about the shading normal.
    mirror: Vec3,
    /// GGX α of the receiver.
    alpha: f32,
    /// ρ_s / (π cos θ_o): the lobe's ρ_s D(θ/2) / (4 cos θ_o) is this over α² t² (see
    /// [`Lobe::widened`]).
    scale: f32,
    /// ρ_d / π, the Lambertian part of f.
    diffuse: f32,
    /// 1 − p_s and π p_s / ρ_s, p_s the chance that BSDF sampling takes the lobe: the
    /// receiver's sampling density towards a light is about cos θ_i / π · (the first + the
    /// second · the lobe's f), ([`Lobe::sampling`]).
    sampling: (f32, f32),
}

impl Lobe {
    /// The lobe of `bsdf` at a receiver with unit shading normal `ns`, seen from the unit
    /// direction `wo`: the scene format's `glossy` BSDF, or a rough conductor (Mitsuba's
    /// `roughconductor`: its Fresnel factor at most 1, so ρ_s its specular reflectance bounds
    /// it; a Beckmann lobe is shaped by the GGX bound of its α, not bounded by it, which only
    /// shapes a draw). `None` when the BSDF has no such lobe (a Lambertian receiver's f is
    /// the same towards every light) or `wo` is not above the shading horizon (the receiver
    /// reflects nothing).
    pub fn of(bsdf: &Bsdf, ns: Vec3, wo: Vec3) -> Option<Lobe> {
        let (albedo, specular, roughness) = match *bsdf {
            Bsdf::Glossy { albedo, specular, roughness } => (albedo, specular, roughness),
            Bsdf::RoughConductor { specular, microfacet, .. } => (Vec3::ZERO, specular, microfacet.alpha),
            _ => return None,
        };
        let cos_o = ns.dot(wo);
        let rho_s = specular.max(Vec3::ZERO).element_sum() / 3.0;
        if !(cos_o > 0.0 && rho_s > 0.0) {
            return None;
        }
        // (cos θ_o floored, so that the bound stays finite at grazing ω_o, where it only
        // shapes the draw: G1(ω_o) takes the lobe to zero there.)
        let scale = rho_s / (PI * cos_o.max(COS_O_FLOOR));
        let diffuse = albedo.max(Vec3::ZERO).element_sum() / (3.0 * PI);
        // (The glossy BSDF's choice of lobe, [`crate::material::glossy`]; a metal has only
        // the lobe.)
        let p_s = rho_s / (rho_s + diffuse * PI);
        // (π p_s / ρ_s, without dividing by a ρ_s that may be subnormal.)
        let sampling = (1.0 - p_s, PI / (rho_s + diffuse * PI));
        (scale.is_finite() && diffuse.is_finite()).then(|| Lobe {
            mirror: (2.0 * cos_o * ns - wo).normalize_or(ns),
            alpha: Ggx::new(roughness).alpha(),
            scale,
            diffuse,
            sampling,
        })
    }

    /// The receiver's BSDF sampling density towards a light whose lobe's f (the specular part,
    /// bounded as [`Lobe::bound`] over cos θ_i) is `f_lobe`, over that of a Lambertian
    /// receiver, cos θ_i / π: 1 − p_s + π p_s f_lobe / ρ_s. The lobe is sampled with
    /// probability p_s and density G1(ω_o) D / (4 cos θ_o) ≤ f_lobe cos θ_i / ρ_s, so this is
    /// about the density where ω_i is near the lobe's peak (G1 ≈ 1) and bounds it elsewhere:
    /// an estimate for the draw's weights ([`super::bidirectional::DrawWeights`]), which only
    /// shapes the draw.
    #[inline(always)]
    pub fn sampling(&self, f_lobe: f32) -> f32 {
        self.sampling.0 + self.sampling.1 * f_lobe
    }

    /// The unit mirror direction r.
    #[inline(always)]
    pub fn mirror(&self) -> Vec3 {
        self.mirror
    }

    /// ρ_d / π.
    #[inline(always)]
    pub fn diffuse(&self) -> f32 {
        self.diffuse
    }

    /// The bound at the mirror direction: ρ_s / (π α² cos θ_o), [`Lobe::bound`] of 1 times 4.
    #[inline(always)]
    pub fn peak(&self) -> f32 {
        self.scale / (self.alpha * self.alpha)
    }

    /// 1 / α².
    #[inline(always)]
    pub fn inv_alpha2(&self) -> f32 {
        1.0 / (self.alpha * self.alpha)
    }

    /// ρ_s D'(θ/2) / (4 cos θ_o) towards a direction at angle θ from r, cos θ = `c`, for a cone
    /// of directions of angular radius θ_b, tan(θ_b / 2) = `tan_half`: D' is GGX of
    /// α' = min(1, α + [`SPREAD`] · tan(θ_b / 2)) (α' = 1 is the uniform distribution, 1/π),
    /// and with cos² (θ/2) = (1 + c)/2, sin² (θ/2) = (1 − c)/2,
    /// D' = 1 / (π α'² (sin²/α'² + cos²)²) = 4 / (π α'² ((1 − c)/α'² + 1 + c)²).
    #[inline(always)]
    pub fn widened(&self, c: f32, tan_half: f32) -> f32 {
        // (A product of unit vectors can exceed 1 by an ulp, which a small α would magnify.)
        let c = c.clamp(-1.0, 1.0);
        let a = (self.alpha + SPREAD * tan_half).min(1.0);
        let a2 = a * a;
        let t = (1.0 - c) / a2 + 1.0 + c;
        self.scale / (a2 * t * t)
    }

    /// The bound ρ_s D(θ/2) / (4 cos θ_o) of the module docs, towards a direction with
    /// cos θ = `c`.
    #[inline(always)]
    pub fn bound(&self, c: f32) -> f32 {
        // (Clamped as in [`Lobe::widened`].)
        let c = c.clamp(-1.0, 1.0);
        let a2 = self.alpha * self.alpha;
        let t = (1.0 - c) * (1.0 / a2) + 1.0 + c;
        (self.scale / a2) / (t * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Frame;
    use crate::material::conductor::ComplexIor;
    use crate::material::microfacet::{Distribution, Microfacet};
    use crate::material::{LocalGeometry, PreparedBsdf, TransportMode};
    use crate::sampling::{Domain, Sampler};

    /// Over random glossy receivers, rough (GGX) metals and directions, the lobe's bound
    /// ρ_d/π cos θ_i + [`Lobe::bound`] is at least the BSDF's f · cos θ_i (channel mean, to
    /// f32 rounding), and at the mirror direction of a glossy receiver it is tight up to the
    /// two G1 (at least 70 % of it for α up to 0.3, ω_o within 60° of the normal);
    /// [`Lobe::widened`] with θ_b = 0 is the same number.
    #[test]
    fn the_half_angle_bounds_the_lobe() {
        let mut s = Sampler::new(31, 0, Domain::Iteration, 0);
        let (mut checked, mut tight) = (0, 0);
        let metal = |alpha| Bsdf::RoughConductor {
            specular: Vec3::new(1.0, 0.8, 0.6),
            ior: ComplexIor { eta: Vec3::new(0.2, 0.5, 1.4), k: Vec3::new(3.6, 2.4, 1.9) },
            microfacet: Microfacet::new(Distribution::Ggx, alpha),
        };
        for (roughness, bsdf) in [0.02f32, 0.1, 0.3, 0.8].into_iter().flat_map(|roughness| {
            [
                Bsdf::Glossy { albedo: Vec3::splat(0.3), specular: Vec3::new(0.9, 0.6, 0.3), roughness },
                metal(roughness),
            ]
            .map(|b| (roughness, b))
        }) {
            for _ in 0..200 {
                let n = Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5).normalize();
                let g = LocalGeometry { ng: n, frame: Frame::from_normal(n) };
                let wo =
                    g.frame.to_world(Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, 0.05 + s.next_f32()));
                let wo = wo.normalize();
                let lobe = Lobe::of(&bsdf, n, wo).unwrap();
                let fx = PreparedBsdf::new(bsdf, g, wo, TransportMode::Radiance);
                let mirror = lobe.mirror();
                assert!((mirror.length() - 1.0).abs() < 1e-5 && (mirror.dot(n) - wo.dot(n)).abs() < 1e-5);
                for j in 0..20 {
                    // Directions near the mirror direction and anywhere above the horizon.
                    let spread = if j % 2 == 0 { 0.05 } else { 2.0 };
                    let wi = (mirror
                        + spread * Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5))
                    .normalize();
                    let cos_i = wi.dot(n);
                    if cos_i <= 0.0 {
                        continue;
                    }
                    let f = fx.eval(wi).element_sum() / 3.0;
                    let c = mirror.dot(wi);
                    let bound = lobe.diffuse() * cos_i + lobe.bound(c);
                    assert!(
                        f <= bound * 1.001 + 1e-6,
                        "alpha {roughness}: f cos {f} above the bound {bound}"
                    );
                    assert!(
                        (lobe.widened(c, 0.0) - lobe.bound(c)).abs() <= 1e-4 * bound,
                        "{} {} {c} {roughness}",
                        lobe.widened(c, 0.0),
                        lobe.bound(c)
                    );
                    checked += 1;
                }
                // At the mirror direction the bound is f · cos up to the two G1, near 1 for
                // a moderate roughness away from grazing.
                // (Not for the metal, whose Fresnel factor the bound takes as 1.)
                if roughness <= 0.3 && wo.dot(n) > 0.5 && matches!(bsdf, Bsdf::Glossy { .. }) {
                    let f = fx.eval(mirror).element_sum() / 3.0;
                    let bound = lobe.diffuse() * mirror.dot(n) + lobe.bound(1.0);
                    assert!(f >= 0.7 * bound, "alpha {roughness}: at the mirror {f} against {bound}");
                    tight += 1;
                }
            }
        }
        assert!(checked > 20_000 && tight > 100, "{checked} directions, {tight} mirrors");
        let diffuse = Bsdf::Diffuse { albedo: Vec3::ONE };
        assert!(Lobe::of(&diffuse, Vec3::Z, Vec3::Z).is_none());
    }

    /// At GGX's smallest α, a cosine an ulp above 1 (as a product of unit vectors can give)
    /// weighs as the mirror direction itself, and a grazing ω_o keeps the bound finite.
    #[test]
    fn extreme_inputs_stay_finite() {
        let mirror = Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ONE, roughness: 0.0 };
        let lobe = Lobe::of(&mirror, Vec3::Z, Vec3::new(0.6, 0.0, 0.8)).unwrap();
        let peak = lobe.widened(1.0, 0.0);
        assert!(peak.is_finite() && peak > 0.0);
        assert_eq!(lobe.widened(1.0 + f32::EPSILON, 0.0), peak);
        let grazing = Vec3::new(1.0, 0.0, 1e-30).normalize();
        let lobe = Lobe::of(&mirror, Vec3::Z, grazing).unwrap();
        assert!(lobe.bound(1.0).is_finite() && lobe.widened(1.0, 0.0) * 1e20 < f32::MAX);
    }
}
