//! The gather: the light a receiver x gets from every virtual light of the iteration,
//!
//! L(x) = Σ_j Φ_j f_j(ω_j, y_j→x) cos θ_j · f_x(x→y_j, ω_o) cos θ_x / ‖y_j − x‖² · V(x, y_j)
//!
//! for point lights (G clamped at the iteration's bound), or each term integrated over the
//! cone of a sphere ([`super::spheres`]). Both BSDFs are evaluated in full (a glossy VPL emits
//! its lobe), Φ_j is already divided by the number of light paths. The connections, each a
//! shadow ray with the contribution it carries, go in VPL order to whoever traces them
//! ([`Connections`]): the gather's own batches ([`super::shadow_batch::ShadowBatch`]), or
//! the batched walker's bounce, with the shadow rays of every path's vertex
//! ([`crate::integrator::deferred::Deferred`]), the same sum either way.
//!
//! With a light tree ([`super::Gather::Tree`]) the sum is estimated instead from k lights
//! drawn per receiver ([`super::tree_gather`]): each drawn light's contribution (the same
//! function as above) divided by k and by its probability, one shadow ray each. With the
//! resampled gather ([`super::Gather::Resampled`]) it is estimated from k lights picked among a
//! window of about m candidates by a cheap estimate of their unoccluded light
//! ([`super::resample`]).

use glam::Vec3;

use super::config::Draws;
use super::light_set::{LightSet, Selection};
use super::light_tree::LightTree;
use super::lobe::Lobe;
use super::resample::{LANES, resample};
use super::tree_gather::{Kernel, Pick, Receiver};
use super::virtual_light::{Lights, Weigh};
use super::window::LightPaths;
use crate::geometry::OffsetPoint;
use crate::integrator::deferred::{Connections, Immediate, Terms};
use crate::integrator::direct::shadow_segment;
use crate::integrator::walker::Vertex;
use crate::integrator::{Counters, RenderContext};
use crate::sampling::Sampler;

impl<L: Lights> LightSet<L> {
    /// Indirect light at the camera vertex `v` from every virtual light of at most
    /// `max_vpl_depth` segments, visibility included, each connection as `weighing` weighs it:
    /// [`LightSet::gather_with`] with its shadow rays traced here.
    pub fn gather<W: Weigh<L>>(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        max_vpl_depth: u32,
        weighing: &W,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        self.gather_with(&mut Immediate::default(), ctx, v, max_vpl_depth, weighing, None, sampler, counters)
    }

