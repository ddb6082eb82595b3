//! Direct lighting from the real emitters: next-event estimation with multiple importance
//! sampling against BSDF sampling (power heuristic), shared by every method; for scenes with
//! lights other than triangles ([`crate::light::Light`]) their samples, and the environment
//! a ray that leaves the scene sees.

use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

use super::{Counters, RenderContext};
use crate::geometry::{OffsetPoint, Ray, offset_origin};
use crate::light::{Choice, ConeSample, EmitterSample, Light, NeeChoice};
use crate::material::{Bsdf, LocalGeometry, Material, PreparedBsdf, TransportMode};
use crate::sampling::Sampler;
use crate::scene::SurfacePoint;

/// Veach's power heuristic (β = 2) for the technique with density `a` against `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2.is_infinite() {
        return 1.0;
    }
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// The segment between two surface points, both ends moved off their surfaces so that
/// neither surface occludes it. The interval is `(0, 1)` in units of the segment.
#[inline]
pub fn shadow_ray(p: Vec3, ng: Vec3, q: Vec3, nq: Vec3) -> Ray {
    // [`shadow_segment`] of the two points, each offset only on the side it needs.
    let o = offset_origin(p, ng, q - p);
    let t = offset_origin(q, nq, p - q);
    Ray { origin: o, dir: t - o, tmin: 0.0, tmax: 1.0 }
}

/// [`shadow_ray`] between two points whose offsets are already computed.
#[inline]
pub fn shadow_segment(a: &OffsetPoint, b: &OffsetPoint) -> Ray {
    let o = a.toward(b.p - a.p);
    let t = b.toward(a.p - b.p);
    Ray { origin: o, dir: t - o, tmin: 0.0, tmax: 1.0 }
}

/// Whether anything blocks the segment between two surface points.
#[inline]
pub fn occluded(ctx: &RenderContext, p: Vec3, ng: Vec3, q: Vec3, nq: Vec3, counters: &mut Counters) -> bool {
    counters.shadow_rays += 1;
    ctx.accel.occluded(&shadow_ray(p, ng, q, nq))
}

/// One light sample at `sp`: picks a point on an emitter (by power, or by importance at
/// `sp` where the emitters are triangles: [`crate::light::spatial`]), and returns its
/// contribution f · Le · G · V / pdf, MIS-weighted against BSDF sampling. Always draws three
/// numbers from `sampler`.
pub fn sample_emitters(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> Vec3 {
    sample_emitters_weighted(ctx, sp, bsdf, wo, sampler, counters, |s| {
        power_heuristic(s.pdf_light, s.pdf_bsdf)
    })
}

/// What a light sample's MIS weight may depend on.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// The density of the light sample per unit solid angle at the receiver.
    pub pdf_light: f32,
    /// The density of the receiver's BSDF sampling in the same direction.
    pub pdf_bsdf: f32,
    /// The cosine at the emitter point, and its squared distance from the receiver.
    pub cos_light: f32,
    pub dist2: f32,
    /// The unit direction from the receiver towards the emitter point.
    pub wi: Vec3,
    /// For a light that is not a triangle ([`crate::light::Light::emission_density`]): the
    /// density with which a light path leaving it reaches the receiver, per unit area there
    /// and without its cosine, beyond what next-event estimation picks of the same light;
    /// `None` for a triangle that next-event estimation picks as the light paths do, whose is
    /// N-free cos θ_e / π / dist2. For a sphere's triangle sampled by its cone, or a triangle
    /// picked by its importance at the receiver ([`crate::light::spatial`]), the same density
    /// relative to next-event estimation's of the point: p_A / (π pdf_light), p_A the light
    /// paths' area density.
    pub emission: Option<f32>,
}

/// [`sample_emitters`] with the MIS weight given by `weight` instead of the power heuristic
/// against BSDF sampling. Always draws three numbers from `sampler`.
#[inline]
pub fn sample_emitters_weighted(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    sampler: &mut Sampler,
    counters: &mut Counters,
    weight: impl FnOnce(LightSample) -> f32,
) -> Vec3 {
    sample_emitters_at(ctx, sp, bsdf, wo, emitter_numbers(sampler), counters, weight)
}

/// A light sample's numbers, `u_select` and `u`, as
/// [`Emitters::sample`](crate::light::Emitters::sample) takes them: three draws, in this order.
#[inline(always)]
pub fn emitter_numbers(sampler: &mut Sampler) -> (f32, Vec2) {
    let u_select = sampler.next_f32();
    (u_select, sampler.next_2d())
}

