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
//! [`fresnel`]), and [`composite`] for the BSDFs made of others. This module checks the hemispheres, applies the transport-mode correction and
//! dispatches on the [`Bsdf`] enum; the lobes work in the local shading frame.

mod adjoint;
pub mod composite;
#[cfg(test)]
mod composite_values;
pub mod conductor;
pub mod diffuse;
pub mod fresnel;
pub mod ggx;
pub mod glass;
pub mod glossy;
pub mod mask;
pub mod microfacet;
pub mod mirror;
#[cfg(test)]
mod mitsuba_values;
pub mod plastic;
mod prepared;
pub mod rough_dielectric;
#[cfg(test)]
mod rough_dielectric_values;
pub mod shading_map;
mod textured;
pub mod thin_dielectric;

pub use adjoint::{Lanes, shading_correction};
pub use prepared::{PreparedBsdf, PreparedDiffuse};
pub use textured::{Slot, Textured};

use glam::{Vec2, Vec3};

use crate::geometry::Frame;
use crate::sampling::reuse::{choose, refined};
use composite::Composite;
use conductor::{ComplexIor, RoughConductor};
use glossy::Glossy;
use microfacet::Microfacet;
use plastic::{Plastic, RoughPlastic, RoughPlasticTable};
use rough_dielectric::RoughDielectric;

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
            Bsdf::Mirror { specular }
            | Bsdf::Conductor { specular, .. }
            | Bsdf::RoughConductor { specular, .. } => &[("specular", *specular)],
            Bsdf::Plastic { diffuse, specular, .. } | Bsdf::RoughPlastic { diffuse, specular, .. } => {
                &[("diffuse", *diffuse), ("specular", *specular)]
            }
            Bsdf::Dielectric { reflectance, transmittance, .. }
            | Bsdf::ThinDielectric { reflectance, transmittance, .. }
            | Bsdf::RoughDielectric { reflectance, transmittance, .. } => {
                &[("specular_reflectance", *reflectance), ("specular_transmittance", *transmittance)]
            }
            Bsdf::Mask { albedo, .. } => &[("albedo", *albedo)],
            // The parts were checked as they were read.
            Bsdf::Glass { .. } | Bsdf::Composite { .. } => &[],
        };
        fields.iter().copied().find(|(_, v)| v.max_element() > 1.0)
    }
}

impl Bsdf {
    /// Mitsuba's `plastic`: `diffuse` under a coating of relative index `eta`; `specular` is
    /// `specular_reflectance`, `None` when the file gives none (Mitsuba then steers the lobe
    /// choice as for a white one). The means are over the surface (a texture's mean).
    pub fn plastic(diffuse: Vec3, specular: Option<Vec3>, eta: f32, nonlinear: bool) -> Bsdf {
        let specular_weight = specular_weight(diffuse, specular);
        Bsdf::Plastic { diffuse, specular: specular.unwrap_or(Vec3::ONE), eta, specular_weight, nonlinear }
    }

    /// Mitsuba's `roughplastic` (see [`Bsdf::plastic`]).
    pub fn rough_plastic(
        diffuse: Vec3,
        specular: Option<Vec3>,
        eta: f32,
        microfacet: Microfacet,
        nonlinear: bool,
    ) -> Bsdf {
        let specular_weight = specular_weight(diffuse, specular);
        let table = RoughPlasticTable::get(microfacet.kind, microfacet.alpha, eta);
        Bsdf::RoughPlastic {
            diffuse,
            specular: specular.unwrap_or(Vec3::ONE),
            specular_weight,
            nonlinear,
            table,
        }
    }
}

/// w = s̄ / (ρ̄ + s̄), s̄ = 1 without a specular reflectance (Mitsuba's plastics).
fn specular_weight(diffuse: Vec3, specular: Option<Vec3>) -> f32 {
    let d = diffuse.element_sum() / 3.0;
    let s = specular.map_or(1.0, |s| s.element_sum() / 3.0);
    if d + s > 0.0 { s / (d + s) } else { 0.0 }
}

