//! `--method pt`: a unidirectional path tracer, pir's ground truth.
//!
//! The walker of [`super::walker`] with next-event estimation on the area emitters (triangle
//! by power, or by importance at the vertex where they are a few: [`crate::light::spatial`];
//! uniform point) combined with BSDF sampling by multiple importance sampling (power
//! heuristic), delta bounces carrying emission at full weight, unbiased Russian roulette. No
//! parameters besides `max_depth` (`--max-depth`).

use glam::Vec3;

use super::deferred::Terms;
use super::direct::{connect_emitters_at, emitter_numbers, power_heuristic};
use super::walker::{Estimator, Vertex, walk};
use super::wavefront::walk_batch;
use super::{Counters, Integrator, RenderContext};
use crate::geometry::Ray;
use crate::sampling::Sampler;

#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracer;

/// The path tracer's two techniques for direct light at every vertex; what a many-light
/// method adds to them is its own.
impl Estimator for PathTracer {
    const COVERS_SURFACES: bool = false;
    const PT_VERTICES: bool = true;
    type State = ();

    #[inline(always)]
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
    }
}

/// One light sample at the non-delta vertex `v`, weighed against BSDF sampling by the power
/// heuristic, given to `terms`.
#[inline(always)]
pub fn light_sample(
    ctx: &RenderContext,
    v: &Vertex,
    beta: Vec3,
    radiance: &mut Vec3,
    sampler: &mut Sampler,
    counters: &mut Counters,
    terms: &mut impl Terms,
) {
    let c = connect_emitters_at(ctx, v.sp, v.bsdf, v.wo, emitter_numbers(sampler), counters);
    terms.sample(ctx, beta, c, |s| power_heuristic(s.pdf_light, s.pdf_bsdf), radiance);
}

impl Integrator for PathTracer {
    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        walk(ctx, ray, self, sampler, counters)
    }

    /// The paths of the batch together ([`super::wavefront`]), each the same as
    /// [`PathTracer::radiance`]'s.
    fn radiance_batch(
        &self,
        ctx: &RenderContext,
        rays: &[Ray],
        samplers: &mut [Sampler],
        counters: &mut Counters,
        out: &mut [Vec3],
    ) {
        walk_batch(ctx, self, rays, samplers, counters, out);
    }
}
