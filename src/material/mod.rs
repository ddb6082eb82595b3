//! Materials of the scene format: diffuse, glossy (Lambert + GGX, no Fresnel), mirror and
//! glass, each with an optional emission.
//!
//! Conventions, written once here:
//! - Directions are world-space unit vectors pointing AWAY from the surface: `wo` towards the
//!   viewer (or the previous vertex), `wi` towards the light (or the next vertex).
//! - [`Bsdf::eval`] returns f(wo, wi) · |cos θi| (the cosine with the shading normal included).
//! - [`Bsdf::sample`] returns the sampled `wi` with weight = eval / pdf.
//! - Reflection from below the geometric surface is black (`wo` or `wi` on the back side of
//!   `ng`); glass is two-sided.
//! - [`TransportMode::Importance`] (tracing from the lights) applies the adjoint shading-normal
//!   correction |wo·ns||wi·ng| / (|wo·ng||wi·ns|) and, for refraction, no 1/η² radiance scaling.
//!   In that mode `wo` is the direction towards the PREVIOUS vertex of the light path (towards
//!   the light, where the particle came from) and `wi` the direction the path continues in
//!   (sampled onward, or towards the camera-side vertex being connected to); ns is the shading
//!   normal, ng the geometric one (Veach 1997, thesis §5.3; pbrt-v3 `CorrectShadingNormal`).
//!   The correction is applied to every lobe, delta ones included (it is 1 when ns = ng); it
//!   is written once, in [`shading_correction`].
//!
//! One file per concept: [`diffuse`], [`glossy`] (with [`ggx`]), [`mirror`], [`glass`] (with
//! [`fresnel`]). This module checks the hemispheres, applies the transport-mode correction and
//! dispatches on the [`Bsdf`] enum; the lobes work in the local shading frame.

mod adjoint;
pub mod diffuse;
pub mod fresnel;
pub mod ggx;
pub mod glass;
pub mod glossy;
pub mod mirror;
mod prepared;
mod textured;

pub use adjoint::{Lanes, shading_correction};
pub use prepared::{PreparedBsdf, PreparedDiffuse};
pub use textured::{Slot, Textured};

use glam::{Vec2, Vec3};

use crate::geometry::Frame;
use glossy::Glossy;

/// A named material: how it scatters and what it emits.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Radiance emitted from the front face (zero for non-emitters).
    pub emission: Vec3,
    /// Whether the BSDF scatters on both sides of the surface, the back as the front (Mitsuba's
    /// `twosided`): a hit from behind sees the surface with its normal flipped towards it
    /// ([`crate::scene::Scene::surface_of_hit`]). Otherwise light arriving from below the
    /// geometric surface sees it black. Emission stays on the front face either way.
    pub two_sided: bool,
    /// Textures that set fields of `bsdf` per surface point ([`Material::bsdf_at`]); `None` for
    /// a constant material, whose `bsdf` holds everywhere.
    pub textures: Option<std::sync::Arc<Textured>>,
}

impl Bsdf {
    /// The first reflectance above 1 in some channel, named as the scene formats name it
    /// (`albedo`, `specular`): such a material reflects more light than it receives, which
    /// every scene format refuses (as Mitsuba does).
    pub fn creates_energy(&self) -> Option<(&'static str, Vec3)> {
        let fields: &[(&'static str, Vec3)] = match self {
            Bsdf::Diffuse { albedo } => &[("albedo", *albedo)],
            Bsdf::Glossy { albedo, specular, .. } => &[("albedo", *albedo), ("specular", *specular)],
            Bsdf::Mirror { specular } => &[("specular", *specular)],
            Bsdf::Glass { .. } => &[],
        };
        fields.iter().copied().find(|(_, v)| v.max_element() > 1.0)
    }
}

impl Material {
    pub fn is_emitter(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The BSDF at texture coordinates `uv` ([`crate::scene::SurfacePoint::uv`]): `bsdf` itself
    /// for an untextured material, else `bsdf` with each textured slot set to its texture's
    /// value there.
    #[inline(always)]
    pub fn bsdf_at(&self, uv: Vec2) -> Bsdf {
        match &self.textures {
            None => self.bsdf,
            Some(t) => t.apply(self.bsdf, uv),
        }
    }

    /// The BSDF with every textured slot at its texture's mean (for estimates over a whole
    /// material).
    pub fn mean_bsdf(&self) -> Bsdf {
        match &self.textures {
            None => self.bsdf,
            Some(t) => t.apply_mean(self.bsdf),
        }
    }
}

/// How a surface scatters light (linear RGB reflectances, per channel).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// f = albedo / π.
    Diffuse { albedo: Vec3 },
    /// f = albedo / π + specular · D(h) G1(wi) G1(wo) / (4 |cos θi| |cos θo|), GGX of alpha
    /// `roughness`, no Fresnel.
    Glossy { albedo: Vec3, specular: Vec3, roughness: f32 },
    /// Perfect specular reflection weighted by `specular`.
    Mirror { specular: Vec3 },
    /// Smooth dielectric of index `ior` against 1, exact Fresnel, no absorption.
    Glass { ior: f32 },
}

/// Whether radiance (camera paths) or importance (light paths) is being transported.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    Radiance,
    Importance,
}