impl Material {
    pub fn is_emitter(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The radiance the front face emits at texture coordinates `uv`: `emission` itself, or
    /// where a texture sets it ([`Slot::Emission`], `emission` then holding its mean, which
    /// chooses among the emitters by power), the texture's value there.
    #[inline]
    pub fn emission_at(&self, uv: Vec2) -> Vec3 {
        match self.textures.as_deref().and_then(|t| t.get(Slot::Emission)) {
            None => self.emission,
            Some(texture) => texture.eval(uv),
        }
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
    /// Mitsuba's `conductor`: perfect specular reflection weighted by `specular` and the
    /// Fresnel reflectance of the complex index `ior` ([`conductor`]).
    Conductor { specular: Vec3, ior: ComplexIor },
    /// Mitsuba's `roughconductor`: a microfacet lobe with the conductor's Fresnel term.
    RoughConductor { specular: Vec3, ior: ComplexIor, microfacet: Microfacet },
    /// Mitsuba's `plastic`: a delta dielectric coating of relative index `eta` over a diffuse
    /// base ([`plastic`]); `specular_weight` steers the lobe choice (from the reflectances'
    /// means over the surface, so not changed by a texture's value at a point).
    Plastic { diffuse: Vec3, specular: Vec3, eta: f32, specular_weight: f32, nonlinear: bool },
    /// Mitsuba's `roughplastic`: a microfacet coating over a diffuse base; the coating's
    /// integrals (and its distribution, α and η) are in the shared `table`.
    RoughPlastic {
        diffuse: Vec3,
        specular: Vec3,
        specular_weight: f32,
        nonlinear: bool,
        table: &'static RoughPlasticTable,
    },
    /// Mitsuba's `dielectric` with its reflection and transmission weighted by
    /// `reflectance` and `transmittance` (Glass when both are 1).
    Dielectric { ior: f32, reflectance: Vec3, transmittance: Vec3 },
    /// Mitsuba's `thindielectric` ([`thin_dielectric`]).
    ThinDielectric { ior: f32, reflectance: Vec3, transmittance: Vec3 },
    /// Mitsuba's `roughdielectric` ([`rough_dielectric`]): a microfacet interface of relative
    /// index `eta` (inside over outside, the outside in front of the shading normal) that
    /// reflects (weighted by `reflectance`) and refracts (by `transmittance`), lit from
    /// either side: the one non-delta BSDF whose lobes reach below the surface.
    RoughDielectric { eta: f32, reflectance: Vec3, transmittance: Vec3, microfacet: Microfacet },
    /// Mitsuba's `mask` of a diffuse BSDF ([`mask`]): opaque with probability `opacity`.
    Mask { opacity: f32, albedo: Vec3 },
    /// Mitsuba's `blendbsdf` of any two BSDFs or `mask` of any other one ([`composite`]):
    /// the `parts` mixed by `weight` (the blend's second part's share, the mask's opacity),
    /// resolved at the texture coordinates `uv` (at their textures' means where `None`).
    Composite { weight: f32, parts: &'static Composite, uv: Option<Vec2> },
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
            // Schlick's mean of the Fresnel term over the hemisphere, F₀ + (1 − F₀)/21.
            Bsdf::RoughConductor { specular, ior, .. } => {
                let f0 = ior.reflectance(1.0);
                specular * (f0 + (Vec3::ONE - f0) / 21.0)
            }
            // The base, plus the rough coating at normal incidence.
            Bsdf::Plastic { diffuse, .. } => diffuse,
            Bsdf::RoughPlastic { diffuse, specular, table, .. } => {
                diffuse + specular * fresnel::fresnel_dielectric(1.0, table.eta).reflectance
            }
            Bsdf::Mask { opacity, albedo } => albedo * opacity,
            Bsdf::Composite { weight, parts, uv } => composite::reflectance(parts, weight, uv),
            // What leaves either side at normal incidence: R F₀ + T (1 − F₀).
            Bsdf::RoughDielectric { eta, reflectance, transmittance, .. } => {
                let f0 = fresnel::fresnel_dielectric(1.0, eta).reflectance;
                reflectance * f0 + transmittance * (1.0 - f0)
            }
            Bsdf::Mirror { .. }
            | Bsdf::Glass { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => Vec3::ZERO,
        }
    }

    /// True for materials that have only delta lobes (mirror, glass, smooth conductors and
    /// dielectrics). Plastic and mask have a delta lobe and a diffuse one: not delta, and their
    /// samples say which lobe they came from ([`BsdfSample::delta`]).
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Mirror { .. }
            | Bsdf::Glass { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. } => true,
            Bsdf::Composite { parts, .. } => parts.is_delta(),
            _ => false,
        }
    }

