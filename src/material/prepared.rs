//! A BSDF with its outgoing direction fixed, for evaluating many incident directions: the
//! VPL gather evaluates the receiver's BSDF for one `wo` against every VPL, and every VPL's
//! BSDF for its one incoming direction against every receiver. The checks and shading-frame
//! coordinates of the fixed direction are computed once. [`Bsdf::eval`] is defined through
//! this type, so both give the same values.

use glam::Vec3;

use super::conductor::RoughConductor;
use super::glossy::Glossy;
use super::plastic::{Plastic, RoughPlastic};
use super::rough_dielectric::RoughDielectric;
use super::{Bsdf, LocalGeometry, TransportMode, diffuse, shading_correction};

/// An active Lambertian [`PreparedBsdf`], taken apart ([`PreparedBsdf::as_diffuse`]). Its
/// `eval(wi)`, with `wi_ng = wi · ng` and `wi_ns = wi · ns` both positive, is
/// `albedo · (1/π · wi_ns)`, times `wo_cos_shading · |wi_ng| / (wo_cos_geometric · |wi_ns|)`
/// in importance mode (zero when that is not finite), then zero unless finite, clamped at 0.
#[derive(Clone, Copy, Debug)]
pub struct PreparedDiffuse {
    pub albedo: Vec3,
    pub mode: TransportMode,
    /// |wo · ns| and |wo · ng| of the fixed direction.
    pub wo_cos_shading: f32,
    pub wo_cos_geometric: f32,
}

#[derive(Clone, Copy, Debug)]
pub struct PreparedBsdf {
    bsdf: Bsdf,
    g: LocalGeometry,
    mode: TransportMode,
    /// The fixed direction, as given (for the reverse densities of [`PreparedBsdf::eval_pdfs`]).
    wo: Vec3,
    /// The fixed direction in the shading frame, and its cosine with the geometric normal.
    wo_l: Vec3,
    wo_ng: f32,
    /// Whether anything can be reflected: `wo` in front of both normals, a non-delta BSDF
    /// (a transmitting one, [`Bsdf::transmits`]: `wo` on the same side of both normals).
    active: bool,
}

impl PreparedBsdf {
    /// The BSDF it was prepared of (at its point: textures already evaluated).
    #[inline]
    pub fn bsdf(&self) -> &Bsdf {
        &self.bsdf
    }

    /// `wo` is the fixed direction (away from the surface); see [`Bsdf::eval`] for the
    /// conventions.
    #[inline]
    pub fn new(bsdf: Bsdf, g: LocalGeometry, wo: Vec3, mode: TransportMode) -> Self {
        let wo_ng = wo.dot(g.ng);
        let wo_l = g.frame.to_local(wo);
        let active = if bsdf.transmits() {
            wo_ng * wo_l.z > 0.0
        } else {
            wo_ng > 0.0 && wo_l.z > 0.0 && !bsdf.is_delta()
        };
        PreparedBsdf { bsdf, g, mode, wo, wo_l, wo_ng, active }
    }

    /// Whether [`PreparedBsdf::eval`] can be non-zero at all.
    #[inline]
    pub fn is_active(&self) -> bool {
        self.active
    }

    /// The constants of an active Lambertian BSDF, for code that evaluates many of them at
    /// once (the VPL gather's lanes) with exactly the operations of [`PreparedBsdf::eval`];
    /// `None` for other BSDFs and inactive ones.
    #[inline]
    pub fn as_diffuse(&self) -> Option<PreparedDiffuse> {
        match self.bsdf {
            Bsdf::Diffuse { albedo } if self.active => Some(PreparedDiffuse {
                albedo,
                mode: self.mode,
                wo_cos_shading: self.wo_l.z.abs(),
                wo_cos_geometric: self.wo_ng.abs(),
            }),
            _ => None,
        }
    }

    /// The fixed direction in the shading frame.
    #[inline]
    pub fn wo_local(&self) -> Vec3 {
        self.wo_l
    }