/// The geometry a BSDF needs at a point: the unit geometric normal and the shading frame.
#[derive(Clone, Copy, Debug)]
pub struct LocalGeometry {
    pub ng: Vec3,
    pub frame: Frame,
}

/// A direction sampled from a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// eval(wo, wi) / pdf (for delta lobes: the lobe's weight).
    pub weight: Vec3,
    /// Solid-angle density of `wi`; for a delta lobe, the discrete probability of the lobe.
    pub pdf: f32,
    /// The direction came from a delta (mirror or glass) lobe.
    pub delta: bool,
    /// Relative index of refraction crossed (1 for reflection).
    pub eta: f32,
}

impl Bsdf {
    /// Its reflectance ρ̄ by channel, for the many-light methods' estimates: the albedo, plus
    /// the specular colour of a glossy one (zero for delta BSDFs, which hold no VPL and
    /// gather nothing).
    pub fn reflectance(&self) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Glossy { albedo, specular, .. } => albedo + specular,
            Bsdf::Mirror { .. } | Bsdf::Glass { .. } => Vec3::ZERO,
        }
    }

    /// True for materials that have only delta lobes (mirror, glass).
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Mirror { .. } | Bsdf::Glass { .. })
    }

    /// Whether light that arrives from `w` (a unit direction away from the surface) can
    /// leave again by a non-delta lobe in any direction: `w` in front of the geometric
    /// normal and above the shading horizon, a non-delta BSDF, a non-zero reflectance.
    /// Where it is false, [`Bsdf::eval`] with `w` as either direction is zero for every
    /// other direction, so a virtual light there adds nothing to any receiver.
    pub fn reflects_from(&self, g: &LocalGeometry, w: Vec3) -> bool {
        !self.is_delta()
            && w.dot(g.ng) > 0.0
            && w.dot(g.frame.n) > 0.0
            && self.reflectance().max_element() > 0.0
    }

    /// f(wo, wi) · |cos θi| for the non-delta part; zero for delta materials.
    ///
    /// Zero unless `wo` and `wi` are both in front of the geometric normal and above the
    /// shading horizon. In [`TransportMode::Importance`] the shading-normal correction is
    /// applied (see the module docs for which of `wo`/`wi` is which).
    pub fn eval(&self, g: &LocalGeometry, wo: Vec3, wi: Vec3, mode: TransportMode) -> Vec3 {
        PreparedBsdf::new(*self, *g, wo, mode).eval(wi)
    }

    /// Solid-angle density with which [`Bsdf::sample`] returns `wi`; zero for delta materials.
    /// It does not depend on the transport mode.
    #[inline]
    pub fn pdf(&self, g: &LocalGeometry, wo: Vec3, wi: Vec3) -> f32 {
        if let Bsdf::Diffuse { albedo } = *self {
            // The Lambertian lobe needs only the two cosines of the shading normal (the same
            // numbers as through the shading frame: z of a local direction is its dot with n).
            if !(albedo.max_element() > 0.0 && wo.dot(g.ng) > 0.0 && wi.dot(g.ng) > 0.0) {
                return 0.0;
            }
            let (co, ci) = (wo.dot(g.frame.n), wi.dot(g.frame.n));
            return if co > 0.0 && ci > 0.0 { diffuse::pdf(Vec3::new(0.0, 0.0, ci)) } else { 0.0 };
        }
        let Some((wo_l, wi_l)) = reflection_pair(g, wo, wi) else { return 0.0 };
        self.local_pdf(wo_l, wi_l)
    }

    /// The pdf of sampling `wi_l` given `wo_l`, both in the shading frame and above its
    /// horizon: zero for delta and black BSDFs, and wherever it would not be finite.
    #[inline]
    pub(crate) fn local_pdf(&self, wo_l: Vec3, wi_l: Vec3) -> f32 {
        let p = match *self {
            Bsdf::Diffuse { albedo } if albedo.max_element() > 0.0 => diffuse::pdf(wi_l),
            Bsdf::Glossy { albedo, specular, roughness } => {
                let lobe = Glossy::new(albedo, specular, roughness);
                if lobe.is_black() { 0.0 } else { lobe.pdf(wo_l, wi_l) }
            }
            _ => 0.0,
        };
        if p.is_finite() { p.max(0.0) } else { 0.0 }
    }

    /// Samples `wi` given `wo`; `u_lobe` chooses between glass' reflection and refraction,
    /// `u` places the direction (and chooses the glossy material's lobe by its first number,
    /// `u_lobe` refining that number's low bits: [`crate::sampling::reuse`]).
    ///
    /// `None` when `wo` is below the (geometric or shading) surface of a reflective material,
    /// in the plane of a glass interface, when the sampled direction is rejected (below either
    /// horizon), or when the weight would not be finite.
    ///
    /// The Lambertian lobe, the common case, inlines into the caller; the others are a call.
    #[inline]
    pub fn sample(
        &self,
        g: &LocalGeometry,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        match *self {
            Bsdf::Diffuse { albedo } => sample_diffuse(albedo, g, wo, u, mode),
            _ => self.sample_other(g, wo, u_lobe, u, mode),
        }
    }

    /// [`Bsdf::sample`] of the lobes other than the Lambertian one.
    #[inline(never)]
    fn sample_other(
        &self,
        g: &LocalGeometry,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        match *self {
            // The Lambertian lobe never comes here ([`Bsdf::sample`] takes it first).
            Bsdf::Diffuse { .. } | Bsdf::Glossy { .. } => self.sample_non_delta(g, wo, u_lobe, u, mode),
            Bsdf::Mirror { specular } => {
                let n = g.frame.n;
                if !(wo.dot(g.ng) > 0.0 && wo.dot(n) > 0.0) {
                    return None;
                }
                let wi = mirror::reflect(wo, n).try_normalize()?;
                let cos_g = wi.dot(g.ng);
                if cos_g.is_nan() || cos_g <= 0.0 {
                    return None;
                }
                let weight = specular * mode_factor(g, wo, wi, mode);
                finite_sample(wi, weight, 1.0, true, 1.0)
            }
            Bsdf::Glass { ior } => {
                let s = glass::sample(g.frame.n, ior, wo, u_lobe, mode)?;
                let weight = Vec3::splat(s.weight * mode_factor(g, wo, s.wi, mode));
                finite_sample(s.wi, weight, s.prob, true, s.eta)
            }
        }
    }

    /// BSDF sampling through [`PreparedBsdf`], for every non-delta lobe (the Lambertian one
    /// takes [`sample_diffuse`] in [`Bsdf::sample`]; this stays its reference).
    fn sample_non_delta(
        &self,
        g: &LocalGeometry,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        // Active exactly when wo is in front of the geometric normal and above the shading
        // horizon (the material is not delta here).
        let prepared = PreparedBsdf::new(*self, *g, wo, mode);
        if !prepared.is_active() {
            return None;
        }
        let wi_l = match *self {
            Bsdf::Diffuse { albedo } if albedo.max_element() > 0.0 => diffuse::sample(u),
            Bsdf::Glossy { albedo, specular, roughness } => {
                Glossy::new(albedo, specular, roughness).sample(prepared.wo_local(), u_lobe, u)?
            }
            _ => return None,
        };
        let wi = g.frame.to_world(wi_l).try_normalize()?;
        // The values of the public eval and pdf, so that weight == eval / pdf exactly.
        let (f, pdf) = prepared.eval_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        finite_sample(wi, f / pdf, pdf, false, 1.0)
    }
}