    /// Whether some of its samples come from a delta lobe: the delta materials, plastic,
    /// mask, and composites with such a part.
    pub fn has_delta(&self) -> bool {
        match self {
            Bsdf::Composite { parts, .. } => parts.has_delta(),
            _ => self.is_delta() || matches!(self, Bsdf::Plastic { .. } | Bsdf::Mask { .. }),
        }
    }

    /// The narrowest microfacet roughness (α) of its non-delta lobes; `None` without a
    /// microfacet lobe.
    pub fn glossy_alpha(&self) -> Option<f32> {
        match *self {
            Bsdf::Glossy { roughness, .. } => Some(roughness),
            Bsdf::RoughConductor { microfacet, .. } => Some(microfacet.alpha),
            Bsdf::RoughPlastic { table, .. } => Some(table.microfacet.alpha),
            Bsdf::RoughDielectric { microfacet, .. } => Some(microfacet.alpha),
            Bsdf::Composite { weight, parts, uv } => composite::glossy_alpha(parts, weight, uv),
            _ => None,
        }
    }

    /// The widest microfacet roughness (α) of its non-delta lobes where every one of them is
    /// a microfacet lobe (a rough conductor or dielectric, a glossy lobe without a diffuse
    /// part, a blend of those with delta parts); `None` where one of them is not (a diffuse
    /// base: a rough plastic, a glossy lobe over an albedo) or where there is none. Where
    /// it is small, every direction the BSDF scatters into lies near a delta lobe's.
    pub fn widest_alpha(&self) -> Option<f32> {
        match *self {
            Bsdf::Glossy { albedo, roughness, .. } if albedo == Vec3::ZERO => Some(roughness),
            Bsdf::RoughConductor { microfacet, .. } | Bsdf::RoughDielectric { microfacet, .. } => {
                Some(microfacet.alpha)
            }
            Bsdf::Composite { weight, parts, uv } => composite::widest_alpha(parts, weight, uv),
            _ => None,
        }
    }