/// [`sample_emitters_weighted`] with its numbers given: `u_select` and `u` as
/// [`Emitters::sample`](crate::light::Emitters::sample) takes them.
#[inline]
pub fn sample_emitters_at(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    (u_select, u): (f32, Vec2),
    counters: &mut Counters,
    weight: impl FnOnce(LightSample) -> f32,
) -> Vec3 {
    let Some(c) = connect_emitters_at(ctx, sp, bsdf, wo, (u_select, u), counters) else {
        return Vec3::ZERO;
    };
    if c.shadow.is_some_and(|ray| ctx.accel.occluded(&ray)) {
        return Vec3::ZERO;
    }
    c.value(weight)
}

/// A light sample connected to a receiver, its visibility not yet known: what next-event
/// estimation adds unless something blocks [`Connection::shadow`]. Split from the test so
/// that a batched walker may trace the shadow rays of many paths together
/// ([`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch)) and add the
/// same values as [`sample_emitters_at`], which tests its one ray at once.
#[derive(Clone, Copy, Debug)]
pub struct Connection {
    /// The segment whose occlusion hides the sample; `None` where its visibility was settled
    /// already (a sphere's cone sample, found by a closest-hit query).
    pub shadow: Option<Ray>,
    /// What the MIS weight may depend on.
    pub sample: LightSample,
    /// The unweighted contribution is `scale / over`: f · Le over the light's density, or for
    /// a light other than a triangle f · (its sample's weight) over the light's pmf.
    scale: Vec3,
    over: f32,
}

impl Connection {
    /// The contribution of an unoccluded sample under the MIS weight `weight`.
    #[inline]
    pub fn value(&self, weight: impl FnOnce(LightSample) -> f32) -> Vec3 {
        self.scale * (weight(self.sample) / self.over)
    }
}

/// The light sample of [`sample_emitters_at`] up to its shadow ray: `None` where it
/// contributes nothing whether or not it is occluded (no point, a back face, a BSDF that is
/// zero towards it). Counts the shadow ray it returns (which its caller traces) and a cone
/// sample's closest-hit query (which it makes).
#[inline(always)]
pub fn connect_emitters_at(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    (u_select, u): (f32, Vec2),
    counters: &mut Counters,
) -> Option<Connection> {
    let es = if ctx.emitters.is_plain() {
        ctx.emitters.sample_from(ctx.scene, sp.p, u_select, u)
    } else {
        match ctx.emitters.choose_from(ctx.scene, sp.p, u_select, u) {
            NeeChoice::Choice(Choice::Area(es)) => es,
            NeeChoice::Choice(Choice::Light { index, pmf, u }) => {
                let light = &ctx.emitters.lights()[index];
                return connect_light(ctx, sp, bsdf, wo, light, pmf, u, counters);
            }
            NeeChoice::Cone(cone) => return connect_cone(ctx, sp, bsdf, wo, cone, counters),
        }
    };
    let c = connect_point(sp, bsdf, wo, &es);
    counters.shadow_rays += u64::from(c.is_some());
    c
}

/// [`connect_emitters_at`]'s connection of `sp` to the point `es` picked on a triangle by
/// area (its shadow ray not counted): `None` where it contributes nothing whether or not it
/// is occluded (a point on the receiver, the emitter's back face, a BSDF that is zero
/// towards it). `pt`'s Lambertian lanes ([`super::diffuse_lanes`]) compute it sixteen at a
/// time and are tested against it.
#[inline(always)]
pub fn connect_point(sp: &SurfacePoint, bsdf: &Bsdf, wo: Vec3, es: &EmitterSample) -> Option<Connection> {
    let d = es.point.p - sp.p;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 || !dist2.is_finite() {
        return None;
    }
    let wi = d / dist2.sqrt();
    let cos_light = es.point.ng.dot(-wi);
    if cos_light <= 0.0 {
        return None;
    }
    let g = LocalGeometry { ng: sp.ng, frame: sp.frame };
    let (f, pdf_bsdf) = PreparedBsdf::new(*bsdf, g, wo, TransportMode::Radiance).eval_pdf(wi);
    if f == Vec3::ZERO {
        return None;
    }
    let pdf_light = es.pdf_area * dist2 / cos_light;
    Some(Connection {
        shadow: Some(shadow_ray(sp.p, sp.ng, es.point.p, es.point.ng)),
        sample: LightSample {
            pdf_light,
            pdf_bsdf,
            cos_light,
            dist2,
            wi,
            emission: (es.pdf_area != es.pdf_start).then(|| cone_emission(es.pdf_start, pdf_light)),
        },
        scale: f * es.radiance,
        over: pdf_light,
    })
}

