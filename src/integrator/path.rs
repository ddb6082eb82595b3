//! `--method pt`: a unidirectional path tracer, pir's ground truth.
//!
//! The walker of [`super::walker`] with no hook: next-event estimation on the area emitters
//! (triangle by power, uniform point) combined with BSDF sampling by multiple importance
//! sampling (power heuristic), delta bounces carrying emission at full weight, unbiased
//! Russian roulette. No parameters besides `max_depth` (`--max-depth`).

use glam::Vec3;

use super::walker::{FullPaths, walk};
use super::{Counters, Integrator, RenderContext};
use crate::geometry::Ray;
use crate::sampling::Sampler;

#[derive(Clone, Copy, Debug, Default)]
pub struct PathTracer;

impl Integrator for PathTracer {
    fn radiance(
        &self,
        ctx: &RenderContext,
        ray: Ray,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        walk(ctx, ray, &FullPaths, sampler, counters)
    }
}