/// [`Bsdf::sample`] of the Lambertian lobe, the common case, in few dependent operations: the
/// direction is the cosine warp taken to world space, not normalized again (the warp is unit
/// and the frame orthonormal, up to rounding), and the weight eval / pdf is the albedo itself
/// (cos θi / π cancels), times the transport mode's factor. The pdf is
/// [`Bsdf::pdf`]'s value for the returned `wi`, bit for bit, as multiple importance sampling
/// wants. Of `wo` and `wi` only the cosines with the two normals are computed. The general
/// path ([`Bsdf::sample_non_delta`]) gives the same sample up to rounding.
#[inline(always)]
fn sample_diffuse(
    albedo: Vec3,
    g: &LocalGeometry,
    wo: Vec3,
    u: Vec2,
    mode: TransportMode,
) -> Option<BsdfSample> {
    let (wo_ng, wo_ns) = (wo.dot(g.ng), wo.dot(g.frame.n));
    if !(wo_ng > 0.0 && wo_ns > 0.0 && albedo.max_element() > 0.0) {
        return None;
    }
    let wi = g.frame.to_world(diffuse::sample(u));
    let (wi_ng, wi_ns) = (wi.dot(g.ng), wi.dot(g.frame.n));
    let pdf = diffuse::eval_pdf_cos(albedo, wi_ns).1;
    if !(wi_ng > 0.0 && wi_ns > 0.0 && pdf > 0.0) {
        return None;
    }
    let weight = prepared::finish(mode, albedo, wo_ns, wo_ng, wi_ng, wi_ns);
    finite_sample(wi, weight, pdf, false, 1.0)
}