/// [`connect_emitters_at`] for a direction in the cone of an emitting sphere: the ray along
/// it counts where its first hit is one of the sphere's triangles, seen from the front, and is
/// wasted (`None`) where it misses them or hits anything else first (another emitter's light
/// is its own technique's). Its density is the cone's for every direction that reaches the
/// triangles, as [`Emitters::nee_pdf`](crate::light::Emitters::nee_pdf) gives it to the
/// emission that BSDF sampling finds there. The closest-hit query settles its visibility here.
#[inline(never)]
fn connect_cone(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    cone: ConeSample,
    counters: &mut Counters,
) -> Option<Connection> {
    let wi = cone.wi;
    let g = LocalGeometry { ng: sp.ng, frame: sp.frame };
    let (f, pdf_bsdf) = PreparedBsdf::new(*bsdf, g, wo, TransportMode::Radiance).eval_pdf(wi);
    if f == Vec3::ZERO {
        return None;
    }
    counters.shadow_rays += 1;
    let ray = Ray::new(offset_origin(sp.p, sp.ng, wi), wi);
    let hit = ctx.accel.intersect(&ray)?;
    if !ctx.emitters.in_group(cone.group, hit.prim) {
        return None;
    }
    let e = ctx.scene.surface_of_hit(&hit, ray.dir);
    let le = e.emitted(ctx.scene.material(e.material).emission_at(e.uv), -wi);
    let cos_light = e.ng.dot(-wi);
    let dist2 = (e.p - sp.p).length_squared();
    if le == Vec3::ZERO || cos_light <= 0.0 || dist2.is_nan() || dist2 <= 0.0 {
        return None;
    }
    let pdf_light = cone.pdf;
    let emission = Some(cone_emission(ctx.emitters.pdf_area(hit.prim), pdf_light));
    Some(Connection {
        shadow: None,
        sample: LightSample { pdf_light, pdf_bsdf, cos_light, dist2, wi, emission },
        scale: f * le,
        over: pdf_light,
    })
}

/// [`LightSample::emission`] of a point of area density `pdf_area` (where light paths start)
/// that next-event estimation draws with another solid-angle density `pdf_light` (by a cone,
/// or by its triangle's importance at the receiver): the density
/// of a light path leaving it towards the receiver, per unit area there without its cosine,
/// p_A cos θ_e / (π d²), relative to next-event estimation's density of the point,
/// pdf_light cos θ_e / d² (for a point sampled by area, the same p_A, this is cos θ_e / π d²).
#[inline]
fn cone_emission(pdf_area: f32, pdf_light: f32) -> f32 {
    pdf_area * FRAC_1_PI / pdf_light
}

/// [`connect_emitters_at`] for a light other than a triangle, chosen with probability `pmf`.
/// A delta light's sample has an infinite density (`pdf_light`: the power heuristic gives it
/// full weight, as no BSDF sample finds it); an infinite light's its solid-angle density,
/// with `cos_light` 1 and `dist2` infinite.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn connect_light(
    ctx: &RenderContext,
    sp: &SurfacePoint,
    bsdf: &Bsdf,
    wo: Vec3,
    light: &Light,
    pmf: f32,
    u: Vec2,
    counters: &mut Counters,
) -> Option<Connection> {
    let ls = light.sample(sp.p, u)?;
    let g = LocalGeometry { ng: sp.ng, frame: sp.frame };
    let (f, pdf_bsdf) = PreparedBsdf::new(*bsdf, g, wo, TransportMode::Radiance).eval_pdf(ls.wi);
    if f == Vec3::ZERO {
        return None;
    }
    counters.shadow_rays += 1;
    let dist2 = ls.position.map_or(f32::INFINITY, |q| (q - sp.p).length_squared());
    let pdf_light = ls.pdf * pmf;
    let emission = Some(light.emission_density(dist2, ctx.scene.bounding_sphere().1));
    Some(Connection {
        shadow: Some(light_shadow_ray(sp.p, sp.ng, &ls)),
        sample: LightSample { pdf_light, pdf_bsdf, cos_light: 1.0, dist2, wi: ls.wi, emission },
        scale: f * ls.weight,
        over: pmf,
    })
}

