//! VPLs kept by their share of the image (Georgiev and Slusallek 2010, "Simple and robust
//! iterative importance sampling of virtual point lights"): where most of an iteration's VPLs
//! light what the camera does not see (a room lit through a door from the next one, light
//! outside a window), `pir-bdpt` traces more light paths and keeps each VPL by Russian
//! roulette with a probability that grows with its estimated contribution to the image, so
//! that the VPLs an iteration gathers from are mostly the ones that light the view.
//!
//! **Unbiased.** A VPL kept with probability q carries its flux divided by q, so its expected
//! flux is what it had; every connection's estimate keeps its expectation. The bidirectional
//! weights are left as they are (functions of the path that sum to one over the techniques,
//! whatever the densities the techniques are drawn with), so every path is still counted
//! once. Nothing else of the light paths changes: light tracing to the camera and the photons
//! of vertex merging use every path traced.
//!
//! **The estimate.** A VPL's contribution to the image is estimated from the points the view
//! pilot found ([`super::view_pilot::View::points`]: the first surfaces the camera sees, and
//! what the mirrors, glass and near-mirrors among those show):
//! [`POINTS_PER_VPL`] of them drawn uniformly, each the unoccluded connection's value times a
//! shadow ray's answer, scaled to all the points. The probability is that estimate relative
//! to the mean over a pilot's VPLs, clamped to [[`MIN_ACCEPTANCE`], 1]: a VPL at least as
//! useful as the average is always kept, one that no sampled point sees is kept once in 16.
//! The floor keeps the estimator robust where the sampled points miss a VPL's receivers (a
//! VPL that lights a few pixels only): its flux is at most 16 times what it was.
//!
//! **When.** Before the first iteration a pilot traces [`PILOT_PATHS`] light paths and finds
//! the mean probability q̄ its VPLs would be kept with. Where q̄ is at least
//! [`WORTH_IT`], most VPLs light the view already and nothing changes (the same images bit
//! for bit). Below, the light paths are multiplied by 1 / q̄ (at most [`MAX_MORE_PATHS`]), so
//! an iteration keeps about as many VPLs as before, and more of them where they count.
//! Where the light paths cannot grow by that factor (the scene's count is near the most an
//! iteration traces, 4,096), nothing changes either: keeping fewer VPLs without more paths
//! would only add noise. The plan is a function of the scene, its camera, the path length,
//! the seed, the sampler and the accelerator, fixed for the whole render, like the other
//! pilots.

use std::sync::Arc;

use super::config::Clamping;
use super::light_paths::{Vpl, trace_pilot_vpls};
use super::points::point_contribution;
use super::view_pilot::View;
use crate::integrator::direct::occluded;
use crate::integrator::{Counters, RenderContext};
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::{Domain, Sampler};

/// Camera points each VPL's contribution is estimated from.
pub const POINTS_PER_VPL: usize = 16;

/// The least probability a VPL is kept with.
pub const MIN_ACCEPTANCE: f32 = 1.0 / 16.0;

/// The mean probability of keeping a VPL at and above which all are kept: near 1/2 twice the
/// paths for about twice the VPLs that light the view did not pay (the Mori knob at 0.47,
/// 0.89–0.96× the efficiency; `docs/results.md`).
pub const WORTH_IT: f32 = 0.45;

/// The most the light paths are multiplied by.
pub const MAX_MORE_PATHS: f32 = 8.0;

/// Light paths of the pilot.
pub const PILOT_PATHS: usize = 1024;

/// The stream of the pilot's light paths and acceptance decisions: an iteration number no
/// render reaches (nor the other pilots).
const PILOT_ITERATION: u64 = u64::MAX - 3;

/// The mean probability of keeping a VPL below which the resampled gather picks
/// [`MORE_PICKS`] times as many of its candidates.
pub const FEW_KEPT: f32 = 1.0 / 8.0;

/// How many times the picks are raised where few VPLs are kept.
pub const MORE_PICKS: usize = 4;

/// The resampled gather's picks per receiver, `base` given, where the plan keeps a VPL with
/// mean probability `mean`.
///
/// **Why.** Where the light paths mostly light what the camera does not see (below
/// [`FEW_KEPT`]: a room lit through a door), the VPLs kept are those of the few paths that
/// reach the view, and an iteration's window of candidates now holds many of them. The
/// image is then mostly their light, and what is left of its error is the picks' among them:
/// more picks pay there, and cost a shadow ray each. Elsewhere the light arriving at a pixel
/// is more the camera path's own and the default picks are kept.
pub fn picks_for(base: usize, mean: f32) -> usize {
    if mean < FEW_KEPT { base * MORE_PICKS } else { base }
}

/// How an iteration's VPLs are kept.
#[derive(Clone, Debug)]
pub struct Acceptance {
    view: Arc<View>,
    /// The contribution per light path of a VPL kept with probability 1 (the pilot's mean).
    target: f64,
    /// The pilot's mean probability of keeping a VPL.
    pub mean: f32,
    /// The bound on G of the estimates ([`estimate`]), the scene's default clamp.
    bound: f32,
}

impl Acceptance {
    /// The plan for the scene seen from the points of `view`, from a pilot of its own, and
    /// the factor by which it multiplies the light paths; `None` where it would keep most
    /// VPLs anyway or the camera sees nothing that reflects. Once per render where the
    /// context keeps it ([`super::Pilots`]); its queries are added to `counters.pilot_rays`
    /// when it runs.
    pub fn plan(
        ctx: &RenderContext,
        view: Arc<View>,
        max_vpl_depth: u32,
        counters: &mut Counters,
    ) -> Option<(Acceptance, f32)> {
        match ctx.pilot {
            Some(pilots) => pilots
                .acceptance
                .get_or_init(|| Acceptance::trace(ctx, view, max_vpl_depth, counters))
                .clone(),
            None => Acceptance::trace(ctx, view, max_vpl_depth, counters),
        }
    }