    /// f(wo, wi) · |cos θi|, exactly [`Bsdf::eval`] for the fixed `wo`.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Vec3 {
        if let Bsdf::Diffuse { albedo } = self.bsdf {
            let Some((wi_ng, wi_ns)) = self.incident_cosines(wi) else { return Vec3::ZERO };
            return self.finish(diffuse::eval_pdf_cos(albedo, wi_ns).0, wi_ng, wi_ns);
        }
        if let Bsdf::Composite { .. } = self.bsdf {
            return self.eval_composite(wi, false).0;
        }
        let Some((wi_ng, wi_l)) = self.incident(wi) else { return Vec3::ZERO };
        self.finish(self.lobe_eval(wi_l), wi_ng, wi_l.z)
    }

    /// The lobe's f · |cos θi| at `wi_l` (shading frame, above the horizon, or either side
    /// for a transmitting BSDF), before the transport-mode factor; zero for delta BSDFs.
    #[inline]
    fn lobe_eval(&self, wi_l: Vec3) -> Vec3 {
        match self.bsdf {
            Bsdf::Diffuse { albedo } => diffuse::eval(albedo, wi_l),
            Bsdf::Glossy { albedo, specular, roughness } => {
                Glossy::new(albedo, specular, roughness).eval(self.wo_l, wi_l)
            }
            Bsdf::RoughConductor { specular, ior, microfacet } => {
                RoughConductor { specular, ior, microfacet }.eval(self.wo_l, wi_l)
            }
            Bsdf::Plastic { diffuse, specular, eta, specular_weight, nonlinear } => {
                Plastic { diffuse, specular, eta, specular_weight, nonlinear }.eval(self.wo_l, wi_l)
            }
            Bsdf::RoughPlastic { diffuse, specular, specular_weight, nonlinear, table } => {
                RoughPlastic { diffuse, specular, specular_weight, nonlinear, table }.eval(self.wo_l, wi_l)
            }
            Bsdf::Mask { opacity, albedo } => diffuse::eval(albedo * opacity, wi_l),
            Bsdf::RoughDielectric { eta, reflectance, transmittance, microfacet } => {
                RoughDielectric { eta, reflectance, transmittance, microfacet }
                    .eval(self.wo_l, wi_l, self.mode)
            }
            // (A composite is evaluated part by part before coming here.)
            Bsdf::Mirror { .. }
            | Bsdf::Glass { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::Dielectric { .. }
            | Bsdf::ThinDielectric { .. }
            | Bsdf::Composite { .. } => Vec3::ZERO,
        }
    }

    /// [`PreparedBsdf::eval`] and [`Bsdf::pdf`] of `wi` at once, with the same values as the
    /// two calls: the checks and the shading-frame coordinates of `wi` are computed once.
    /// Next-event estimation needs both, and so does BSDF sampling for its weight eval / pdf.
    ///
    /// The Lambertian lobe, the common case, is inlined into the caller and needs only the
    /// cosines of `wi`; the other lobes take the general path.
    #[inline(always)]
    pub fn eval_pdf(&self, wi: Vec3) -> (Vec3, f32) {
        if let Bsdf::Diffuse { albedo } = self.bsdf {
            let Some((wi_ng, wi_ns)) = self.incident_cosines(wi) else { return (Vec3::ZERO, 0.0) };
            let (f, pdf) = diffuse::eval_pdf_cos(albedo, wi_ns);
            return (self.finish(f, wi_ng, wi_ns), pdf);
        }
        self.eval_pdf_general(wi)
    }

    /// [`Bsdf::pdf`] of `wi` alone (zero wherever [`PreparedBsdf::eval`] is): the density with
    /// which BSDF sampling picks `wi`, per unit solid angle.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if let Bsdf::Composite { .. } = self.bsdf {
            return self.eval_composite(wi, true).1;
        }
        let Some((_, wi_l)) = self.incident(wi) else { return 0.0 };
        self.bsdf.local_pdf(self.wo_l, wi_l)
    }

    /// [`PreparedBsdf::eval`], [`PreparedBsdf::pdf`] and the reverse density
    /// [`Bsdf::pdf`]`(g, wi, wo)` (of sampling the fixed direction from `wi`) at once, each
    /// bit for bit what its own call gives: what a bidirectional connection needs of each end.
    /// The Lambertian lobe needs only the cosines, the glossy one shares its half vector, D
    /// and G1 ([`Glossy::eval_pdfs`]); the others are the three calls.
    #[inline]
    pub fn eval_pdfs(&self, wi: Vec3) -> (Vec3, f32, f32) {
        match self.bsdf {
            Bsdf::Diffuse { albedo } => {
                let Some((wi_ng, wi_ns)) = self.incident_cosines(wi) else { return (Vec3::ZERO, 0.0, 0.0) };
                let (f, pdf) = diffuse::eval_pdf_cos(albedo, wi_ns);
                // (`Bsdf::pdf`'s Lambertian case: cos θo / π where the albedo is not black.)
                let rev = if albedo.max_element() > 0.0 {
                    diffuse::pdf(Vec3::new(0.0, 0.0, self.wo_l.z))
                } else {
                    0.0
                };
                (self.finish(f, wi_ng, wi_ns), pdf, rev)
            }
            Bsdf::Glossy { albedo, specular, roughness } => {
                let Some((wi_ng, wi_l)) = self.incident(wi) else { return (Vec3::ZERO, 0.0, 0.0) };
                let lobe = Glossy::new(albedo, specular, roughness);
                let (f, pdf, rev) = lobe.eval_pdfs(self.wo_l, wi_l);
                // (`Bsdf::local_pdf`'s checks.)
                let density = |p: f32| match lobe.is_black() {
                    true => 0.0,
                    false if p.is_finite() => p.max(0.0),
                    false => 0.0,
                };
                (self.finish(f, wi_ng, wi_l.z), density(pdf), density(rev))
            }
            _ => (self.eval(wi), self.pdf(wi), self.bsdf.pdf(&self.g, wi, self.wo)),
        }
    }

    /// [`PreparedBsdf::eval_pdf`] of any lobe.
    #[inline(never)]
    pub(super) fn eval_pdf_general(&self, wi: Vec3) -> (Vec3, f32) {
        if let Bsdf::Composite { .. } = self.bsdf {
            return self.eval_composite(wi, true);
        }
        let Some((wi_ng, wi_l)) = self.incident(wi) else { return (Vec3::ZERO, 0.0) };
        (self.finish(self.lobe_eval(wi_l), wi_ng, wi_l.z), self.bsdf.local_pdf(self.wo_l, wi_l))
    }

    /// A composite's eval and (where `with_pdf`) pdf: part by part, each with its own checks
    /// and transport-mode factor (`wo` from the shading frame again).
    #[inline(never)]
    fn eval_composite(&self, wi: Vec3, with_pdf: bool) -> (Vec3, f32) {
        let Bsdf::Composite { weight, parts, uv } = self.bsdf else { return (Vec3::ZERO, 0.0) };
        if !self.active {
            return (Vec3::ZERO, 0.0);
        }
        let wo = self.g.frame.to_world(self.wo_l);
        super::composite::eval_pdf(parts, (weight, uv), &self.g, wo, wi, self.mode, with_pdf)
    }

    /// `wi · ng` and `wi · ns` when the BSDF is active and `wi` is in front of the geometric
    /// normal and above the shading horizon; `None` otherwise.
    #[inline]
    fn incident_cosines(&self, wi: Vec3) -> Option<(f32, f32)> {
        if !self.active {
            return None;
        }
        let wi_ng = wi.dot(self.g.ng);
        if wi_ng.is_nan() || wi_ng <= 0.0 {
            return None;
        }
        let wi_ns = wi.dot(self.g.frame.n);
        (wi_ns > 0.0).then_some((wi_ng, wi_ns))
    }

    /// [`PreparedBsdf::incident_cosines`] with the whole of `wi` in the shading frame (its z
    /// is `wi · ns`); for a transmitting BSDF, `wi` on either side, the same side of both
    /// normals.
    #[inline]
    fn incident(&self, wi: Vec3) -> Option<(f32, Vec3)> {
        if self.bsdf.transmits() {
            if !self.active {
                return None;
            }
            let (wi_ng, wi_l) = (wi.dot(self.g.ng), self.g.frame.to_local(wi));
            return (wi_ng * wi_l.z > 0.0).then_some((wi_ng, wi_l));
        }
        let (wi_ng, _) = self.incident_cosines(wi)?;
        Some((wi_ng, self.g.frame.to_local(wi)))
    }

    /// The transport-mode factor applied to a lobe's value, then zero unless finite, clamped
    /// at 0.
    #[inline]
    fn finish(&self, value: Vec3, wi_ng: f32, wi_ns: f32) -> Vec3 {
        finish(self.mode, value, self.wo_l.z, self.wo_ng, wi_ng, wi_ns)
    }
}

/// A lobe's value for `wo`, `wi` with the cosines `wo · ns`, `wo · ng`, `wi · ng`, `wi · ns`:
/// times the transport-mode factor, then zero unless finite, clamped at 0. In radiance mode
/// the factor is 1 and not multiplied in (the same value).
#[inline]
pub(super) fn finish(
    mode: TransportMode,
    value: Vec3,
    wo_ns: f32,
    wo_ng: f32,
    wi_ng: f32,
    wi_ns: f32,
) -> Vec3 {
    let value = match mode {
        TransportMode::Radiance => value,
        TransportMode::Importance => value * shading_correction(wo_ns, wo_ng, wi_ng, wi_ns),
    };
    if value.is_finite() { value.max(Vec3::ZERO) } else { Vec3::ZERO }
}
