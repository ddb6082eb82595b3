//! The camera path of the forward many-light methods (`ir`, `ir-clamp`, `pir-clamp`, `vsl`,
//! `pir-vsl`, `pir-mis`): the walker's [`Estimator`] that adds the gather from the
//! iteration's virtual lights at each non-delta vertex, and for `pir-mis` the bounce that its
//! connections are weighed against ([`super::mis`]).

use glam::Vec3;

use super::light_set::LightSet;
use super::mis::{EmitterPath, Technique, Weighing};
use super::points::PointLights;
use super::virtual_light::{Lights, Plain};
use crate::geometry::{Ray, offset_origin};
use crate::integrator::deferred::Terms;
use crate::integrator::direct::{LightSample, Sampled, emission_weighted, sample_emitters_weighted};
use crate::integrator::path::light_sample;
use crate::integrator::scatter::scatter;
use crate::integrator::walker::{Estimator, Vertex};
use crate::integrator::{Counters, RenderContext};
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::Sampler;

/// The thesis' methods (`ir`, `ir-clamp`, `pir-clamp`, `vsl`, `pir-vsl`) on lights of any
/// kind: the path tracer's techniques for direct light, and at a non-delta vertex of d
/// segments the light of every virtual light of at most max_depth − d − 1 segments, which
/// covers every path whose next vertex is a non-delta surface.
pub struct Gathering<'a, L> {
    pub set: &'a LightSet<L>,
}

impl<L: Lights> Estimator for Gathering<'_, L> {
    const COVERS_SURFACES: bool = true;
    type State = ();

    #[inline]
    fn at_vertex(
        &self,
        _: &mut (),
        ctx: &RenderContext,
        v: &Vertex,
        beta: Vec3,
        radiance: &mut Vec3,
        sampler: &mut Sampler,
        counters: &mut Counters,
        terms: &mut impl Terms,
    ) {
        light_sample(ctx, v, beta, radiance, sampler, counters, terms);
        let max_vpl_depth = ctx.max_depth - v.depth - 1;
        let gathered = self.set.gather_with(terms, ctx, v, max_vpl_depth, &Plain, None, sampler, counters);
        terms.add_gathered(beta, gathered, radiance);
    }
}

/// `pir-mis` on point lights: [`Gathering`] whose connections are weighed against a
/// BSDF-sampled bounce ([`super::mis`]), the weighted connection bounded by `bound`; the
/// bounce's share is added where the covered walk ends.
pub struct WeighedGathering<'a> {
    pub set: &'a LightSet<PointLights>,
    /// The iteration's light paths: every connection counts them all.
    pub paths: f32,
    pub bound: f32,
}

impl WeighedGathering<'_> {
    /// The gather at the vertex `v` through `terms` ([`LightSet::gather_with`]), its
    /// connections weighed against the bounce.
    #[inline(always)]
    fn gather_with<T: Terms>(
        &self,
        terms: &mut T,
        ctx: &RenderContext,
        v: &Vertex,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> T::Gathered {
        let max_vpl_depth = ctx.max_depth - v.depth - 1;
        let fx = PreparedBsdf::new(*v.bsdf, v.sp.geometry(), v.wo, TransportMode::Radiance);
        let weighing = Weighing { technique: Technique::Connect { fx: &fx }, bound: self.bound };
        self.set.gather_with(terms, ctx, v, max_vpl_depth, &weighing, None, sampler, counters)
    }
}

impl Estimator for WeighedGathering<'_> {
    const COVERS_SURFACES: bool = true;
    type State = ();

    #[inline]
    fn at_vertex(
        &self,
        _: &mut (),
        ctx: &RenderContext,
        v: &Vertex,
        beta: Vec3,
        radiance: &mut Vec3,
        sampler: &mut Sampler,
        counters: &mut Counters,
        terms: &mut impl Terms,
    ) {
        light_sample(ctx, v, beta, radiance, sampler, counters, terms);
        let gathered = self.gather_with(terms, ctx, v, sampler, counters);
        terms.add_gathered(beta, gathered, radiance);
    }

    #[inline]
    fn uses_bounces(&self) -> bool {
        true
    }

    /// The bounce's share ([`super::mis`]): the emitters sampled from y and the gather at y, each
    /// weighed against the connection of the gathering vertex to the VPLs at y.
    fn at_bounce(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        how: &Sampled,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Option<Vec3> {
        let bounce = how.pdf / (v.sp.p - how.from).length_squared();
        let path = |light| EmitterPath { bounce, paths: self.paths, light };
        let direct =
            sample_emitters_weighted(ctx, v.sp, v.bsdf, v.wo, sampler, counters, |s| path(s).light_weight());
        let weighing = Weighing { technique: Technique::Bounce { bounce }, bound: self.bound };
        let max_vpl_depth = ctx.max_depth - v.depth - 1;
        let gathered = self.set.gather(ctx, v, max_vpl_depth, &weighing, sampler, counters);
        // C: y's BSDF sample, where it hits an emitter.
        let mut beta = Vec3::ONE;
        let Some(s) = scatter(v.bsdf, v.sp, v.wo, TransportMode::Radiance, sampler, &mut beta) else {
            return Some(direct + gathered);
        };
        // A delta lobe of a plastic or a mask: the walk itself goes on through it.
        if s.delta {
            return Some(direct + gathered);
        }
        counters.rays += 1;
        let ray = Ray::new(offset_origin(v.sp.p, v.sp.ng, s.wi), s.wi);
        let mut found = Vec3::ZERO;
        let hit = ctx.accel.intersect(&ray);
        if let Some(hit) = hit
            && let material = ctx.scene.material_of(hit.prim)
            && material.is_emitter()
        {
            let e = ctx.scene.surface_of_hit(&hit, ray.dir);
            let how = Sampled { from: v.sp.p, pdf: s.pdf, delta: s.delta };
            found = beta * emission_weighted(ctx, material, &e, -s.wi, &how, |l| path(l).bsdf_weight());
        }
        if hit.is_none() && !ctx.emitters.environments().is_empty() {
            found = beta * escaped(ctx, s.wi, &Sampled { from: v.sp.p, pdf: s.pdf, delta: s.delta }, path);
        }
        Some(direct + gathered + found)
    }
}

/// C where y's BSDF-sampled ray (unit direction `dir`, sampled as `how`) leaves the scene: the
/// environments' radiance, each weighed by `path`'s C weight with its own next-event density.
fn escaped(ctx: &RenderContext, dir: Vec3, how: &Sampled, path: impl Fn(LightSample) -> EmitterPath) -> Vec3 {
    let radius = ctx.scene.bounding_sphere().1;
    let mut l = Vec3::ZERO;
    for &k in ctx.emitters.environments() {
        let light = &ctx.emitters.lights()[k];
        let le = light.environment(dir);
        if le == Vec3::ZERO {
            continue;
        }
        if how.delta {
            l += le;
            continue;
        }
        let sample = LightSample {
            pdf_light: ctx.emitters.light_pmf(k) * light.environment_pdf(dir),
            pdf_bsdf: how.pdf,
            cos_light: 1.0,
            dist2: f32::INFINITY,
            wi: dir,
            emission: Some(light.emission_density(f32::INFINITY, radius)),
        };
        l += le * path(sample).bsdf_weight();
    }
    l
}