    /// [`Acceptance::plan`] without the render's cache.
    fn trace(
        ctx: &RenderContext,
        view: Arc<View>,
        max_vpl_depth: u32,
        counters: &mut Counters,
    ) -> Option<(Acceptance, f32)> {
        if view.points.is_empty() {
            return None;
        }
        let (vpls, rays, _) = trace_pilot_vpls(ctx, PILOT_ITERATION, PILOT_PATHS, max_vpl_depth);
        let bound = Clamping::default_bound(ctx.scene.bounds().diagonal());
        counters.pilot_rays += rays;
        let mut queries = Counters::default();
        let estimates: Vec<f64> = vpls
            .iter()
            .enumerate()
            .map(|(j, v)| {
                let mut sampler = Sampler::new(ctx.seed, PILOT_ITERATION, Domain::Acceptance, j as u64);
                estimate(ctx, &view, v, bound, &mut sampler, &mut queries) * PILOT_PATHS as f64
            })
            .collect();
        counters.pilot_rays += queries.shadow_rays;
        let target = estimates.iter().sum::<f64>() / estimates.len().max(1) as f64;
        if !(target > 0.0 && target.is_finite()) {
            return None;
        }
        let mean =
            estimates.iter().map(|&e| probability(e, target) as f64).sum::<f64>() / estimates.len() as f64;
        let mean = mean as f32;
        if mean >= WORTH_IT {
            return None;
        }
        Some((Acceptance { view, target, mean, bound }, (1.0 / mean).min(MAX_MORE_PATHS)))
    }

    /// Keeps each of `vpls[from..]` (the VPLs of path `path` of `iteration`, one of `paths`)
    /// with its probability, its flux divided by it, in order and in place; the numbers are
    /// the path's own ([`Domain::Acceptance`]), whatever the thread. Counts its shadow rays in
    /// `counters`.
    #[allow(clippy::too_many_arguments)]
    pub fn keep(
        &self,
        ctx: &RenderContext,
        iteration: u64,
        path: usize,
        paths: usize,
        vpls: &mut Vec<Vpl>,
        from: usize,
        counters: &mut Counters,
    ) {
        if vpls.len() <= from {
            return;
        }
        let mut sampler = Sampler::new(ctx.seed, iteration, Domain::Acceptance, path as u64);
        let mut kept = from;
        for i in from..vpls.len() {
            let mut v = vpls[i];
            let q = probability(
                estimate(ctx, &self.view, &v, self.bound, &mut sampler, counters) * paths as f64,
                self.target,
            );
            if sampler.next_f32() < q {
                v.flux /= q;
                vpls[kept] = v;
                kept += 1;
            }
        }
        vpls.truncate(kept);
    }
}

/// The probability of keeping a VPL whose estimated contribution per light path is
/// `per_path`, where the pilot's mean is `target`.
fn probability(per_path: f64, target: f64) -> f32 {
    let q = (per_path / target) as f32;
    if q.is_nan() { 1.0 } else { q.clamp(MIN_ACCEPTANCE, 1.0) }
}

/// An estimate of the VPL's contribution to the points of `view` (their sum): the
/// contributions to [`POINTS_PER_VPL`] points drawn uniformly, each with its shadow ray, times
/// the points over the draws. G is bounded at `bound`, the default clamp's b (100 / diagonal², two
/// facing surfaces a tenth of the scene apart), so that a VPL beside a camera point (or in a
/// crease) neither decides the pilot's mean alone nor makes it infinite; this only shapes the
/// probabilities, not what a kept VPL adds. Draws [`POINTS_PER_VPL`] numbers from `sampler`.
fn estimate(
    ctx: &RenderContext,
    view: &View,
    vpl: &Vpl,
    bound: f32,
    sampler: &mut Sampler,
    counters: &mut Counters,
) -> f64 {
    let fp = PreparedBsdf::new(vpl.bsdf(ctx.scene), vpl.geometry(), vpl.w_in, TransportMode::Importance);
    let n = view.points.len();
    let mut sum = 0.0f64;
    for _ in 0..POINTS_PER_VPL {
        let j = ((sampler.next_f32() * n as f32) as usize).min(n - 1);
        if !fp.is_active() {
            continue;
        }
        let x = &view.points[j];
        let c = point_contribution(x.p, x.n, &x.fx, vpl, &fp, bound);
        let value = (c.x + c.y + c.z) as f64 / 3.0;
        if value > 0.0 && !occluded(ctx, x.p, x.ng, vpl.p, vpl.ng, counters) {
            sum += value;
        }
    }
    sum * n as f64 / POINTS_PER_VPL as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A VPL as useful as the pilot's mean or more is always kept, one no point sees once in
    /// 16, and a probability that is not a number keeps the VPL as it is.
    #[test]
    fn the_probability_follows_the_estimate_within_its_bounds() {
        assert_eq!(probability(4.0, 2.0), 1.0);
        assert_eq!(probability(2.0, 2.0), 1.0);
        assert_eq!(probability(0.5, 2.0), 0.25);
        assert_eq!(probability(0.0, 2.0), MIN_ACCEPTANCE);
        assert_eq!(probability(f64::INFINITY, 2.0), 1.0);
        assert_eq!(probability(f64::NAN, 2.0), 1.0);
    }

    #[test]
    fn more_picks_only_where_few_vpls_are_kept() {
        assert_eq!(picks_for(4, 0.11), 16);
        assert_eq!(picks_for(4, FEW_KEPT), 4);
        assert_eq!(picks_for(4, 0.46), 4);
    }
}
