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

use glam::{Vec2, Vec3};

use crate::geometry::Frame;

/// A named material: how it scatters and what it emits.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub bsdf: Bsdf,
    /// Radiance emitted from the front face (zero for non-emitters).
    pub emission: Vec3,
}

impl Material {
    pub fn is_emitter(&self) -> bool {
        self.emission.max_element() > 0.0
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
    /// True for materials that have only delta lobes (mirror, glass).
    pub fn is_delta(&self) -> bool {
        matches!(self, Bsdf::Mirror { .. } | Bsdf::Glass { .. })
    }

    /// f(wo, wi) · |cos θi| for the non-delta part; zero for delta materials.
    pub fn eval(&self, _g: &LocalGeometry, _wo: Vec3, _wi: Vec3, _mode: TransportMode) -> Vec3 {
        Vec3::ZERO
    }

    /// Solid-angle density with which [`Bsdf::sample`] returns `wi`; zero for delta materials.
    pub fn pdf(&self, _g: &LocalGeometry, _wo: Vec3, _wi: Vec3, _mode: TransportMode) -> f32 {
        0.0
    }

    /// Samples `wi` given `wo`; `u_lobe` chooses between lobes, `u` places the direction.
    pub fn sample(
        &self,
        _g: &LocalGeometry,
        _wo: Vec3,
        _u_lobe: f32,
        _u: Vec2,
        _mode: TransportMode,
    ) -> Option<BsdfSample> {
        None
    }
}
