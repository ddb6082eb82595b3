//! `--method pt`: a unidirectional path tracer, pir's ground truth.
//!
//! The walker of [`super::walker`] with next-event estimation on the area emitters (triangle
//! by power, uniform point) combined with BSDF sampling by multiple importance sampling (power
//! heuristic), delta bounces carrying emission at full weight, unbiased Russian roulette. No
//! parameters besides `max_depth` (`--max-depth`).

use glam::Vec3;

use super::direct::{emission, sample_emitters};
use super::walker::{Arrival, Estimator, Vertex, walk};
use super::{Counters, Integrator, RenderContext};
use crate::geometry::Ray;
use crate::sampling::Sampler;

#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracer;

/// The path tracer's two techniques for direct light at every vertex; what a many-light
/// method adds to them is its own.
impl Estimator for PathTracer {
    const COVERS_SURFACES: bool = false;
    type State = ();

    #[inline]
    fn start(&self, _ray: &Ray) {}

    #[inline]
    fn on_hit(&self, _: &mut (), ctx: &RenderContext, at: &Arrival, beta: Vec3, radiance: &mut Vec3) {
        light_hit(ctx, at, beta, radiance);
    }

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
    ) {
        light_sample(ctx, v, beta, radiance, sampler, counters);
    }
}

/// The emission a camera path finds at `at`, weighed against light sampling by the power
/// heuristic (in full from the camera or a delta lobe).
#[inline(always)]
pub fn light_hit(ctx: &RenderContext, at: &Arrival, beta: Vec3, radiance: &mut Vec3) {
    *radiance += beta * emission(ctx, at.material, at.sp, at.wo, at.how);
}

/// One light sample at the non-delta vertex `v`, weighed against BSDF sampling by the power
/// heuristic.
#[inline(always)]
pub fn light_sample(
    ctx: &RenderContext,
    v: &Vertex,
    beta: Vec3,
    radiance: &mut Vec3,
    sampler: &mut Sampler,
    counters: &mut Counters,
) {
    *radiance += beta * sample_emitters(ctx, v.sp, v.bsdf, v.wo, sampler, counters);
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
}