/// The local (shading-frame) coordinates of `wo` and `wi` when both are in front of the
/// geometric normal and above the shading horizon; `None` otherwise.
fn reflection_pair(g: &LocalGeometry, wo: Vec3, wi: Vec3) -> Option<(Vec3, Vec3)> {
    if !(wo.dot(g.ng) > 0.0 && wi.dot(g.ng) > 0.0) {
        return None;
    }
    let (wo_l, wi_l) = (g.frame.to_local(wo), g.frame.to_local(wi));
    (wo_l.z > 0.0 && wi_l.z > 0.0).then_some((wo_l, wi_l))
}

/// 1 in radiance mode; the adjoint shading-normal correction in importance mode.
fn mode_factor(g: &LocalGeometry, wo: Vec3, wi: Vec3, mode: TransportMode) -> f32 {
    match mode {
        TransportMode::Radiance => 1.0,
        TransportMode::Importance => {
            let ns = g.frame.n;
            shading_correction(wo.dot(ns), wo.dot(g.ng), wi.dot(g.ng), wi.dot(ns))
        }
    }
}

#[inline(always)]
fn finite_sample(wi: Vec3, weight: Vec3, pdf: f32, delta: bool, eta: f32) -> Option<BsdfSample> {
    (weight.is_finite() && pdf.is_finite() && pdf > 0.0 && wi.is_finite()).then_some(BsdfSample {
        wi,
        weight: weight.max(Vec3::ZERO),
        pdf,
        delta,
        eta,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Domain, Sampler, uniform_cone};

    /// A direction uniform over the sphere (the cone of every cosine).
    fn dir(rng: &mut Sampler) -> Vec3 {
        uniform_cone(rng.next_2d(), -1.0)
    }

    /// `reflects_from` is false exactly where every evaluation with that direction is zero:
    /// checked against `eval` over many other directions, both modes, for tilted shading
    /// normals, black and delta materials included.
    #[test]
    fn reflects_from_is_false_exactly_where_nothing_is_reflected() {
        let mut rng = Sampler::new(9, 0, Domain::Iteration, 0);
        let bsdfs = [
            Bsdf::Diffuse { albedo: Vec3::new(0.8, 0.5, 0.2) },
            Bsdf::Diffuse { albedo: Vec3::ZERO },
            Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.5), roughness: 0.3 },
            Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::ZERO, roughness: 0.3 },
            Bsdf::Mirror { specular: Vec3::ONE },
            Bsdf::Glass { ior: 1.5 },
        ];
        let (mut reflecting, mut not) = (0, 0);
        for bsdf in bsdfs {
            for _ in 0..300 {
                let ng = dir(&mut rng);
                let ns = (ng + 0.3 * dir(&mut rng)).normalize();
                let g = LocalGeometry { ng, frame: Frame::from_normal(ns) };
                let w = dir(&mut rng);
                let any = (0..200).any(|_| {
                    let other = dir(&mut rng);
                    [TransportMode::Radiance, TransportMode::Importance].into_iter().any(|mode| {
                        bsdf.eval(&g, w, other, mode) != Vec3::ZERO
                            || bsdf.eval(&g, other, w, mode) != Vec3::ZERO
                    })
                });
                assert_eq!(bsdf.reflects_from(&g, w), any, "{bsdf:?}, ng {ng}, ns {ns}, w {w}");
                if any { reflecting += 1 } else { not += 1 }
            }
        }
        assert!(reflecting > 200 && not > 200, "{reflecting} reflecting, {not} not");
    }

    /// The Lambertian fast paths give what the general paths give: the evaluation bit for bit,
    /// the sample up to rounding (both or neither, except at grazing angles), for shading
    /// normals tilted off the geometric one, directions on both sides and both modes.
    #[test]
    fn diffuse_fast_paths_are_the_general_paths() {
        let mut rng = Sampler::new(5, 0, Domain::Iteration, 0);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() <= 1e-5;
        let (mut both, mut grazing) = (0, 0);
        for albedo in [Vec3::new(0.8, 0.5, 0.2), Vec3::ZERO, Vec3::new(0.0, 0.3, 0.0)] {
            let bsdf = Bsdf::Diffuse { albedo };
            for _ in 0..2000 {
                let ng = dir(&mut rng);
                let ns = (ng + 0.4 * dir(&mut rng)).normalize();
                let g = LocalGeometry { ng, frame: Frame::from_normal(ns) };
                let (wo, wi) = (dir(&mut rng), dir(&mut rng));
                let u = rng.next_2d();
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let fast = sample_diffuse(albedo, &g, wo, u, mode);
                    let general = bsdf.sample_non_delta(&g, wo, 0.5, u, mode);
                    match (fast, general) {
                        (None, None) => {}
                        (Some(a), Some(b)) => {
                            both += 1;
                            // Importance mode divides by wi·ns: relative rounding 1e-7 / cos θi.
                            let tol = 1e-5 + 1e-7 / (std::f32::consts::PI * b.pdf);
                            let rel = (a.weight - b.weight).abs().max_element() / b.weight.max_element();
                            assert!(close(a.wi, b.wi) && rel <= tol, "{a:?} {b:?}");
                            // The cosine up to rounding of the unit vectors (absolute, not relative, at grazing).
                            assert!((a.pdf - b.pdf).abs() <= 1e-6, "{a:?} {b:?}");
                            assert_eq!((a.delta, a.eta), (b.delta, b.eta));
                        }
                        (Some(s), None) | (None, Some(s)) => {
                            assert!(s.wi.dot(ng).min(s.pdf) < 1e-5, "{fast:?} {general:?}");
                            grazing += 1;
                        }
                    }
                    let p = PreparedBsdf::new(bsdf, g, wo, mode);
                    for w in [wi, fast.map_or(wi, |s| s.wi)] {
                        let ((f, pdf), (fg, pdfg)) = (p.eval_pdf(w), p.eval_pdf_general(w));
                        assert_eq!((bits(f), pdf.to_bits()), (bits(fg), pdfg.to_bits()));
                        assert_eq!(bits(p.eval(w)), bits(fg));
                    }
                }
            }
        }
        assert!(both > 1000 && grazing * 1000 < both, "{both} samples, {grazing} grazing");
    }
}