    /// [`LightSet::gather`] through `terms` ([`Terms::gather`]): its connections traced at
    /// once, or kept with the batched walker's bounce; what to give
    /// [`Terms::add_gathered`]. A sampled gather draws as `draws` says where given (any
    /// counts estimate the same sum).
    #[allow(clippy::too_many_arguments)]
    pub fn gather_with<T: Terms, W: Weigh<L>>(
        &self,
        terms: &mut T,
        ctx: &RenderContext,
        v: &Vertex,
        max_vpl_depth: u32,
        weighing: &W,
        draws: Option<Draws>,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> T::Gathered {
        let most = self.most_connections();
        terms.gather(ctx.accel, counters, most, |q| {
            self.connect(v, max_vpl_depth, weighing, draws, sampler, q)
        })
    }

    /// The most connections a receiver's gather makes ([`LightSet::connect`]): every light,
    /// or the sampled gathers' samples.
    fn most_connections(&self) -> usize {
        match self.selection {
            Selection::All => self.lights.chunks() * LANES,
            Selection::Tree { samples, .. } | Selection::Resampled { samples, .. } => samples,
        }
    }

    /// The connections of the gather at the camera vertex `v` ([`LightSet::gather`]), each
    /// a shadow ray with its weighted contribution, given to `queue` in light order (drawn
    /// order for the sampled gathers, which draw as `draws` says where given); `false` (and
    /// none given) where the receiver reflects nothing towards `v.wo` (the tree's gather says
    /// `true` there and gives none).
    #[allow(clippy::too_many_arguments)]
    fn connect<W: Weigh<L>>(
        &self,
        v: &Vertex,
        max_vpl_depth: u32,
        weighing: &W,
        draws: Option<Draws>,
        sampler: &mut Sampler,
        queue: &mut dyn Connections,
    ) -> bool {
        let lights = &self.lights;
        // The counts here: the selection's own, or as `draws` says (at least one each).
        let (k_here, m_here) = draws.map_or((usize::MAX, usize::MAX), |d| (d.samples, d.candidates));
        let count = |own: usize, here: usize| here.clamp(1, own);
        match self.selection {
            Selection::All => all(lights, v, max_vpl_depth, weighing, sampler, queue),
            Selection::Tree { ref tree, samples } => {
                let k = count(samples, k_here);
                drawn(lights, tree, k, v, max_vpl_depth, weighing, sampler, queue)
            }
            Selection::Resampled { candidates, samples, ref paths } => {
                let (m, k) = (count(candidates, m_here), count(samples, k_here));
                resampled(lights, paths, m, k, v, max_vpl_depth, weighing, sampler, queue)
            }
        }
    }
}

/// Queues every light's weighted contribution with its shadow ray, in light order; `false`
/// when the receiver reflects nothing towards `v.wo`.
fn all<L: Lights, W: Weigh<L>>(
    lights: &L,
    v: &Vertex,
    max_vpl_depth: u32,
    weighing: &W,
    sampler: &mut Sampler,
    queue: &mut dyn Connections,
) -> bool {
    let rx = lights.receiver(v, max_vpl_depth, None);
    if !L::is_active(&rx) {
        return false;
    }
    let x = OffsetPoint::new(v.sp.p, v.sp.ng);
    for chunk in 0..lights.chunks() {
        let cs = lights.chunk_contributions(chunk, &rx, sampler);
        for (i, c) in cs.into_iter().enumerate() {
            if c != Vec3::ZERO {
                let j = chunk * LANES + i;
                queue.push(shadow_segment(&x, lights.end(j)), weighing.weigh(lights, j, v.sp.p, c));
            }
        }
    }
    true
}

/// Queues the weighted contributions of k lights drawn from the light tree, each divided by k
/// and its probability ([`super::tree_gather`]). Draws k numbers, always.
#[allow(clippy::too_many_arguments)]
fn drawn<L: Lights, W: Weigh<L>>(
    lights: &L,
    tree: &LightTree,
    k: usize,
    v: &Vertex,
    max_vpl_depth: u32,
    weighing: &W,
    sampler: &mut Sampler,
    queue: &mut dyn Connections,
) -> bool {
    let lobe = weighing.lobe(v);
    let rx = lights.receiver(v, max_vpl_depth, lobe);
    let picks = sample_lights(tree, k, lights.kernel(), v, lobe, L::is_active(&rx), max_vpl_depth, sampler);
    let x = OffsetPoint::new(v.sp.p, v.sp.ng);
    for pick in &picks {
        let j = pick.light;
        let c = lights.contribution(j, &rx, sampler);
        if c != Vec3::ZERO {
            let c = weighing.weigh(lights, j, v.sp.p, c);
            queue.push(shadow_segment(&x, lights.end(j)), weighted(c, pick, k));
        }
    }
    true
}

/// Queues the weighted contributions of k lights picked from a window of about m candidates
/// among the lights of `paths` by their estimated unoccluded light ([`super::resample`]);
/// `false` when the receiver reflects nothing towards `v.wo`. Draws two numbers before the
/// candidates' own, always.
#[allow(clippy::too_many_arguments)]
fn resampled<L: Lights, W: Weigh<L>>(
    lights: &L,
    paths: &LightPaths,
    m: usize,
    k: usize,
    v: &Vertex,
    max_vpl_depth: u32,
    weighing: &W,
    sampler: &mut Sampler,
    queue: &mut dyn Connections,
) -> bool {
    let rx = lights.receiver(v, max_vpl_depth, weighing.lobe(v));
    let weights = weighing.draw_weights();
    let active = L::is_active(&rx);
    let x = OffsetPoint::new(v.sp.p, v.sp.ng);
    resample(
        paths,
        m,
        k,
        active,
        sampler,
        |cands, window, sampler| lights.push_estimates(cands, window, &rx, weights, sampler),
        |j, factor, sampler| {
            if let Some(c) = weighing.picked(lights, j, &rx, v.sp.p, sampler) {
                queue.push(shadow_segment(&x, lights.end(j)), c * factor);
            }
        },
    );
    active
}

/// Draws the k lights of the sampled gather at `v` (k numbers from `sampler`, always); none
/// unless the receiver is `active` (reflects anything towards `v.wo`).
#[allow(clippy::too_many_arguments)]
fn sample_lights(
    tree: &LightTree,
    k: usize,
    kernel: Kernel,
    v: &Vertex,
    lobe: Option<Lobe>,
    active: bool,
    max_vpl_depth: u32,
    sampler: &mut Sampler,
) -> Vec<Pick> {
    let sp = &v.sp;
    let mut picks = Vec::with_capacity(k);
    if !active {
        // The same k numbers are drawn whether or not the receiver reflects anything.
        for _ in 0..k {
            sampler.next_u64();
        }
        return picks;
    }
    let rx = Receiver { p: sp.p, ng: sp.ng, ns: sp.frame.n, max_depth: max_vpl_depth, kernel, lobe };
    tree.sample_stratified(&rx, k, sampler, |p| picks.push(p));
    picks
}

/// A sampled light's contribution divided by k and its probability.
#[inline]
fn weighted(c: Vec3, pick: &Pick, k: usize) -> Vec3 {
    (c.as_dvec3() / (k as f64 * pick.prob)).as_vec3()
}