/// Whether something hides the light sample `ls` (of a light that is not a triangle) from
/// the point `p` of geometric normal `ng` ([`light_shadow_ray`]). Counts the ray.
pub fn light_occluded(
    ctx: &RenderContext,
    p: Vec3,
    ng: Vec3,
    ls: &crate::light::LightSample,
    counters: &mut Counters,
) -> bool {
    counters.shadow_rays += 1;
    ctx.accel.occluded(&light_shadow_ray(p, ng, ls))
}

/// The shadow ray of the light sample `ls` (of a light that is not a triangle) from the point
/// `p` of geometric normal `ng`: up to the light's position (which no surface around it
/// occludes), or out of the scene for a light at infinity.
#[inline]
pub fn light_shadow_ray(p: Vec3, ng: Vec3, ls: &crate::light::LightSample) -> Ray {
    let origin = offset_origin(p, ng, ls.wi);
    match ls.position {
        Some(q) => Ray { origin, dir: q - origin, tmin: 0.0, tmax: 1.0 },
        None => Ray::new(origin, ls.wi),
    }
}

/// Radiance of the environments arriving along the unit direction `dir` of a ray that left
/// the scene, weighted by MIS against light sampling (power heuristic, each environment by its
/// own density) unless the ray came from the camera or a delta lobe.
#[inline(never)]
pub fn environment(ctx: &RenderContext, dir: Vec3, how: &Sampled) -> Vec3 {
    let mut l = Vec3::ZERO;
    for &k in ctx.emitters.environments() {
        let light = &ctx.emitters.lights()[k];
        let le = light.environment(dir);
        if how.delta {
            l += le;
        } else if le != Vec3::ZERO {
            let pdf_light = ctx.emitters.light_pmf(k) * light.environment_pdf(dir);
            l += le * power_heuristic(how.pdf, pdf_light);
        }
    }
    l
}

/// How the ray that reached a surface was sampled: what the MIS weight of the emission it
/// finds depends on.
#[derive(Clone, Copy, Debug)]
pub struct Sampled {
    /// The point the ray left.
    pub from: Vec3,
    /// Solid-angle density of its direction (for BSDF samples).
    pub pdf: f32,
    /// From the camera or a delta lobe: light sampling cannot find this path, full weight.
    pub delta: bool,
}

impl Sampled {
    pub fn camera(origin: Vec3) -> Self {
        Sampled { from: origin, pdf: 0.0, delta: true }
    }
}

/// Emission of `material` at `sp` towards `wo` (pointing back along the ray), weighted by MIS
/// against light sampling unless the ray came from the camera or a delta lobe.
#[inline]
pub fn emission(
    ctx: &RenderContext,
    material: &Material,
    sp: &SurfacePoint,
    wo: Vec3,
    how: &Sampled,
) -> Vec3 {
    if !material.is_emitter() {
        return Vec3::ZERO;
    }
    emission_weighted(ctx, material, sp, wo, how, |s| power_heuristic(s.pdf_bsdf, s.pdf_light))
}

/// [`emission`] with the MIS weight of a BSDF-sampled ray given by `weight` (from the
/// emitter point as light sampling from `how.from` would see it) instead of the power
/// heuristic against light sampling.
#[inline]
pub fn emission_weighted(
    ctx: &RenderContext,
    material: &Material,
    sp: &SurfacePoint,
    wo: Vec3,
    how: &Sampled,
    weight: impl FnOnce(LightSample) -> f32,
) -> Vec3 {
    let le = sp.emitted(material.emission_at(sp.uv), wo);
    if le == Vec3::ZERO || how.delta {
        return le;
    }
    let cos_light = sp.ng.dot(wo).abs();
    if cos_light <= 0.0 {
        return Vec3::ZERO;
    }
    let dist2 = (sp.p - how.from).length_squared();
    let (pdf_light, emission) = match ctx.emitters.nee_pdf(sp.prim, how.from, dist2, cos_light) {
        None => (ctx.emitters.pdf_area(sp.prim) * dist2 / cos_light, None),
        Some(pdf) => (pdf, Some(cone_emission(ctx.emitters.pdf_area(sp.prim), pdf))),
    };
    le * weight(LightSample { pdf_light, pdf_bsdf: how.pdf, cos_light, dist2, wi: -wo, emission })
}