    /// Whether a non-delta lobe transmits: the rough dielectric (or a composite with one),
    /// whose [`Bsdf::eval`] and [`Bsdf::pdf`] are non-zero for directions on both sides of
    /// the surface, from either side. Every other non-delta BSDF reflects only into the
    /// hemisphere in front of both its normals.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Bsdf::RoughDielectric { .. } => true,
            Bsdf::Composite { parts, .. } => parts.transmits(),
            _ => false,
        }
    }

    /// Whether light that arrives from `w` (a unit direction away from the surface) can
    /// leave again by a non-delta lobe in any direction: `w` in front of the geometric
    /// normal and above the shading horizon (for a transmitting BSDF, on the same side of
    /// both normals, either side), a non-delta BSDF, a non-zero reflectance. Where it is
    /// false, [`Bsdf::eval`] with `w` as either direction is zero for every other direction,
    /// so a virtual light there adds nothing to any receiver.
    pub fn reflects_from(&self, g: &LocalGeometry, w: Vec3) -> bool {
        if let Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet } = *self {
            let lobe = RoughDielectric { eta, reflectance, transmittance, microfacet };
            return w.dot(g.ng) * w.dot(g.frame.n) > 0.0 && !lobe.is_black();
        }
        if let Bsdf::Composite { weight, parts, uv } = *self {
            return composite::reflects_from(parts, weight, uv, g, w);
        }
        !self.is_delta()
            && w.dot(g.ng) > 0.0
            && w.dot(g.frame.n) > 0.0
            && self.reflectance().max_element() > 0.0
    }

    /// f(wo, wi) · |cos θi| for the non-delta part; zero for delta materials.
    ///
    /// Zero unless `wo` and `wi` are both in front of the geometric normal and above the
    /// shading horizon (for a transmitting BSDF, [`Bsdf::transmits`]: unless each is on the
    /// same side of both normals, either side). In [`TransportMode::Importance`] the shading-normal correction is
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
        if self.transmits() || matches!(self, Bsdf::Composite { .. }) {
            return PreparedBsdf::new(*self, *g, wo, TransportMode::Radiance).pdf(wi);
        }
        let Some((wo_l, wi_l)) = reflection_pair(g, wo, wi) else { return 0.0 };
        self.local_pdf(wo_l, wi_l)
    }

    /// The pdf of sampling `wi_l` given `wo_l`, both in the shading frame and above its
    /// horizon (for a transmitting BSDF, either side): zero for delta and black BSDFs, and
    /// wherever it would not be finite.
    #[inline]
    pub(crate) fn local_pdf(&self, wo_l: Vec3, wi_l: Vec3) -> f32 {
        let p = match *self {
            Bsdf::Diffuse { albedo } if albedo.max_element() > 0.0 => diffuse::pdf(wi_l),
            Bsdf::Glossy { albedo, specular, roughness } => {
                let lobe = Glossy::new(albedo, specular, roughness);
                if lobe.is_black() { 0.0 } else { lobe.pdf(wo_l, wi_l) }
            }
            Bsdf::RoughConductor { specular, ior, microfacet } if specular.max_element() > 0.0 => {
                RoughConductor { specular, ior, microfacet }.pdf(wo_l, wi_l)
            }
            Bsdf::Plastic { diffuse, specular, eta, specular_weight, nonlinear } => {
                Plastic { diffuse, specular, eta, specular_weight, nonlinear }.pdf(wo_l, wi_l)
            }
            Bsdf::RoughPlastic { diffuse, specular, specular_weight, nonlinear, table } => {
                RoughPlastic { diffuse, specular, specular_weight, nonlinear, table }.pdf(wo_l, wi_l)
            }
            Bsdf::Mask { opacity, albedo } if albedo.max_element() > 0.0 => opacity * diffuse::pdf(wi_l),
            Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet } => {
                let lobe = RoughDielectric { eta, reflectance, transmittance, microfacet };
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
            Bsdf::Diffuse { .. }
            | Bsdf::Glossy { .. }
            | Bsdf::RoughConductor { .. }
            | Bsdf::RoughPlastic { .. }
            | Bsdf::RoughDielectric { .. } => self.sample_non_delta(g, wo, u_lobe, u, mode),
            Bsdf::Conductor { specular, ior } => {
                let n = g.frame.n;
                let cos_o = wo.dot(n);
                if !(wo.dot(g.ng) > 0.0 && cos_o > 0.0) {
                    return None;
                }
                let wi = mirror::reflect(wo, n).try_normalize()?;
                if wi.dot(g.ng).is_nan() || wi.dot(g.ng) <= 0.0 {
                    return None;
                }
                let weight = specular * ior.reflectance(cos_o) * mode_factor(g, wo, wi, mode);
                finite_sample(wi, weight, 1.0, true, 1.0)
            }
            Bsdf::Plastic { diffuse, specular, eta, specular_weight, nonlinear } => {
                let prepared = PreparedBsdf::new(*self, *g, wo, mode);
                if !prepared.is_active() {
                    return None;
                }
                let lobe = Plastic { diffuse, specular, eta, specular_weight, nonlinear };
                match lobe.choose(prepared.wo_local(), u_lobe, u) {
                    Err((wi_l, weight, p)) => {
                        let wi = g.frame.to_world(wi_l).try_normalize()?;
                        if wi.dot(g.ng).is_nan() || wi.dot(g.ng) <= 0.0 {
                            return None;
                        }
                        finite_sample(wi, weight * mode_factor(g, wo, wi, mode), p, true, 1.0)
                    }
                    Ok(wi_l) => Self::sampled_non_delta(&prepared, g, wi_l),
                }
            }
            Bsdf::Mask { opacity, .. } => {
                let (pass, x) = choose(refined(u.x, u_lobe), 1.0 - opacity);
                if pass {
                    return finite_sample(-wo, Vec3::ONE, 1.0 - opacity, true, 1.0);
                }
                let prepared = PreparedBsdf::new(*self, *g, wo, mode);
                if !prepared.is_active() {
                    return None;
                }
                Self::sampled_non_delta(&prepared, g, diffuse::sample(Vec2::new(x, u.y)))
            }
            Bsdf::Dielectric { ior, reflectance, transmittance } => {
                let s = glass::sample(g.frame.n, ior, wo, u_lobe, mode)?;
                let lobe = if s.eta == 1.0 && s.wi.dot(g.frame.n) * wo.dot(g.frame.n) > 0.0 {
                    reflectance
                } else {
                    transmittance
                };
                let weight = lobe * (s.weight * mode_factor(g, wo, s.wi, mode));
                finite_sample(s.wi, weight, s.prob, true, s.eta)
            }
            Bsdf::ThinDielectric { ior, reflectance, transmittance } => {
                let n = g.frame.n;
                let n = if wo.dot(n) < 0.0 { -n } else { n };
                let (wi, reflected, p) = thin_dielectric::sample(n, ior, wo, u_lobe)?;
                let lobe = if reflected { reflectance } else { transmittance };
                finite_sample(wi, lobe * mode_factor(g, wo, wi, mode), p, true, 1.0)
            }
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
            Bsdf::Composite { weight, parts, uv } => {
                composite::sample(parts, (weight, uv), g, wo, u_lobe, u, mode)
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
        // horizon (the material is not delta here; a transmitting one: on the same side of
        // both normals).
        let prepared = PreparedBsdf::new(*self, *g, wo, mode);
        if !prepared.is_active() {
            return None;
        }
        let wi_l = match *self {
            Bsdf::Diffuse { albedo } if albedo.max_element() > 0.0 => diffuse::sample(u),
            Bsdf::Glossy { albedo, specular, roughness } => {
                Glossy::new(albedo, specular, roughness).sample(prepared.wo_local(), u_lobe, u)?
            }
            Bsdf::RoughConductor { specular, ior, microfacet } => {
                RoughConductor { specular, ior, microfacet }.sample(prepared.wo_local(), u)?
            }
            Bsdf::RoughPlastic { diffuse, specular, specular_weight, nonlinear, table } => {
                RoughPlastic { diffuse, specular, specular_weight, nonlinear, table }.sample(
                    prepared.wo_local(),
                    u_lobe,
                    u,
                )?
            }
            Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet } => {
                RoughDielectric { eta, reflectance, transmittance, microfacet }.sample(
                    prepared.wo_local(),
                    u_lobe,
                    u,
                )?
            }
            _ => return None,
        };
        Self::sampled_non_delta(&prepared, g, wi_l)
    }

    /// The sample of the non-delta direction `wi_l` (shading frame), with the values of the
    /// public eval and pdf, so that weight == eval / pdf exactly.
    fn sampled_non_delta(prepared: &PreparedBsdf, g: &LocalGeometry, wi_l: Vec3) -> Option<BsdfSample> {
        let wi = g.frame.to_world(wi_l).try_normalize()?;
        // The values of the public eval and pdf, so that weight == eval / pdf exactly.
        let (f, pdf) = prepared.eval_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        // A refraction crosses η_t / η_i (the rough dielectric's only; `eval_pdf` found both
        // directions on their sides of both normals).
        let wo_z = prepared.wo_local().z;
        let eta = match *prepared.bsdf() {
            Bsdf::RoughDielectric { eta, .. } if wi_l.z * wo_z < 0.0 => {
                if wo_z > 0.0 {
                    eta
                } else {
                    1.0 / eta
                }
            }
            _ => 1.0,
        };
        finite_sample(wi, f / pdf, pdf, false, eta)
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

    /// A `blendbsdf` of two constant BSDFs, the second of share `w`.
    fn blend(w: f32, a: Bsdf, b: Bsdf) -> Bsdf {
        let part = |bsdf| composite::Part { bsdf, textures: None };
        Bsdf::Composite { weight: w, parts: Composite::Blend([part(a), part(b)]).intern(), uv: None }
    }

    /// A `mask` of opacity `w` of a constant BSDF.
    fn mask(w: f32, inner: Bsdf) -> Bsdf {
        let parts = Composite::Mask(composite::Part { bsdf: inner, textures: None }).intern();
        Bsdf::Composite { weight: w, parts, uv: None }
    }

    /// `widest_alpha`: the widest microfacet lobe where every non-delta lobe is one; none
    /// where a diffuse lobe is among them, or no non-delta lobe at all.
    #[test]
    fn widest_alpha_is_the_widest_lobe_where_every_lobe_is_a_microfacet() {
        use microfacet::Distribution::{Beckmann, Ggx};
        let lambert = Bsdf::Diffuse { albedo: Vec3::splat(0.5) };
        let metal = |alpha| Bsdf::RoughConductor {
            specular: Vec3::ONE,
            ior: conductor::ComplexIor::NONE,
            microfacet: Microfacet::new(Ggx, alpha),
        };
        let glass = |alpha| Bsdf::RoughDielectric {
            eta: 1.5,
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
            microfacet: Microfacet::new(Beckmann, alpha),
        };
        let coat = |albedo| Bsdf::Glossy { albedo, specular: Vec3::splat(0.5), roughness: 0.02 };
        let mirror = Bsdf::Mirror { specular: Vec3::ONE };
        for (bsdf, expected) in [
            (metal(0.01), Some(0.01)),
            (glass(0.001), Some(0.001)),
            (coat(Vec3::ZERO), Some(0.02)),
            (coat(Vec3::splat(0.3)), None),
            (lambert, None),
            (mirror, None),
            (Bsdf::rough_plastic(Vec3::splat(0.5), None, 1.5, Microfacet::new(Ggx, 0.01), false), None),
            (blend(0.3, metal(0.01), glass(0.05)), Some(0.05)),
            (blend(0.3, metal(0.01), mirror), Some(0.01)),
            (blend(0.3, metal(0.01), lambert), None),
            (blend(0.0, metal(0.01), lambert), Some(0.01)),
            (blend(0.5, mirror, Bsdf::Glass { ior: 1.5 }), None),
            (mask(0.6, metal(0.02)), Some(0.02)),
            (mask(0.6, lambert), None),
        ] {
            assert_eq!(bsdf.widest_alpha(), expected, "{bsdf:?}");
        }
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
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: Vec3::ONE,
                transmittance: Vec3::new(0.5, 0.2, 0.0),
                microfacet: Microfacet::new(microfacet::Distribution::Ggx, 0.4),
            },
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: Vec3::ZERO,
                transmittance: Vec3::ZERO,
                microfacet: Microfacet::new(microfacet::Distribution::Beckmann, 0.4),
            },
            blend(
                0.3,
                Bsdf::Diffuse { albedo: Vec3::new(0.8, 0.5, 0.2) },
                Bsdf::RoughDielectric {
                    eta: 1.5,
                    reflectance: Vec3::ONE,
                    transmittance: Vec3::new(0.5, 0.2, 0.0),
                    microfacet: Microfacet::new(microfacet::Distribution::Ggx, 0.4),
                },
            ),
            blend(0.5, Bsdf::Mirror { specular: Vec3::ONE }, Bsdf::Diffuse { albedo: Vec3::ZERO }),
            mask(0.6, Bsdf::Glossy { albedo: Vec3::ZERO, specular: Vec3::splat(0.5), roughness: 0.3 }),
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

    /// Every BSDF of Mitsuba's set: a non-delta sample's pdf and weight are the public pdf and
    /// eval / pdf; the share of non-delta samples is the integral of the pdf over the sphere
    /// (by uniform directions); white materials reflect at most what they receive (white
    /// furnace), and, reciprocal ones, the same in importance mode with ns = ng.
    #[test]
    fn sampling_matches_pdf_and_conserves_energy() {
        use microfacet::Distribution::{Beckmann, Ggx};
        let mut rng = Sampler::new(21, 0, Domain::Iteration, 0);
        let white = Vec3::ONE;
        let ior = conductor::ComplexIor { eta: Vec3::new(0.2, 0.9, 1.1), k: Vec3::new(3.9, 2.4, 2.1) };
        let bsdfs = [
            Bsdf::RoughConductor {
                specular: white,
                ior: conductor::ComplexIor::NONE,
                microfacet: Microfacet::new(Ggx, 0.3),
            },
            Bsdf::RoughConductor { specular: white, ior, microfacet: Microfacet::new(Beckmann, 0.2) },
            Bsdf::RoughConductor {
                specular: white,
                ior: conductor::ComplexIor::NONE,
                microfacet: Microfacet::new(Beckmann, 0.6),
            },
            Bsdf::Conductor { specular: white, ior },
            Bsdf::plastic(white, None, 1.5, false),
            Bsdf::plastic(Vec3::new(0.9, 0.5, 0.1), Some(white), 1.9, true),
            Bsdf::rough_plastic(white, None, 1.5, Microfacet::new(Ggx, 0.2), false),
            Bsdf::rough_plastic(white, Some(white), 1.5, Microfacet::new(Beckmann, 0.4), true),
            Bsdf::Dielectric { ior: 1.5, reflectance: white, transmittance: Vec3::ZERO },
            Bsdf::ThinDielectric { ior: 1.5, reflectance: white, transmittance: white },
            Bsdf::Mask { opacity: 0.7, albedo: white },
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: white,
                transmittance: white,
                microfacet: Microfacet::new(Ggx, 0.3),
            },
            Bsdf::RoughDielectric {
                eta: 1.33,
                reflectance: white,
                transmittance: white,
                microfacet: Microfacet::new(Beckmann, 0.3),
            },
            // Composites: non-delta parts, a delta and a non-delta one, a transmitting one,
            // masks of a microfacet lobe and of a delta one, and a blend within a mask.
            blend(
                0.3,
                Bsdf::RoughConductor { specular: white, ior, microfacet: Microfacet::new(Beckmann, 0.2) },
                Bsdf::Diffuse { albedo: white },
            ),
            blend(0.6, Bsdf::Conductor { specular: white, ior }, Bsdf::Diffuse { albedo: white }),
            blend(
                0.4,
                Bsdf::RoughDielectric {
                    eta: 1.5,
                    reflectance: white,
                    transmittance: white,
                    microfacet: Microfacet::new(Ggx, 0.3),
                },
                Bsdf::rough_plastic(white, None, 1.5, Microfacet::new(Ggx, 0.2), false),
            ),
            mask(0.6, Bsdf::RoughConductor { specular: white, ior, microfacet: Microfacet::new(Ggx, 0.3) }),
            mask(0.3, Bsdf::Dielectric { ior: 1.5, reflectance: white, transmittance: white }),
            mask(0.8, blend(0.5, Bsdf::plastic(white, None, 1.5, false), Bsdf::Diffuse { albedo: white })),
        ];
        for bsdf in bsdfs {
            let g = LocalGeometry { ng: Vec3::Z, frame: Frame::from_normal(Vec3::Z) };
            // A transmitting BSDF is lit from inside too, its pdf integrated over the sphere,
            // and its furnace taken in importance mode (radiance mode scales refraction by
            // (η_i/η_t)², which is not energy).
            let transmits = bsdf.transmits();
            let cosines: &[f32] = if transmits { &[0.95, 0.5, 0.15, -0.9, -0.4] } else { &[0.95, 0.5, 0.15] };
            let mode = if transmits { TransportMode::Importance } else { TransportMode::Radiance };
            for &cos_o in cosines {
                let wo = Vec3::new((1.0 - cos_o * cos_o).sqrt(), 0.0, cos_o);
                let n = 40_000;
                let (mut non_delta, mut energy) = (0usize, Vec3::ZERO);
                for _ in 0..n {
                    let Some(s) = bsdf.sample(&g, wo, rng.next_f32(), rng.next_2d(), mode) else {
                        continue;
                    };
                    energy += s.weight;
                    if !s.delta {
                        non_delta += 1;
                        let (f, pdf) = (bsdf.eval(&g, wo, s.wi, mode), bsdf.pdf(&g, wo, s.wi));
                        assert!((pdf - s.pdf).abs() <= 1e-4 * pdf, "{bsdf:?}: {pdf} vs {}", s.pdf);
                        assert!(
                            (f / pdf - s.weight).abs().max_element() <= 1e-3 * s.weight.max_element() + 1e-6
                        );
                    }
                }
                let albedo = energy / n as f32;
                assert!(albedo.max_element() <= 1.02, "{bsdf:?} cos {cos_o}: albedo {albedo}");
                if let Bsdf::RoughDielectric { microfacet, .. } = bsdf {
                    // Lossless: all but what the microfacets' single scattering loses leaves,
                    // as Mitsuba 3.9.1's mean importance-mode sample weight over 10⁶ samples
                    // (`BSDF.sample` in `llvm_ad_rgb`) at the cosines above.
                    let mitsuba: [f32; 5] = match microfacet.kind {
                        Ggx => [0.98670, 0.94681, 0.86735, 0.87934, 0.76435],
                        Beckmann => [0.99992, 0.98135, 0.95362, 0.99483, 0.84101],
                    };
                    let expected = mitsuba[cosines.iter().position(|&c| c == cos_o).unwrap()];
                    assert!(
                        (albedo - Vec3::splat(expected)).abs().max_element() < 0.01,
                        "{bsdf:?} cos {cos_o}: albedo {albedo}, Mitsuba's {expected}"
                    );
                }
                // ∫ pdf dω over the upper hemisphere (the sphere), by uniform directions.
                let (lowest, solid, m) = if transmits { (-1.0, 4.0, 1_000_000) } else { (0.0, 2.0, 200_000) };
                let integral =
                    (0..m).map(|_| bsdf.pdf(&g, wo, uniform_cone(rng.next_2d(), lowest)) as f64).sum::<f64>()
                        * solid
                        * std::f64::consts::PI
                        / m as f64;
                let share = non_delta as f64 / n as f64;
                assert!(
                    (integral - share).abs() < 0.03,
                    "{bsdf:?} cos {cos_o}: ∫ pdf {integral}, share {share}"
                );
            }
        }
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

    /// `eval_pdfs` is `eval`, `pdf` and the reverse `Bsdf::pdf` bit for bit: for the lobes it
    /// shares work in (Lambertian, glossy: black, rough, near-mirror, without a diffuse part)
    /// and for those it passes on, shading normals tilted off the geometric one, directions on
    /// both sides (and mirrored ones, in the glossy lobe), both modes.
    #[test]
    fn eval_pdfs_are_the_three_calls() {
        let mut rng = Sampler::new(7, 0, Domain::Iteration, 0);
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let glossy = |albedo: f32, specular: f32, roughness: f32| Bsdf::Glossy {
            albedo: Vec3::new(albedo, albedo * 0.5, 0.0),
            specular: Vec3::splat(specular),
            roughness,
        };
        let bsdfs = [
            Bsdf::Diffuse { albedo: Vec3::new(0.8, 0.5, 0.2) },
            Bsdf::Diffuse { albedo: Vec3::ZERO },
            glossy(0.3, 0.5, 0.3),
            glossy(0.05, 0.8, 0.05),
            glossy(0.0, 0.5, 0.01),
            glossy(0.5, 0.0, 0.2),
            glossy(0.0, 0.0, 0.2),
            Bsdf::RoughDielectric {
                eta: 1.5,
                reflectance: Vec3::ONE,
                transmittance: Vec3::new(0.5, 0.2, 0.0),
                microfacet: Microfacet::new(microfacet::Distribution::Ggx, 0.4),
            },
            blend(0.3, Bsdf::Diffuse { albedo: Vec3::new(0.8, 0.5, 0.2) }, glossy(0.0, 0.5, 0.2)),
            mask(0.6, glossy(0.0, 0.5, 0.3)),
            Bsdf::Mirror { specular: Vec3::ONE },
        ];
        let mut nonzero = 0;
        for bsdf in bsdfs {
            for _ in 0..3000 {
                let ng = dir(&mut rng);
                let ns = (ng + 0.3 * dir(&mut rng)).normalize();
                let g = LocalGeometry { ng, frame: Frame::from_normal(ns) };
                let wo = dir(&mut rng);
                let mirrored = (2.0 * wo.dot(ns) * ns - wo + 0.05 * dir(&mut rng)).normalize();
                for wi in [dir(&mut rng), mirrored] {
                    for mode in [TransportMode::Radiance, TransportMode::Importance] {
                        let p = PreparedBsdf::new(bsdf, g, wo, mode);
                        let (f, pdf, rev) = p.eval_pdfs(wi);
                        let calls = (bits(p.eval(wi)), p.pdf(wi).to_bits(), bsdf.pdf(&g, wi, wo).to_bits());
                        assert_eq!(
                            (bits(f), pdf.to_bits(), rev.to_bits()),
                            calls,
                            "{bsdf:?} {g:?} {wo} {wi}"
                        );
                        if rev > 0.0 && pdf > 0.0 {
                            nonzero += 1;
                        }
                    }
                }
            }
        }
        assert!(nonzero > 20_000, "{nonzero}");
    }
}
