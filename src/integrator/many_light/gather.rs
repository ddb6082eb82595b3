//! The gather: the light a receiver x gets from every virtual light of the iteration,
//!
//! L(x) = Σ_j Φ_j f_j(ω_j, y_j→x) cos θ_j · f_x(x→y_j, ω_o) cos θ_x / ‖y_j − x‖² · V(x, y_j)
//!
//! for point lights (G clamped at the iteration's bound), or each term integrated over the
//! cone of a sphere ([`super::spheres`]). Both BSDFs are evaluated in full (a glossy VPL emits
//! its lobe), Φ_j is already divided by the number of light paths, and the shadow rays go to
//! the accelerator in batches ([`ShadowBatch`]), in VPL order.
//!
//! With a light tree ([`super::Gather::Tree`]) the sum is estimated instead from k lights
//! drawn per receiver ([`super::tree_gather`]): each drawn light's contribution (the same
//! function as above) divided by k and by its probability, one shadow ray each. With the
//! resampled gather ([`super::Gather::Resampled`]) it is estimated from k lights picked among a
//! window of m candidates by a cheap estimate of their unoccluded light ([`super::resample`]).

use glam::{Vec3, Vec4};

use super::lanes::{DiffuseReceiver, EstimateReceiver, LANES, LaneKind};
use super::light_paths::Vpl;
use super::light_set::{LightSet, Lights, PointLights, Selection};
use super::light_tree::LightTree;
use super::lobe::Lobe;
use super::mis::{Technique, Weighing};
use super::resample::resample;
use super::shadow_batch::{ShadowBatch, with_shadow_batch};
use super::spheres::{SphereLights, SphereReceiver};
use super::tree_gather::{Kernel, Pick, Receiver};
use crate::geometry::OffsetPoint;
use crate::integrator::direct::shadow_segment;
use crate::integrator::walker::Vertex;
use crate::integrator::{Counters, RenderContext};
use crate::material::{PreparedBsdf, TransportMode};
use crate::sampling::Sampler;

impl LightSet {
    /// Indirect light at the camera vertex `v` from every virtual light of at most
    /// `max_vpl_depth` segments, visibility included, each connection as `weighing` weighs it
    /// ([`super::mis`]; point lights only, spheres ignore it).
    pub fn gather(
        &self,
        ctx: &RenderContext,
        v: &Vertex,
        max_vpl_depth: u32,
        weighing: &Weighing,
        sampler: &mut Sampler,
        counters: &mut Counters,
    ) -> Vec3 {
        with_shadow_batch(ctx.accel, |batch| {
            let queued = match (&self.lights, &self.selection) {
                (Lights::Points(p), Selection::All) => p.queue(v, max_vpl_depth, weighing, batch),
                (Lights::Spheres(s), Selection::All) => s.queue(v, max_vpl_depth, sampler, batch),
                (lights, &Selection::Resampled { candidates, samples }) => {
                    let (m, k) = (candidates, samples);
                    match lights {
                        Lights::Points(p) => {
                            p.queue_resampled(v, max_vpl_depth, m, k, weighing, sampler, batch)
                        }
                        Lights::Spheres(s) => s.queue_resampled(v, max_vpl_depth, m, k, sampler, batch),
                    }
                }
                (lights, Selection::Tree { tree, samples: k }) => {
                    let fx = PreparedBsdf::new(*v.bsdf, v.sp.geometry(), v.wo, TransportMode::Radiance);
                    let lobe = receiver_lobe(v, weighing);
                    let picks =
                        sample_lights(tree, *k, lights, v, lobe, fx.is_active(), max_vpl_depth, sampler);
                    match lights {
                        Lights::Points(p) => p.queue_sampled(v, &fx, &picks, *k, weighing, batch),
                        Lights::Spheres(s) => s.queue_sampled(v, &picks, *k, sampler, batch),
                    }
                }
            };
            if !queued {
                return Vec3::ZERO;
            }
            let (total, traced) = batch.finish();
            counters.shadow_rays += traced;
            total
        })
    }
}

/// The receiver's lobe at `v` for the sampled gathers' draws ([`Lobe`]), for the thesis' plain
/// sum only: a weighed connection in a glossy lobe is mostly left to BSDF sampling, so its
/// weighted value does not follow the lobe, and `pir-mis` and `pir-bdpt` draw as before.
fn receiver_lobe(v: &Vertex, weighing: &Weighing) -> Option<Lobe> {
    match weighing.technique {
        Technique::Plain => Lobe::of(v.bsdf, v.sp.frame.n, v.wo),
        _ => None,
    }
}

/// Draws the k lights of the sampled gather at `v` (k numbers from `sampler`, always); none
/// unless the receiver is `active` (reflects anything towards `v.wo`).
#[allow(clippy::too_many_arguments)]
fn sample_lights(
    tree: &LightTree,
    k: usize,
    lights: &Lights,
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
    let kernel = match lights {
        Lights::Points(p) => Kernel::Point { bound: p.bound },
        Lights::Spheres(_) => Kernel::Sphere,
    };
    let rx = Receiver { p: sp.p, ng: sp.ng, ns: sp.frame.n, max_depth: max_vpl_depth, kernel, lobe };
    tree.sample_stratified(&rx, k, sampler, |p| picks.push(p));
    picks
}

/// A sampled light's contribution divided by k and its probability.
#[inline]
fn weighted(c: Vec3, pick: &Pick, k: usize) -> Vec3 {
    (c.as_dvec3() / (k as f64 * pick.prob)).as_vec3()
}

impl PointLights {
    /// Queues the sampled lights' weighted contributions with their shadow rays.
    fn queue_sampled(
        &self,
        v: &Vertex,
        fx: &PreparedBsdf,
        picks: &[Pick],
        k: usize,
        weighing: &Weighing,
        batch: &mut ShadowBatch,
    ) -> bool {
        let sp = &v.sp;
        let x = OffsetPoint::new(sp.p, sp.ng);
        for pick in picks {
            let j = pick.light;
            let (vpl, emitting) = (&self.vpls[j], &self.emitting[j]);
            let c = point_contribution(sp.p, sp.frame.n, fx, vpl, emitting, self.bound);
            if c != Vec3::ZERO {
                let c = weighing.apply(sp.p, vpl, emitting, c);
                batch.push(shadow_segment(&x, self.lanes.end(j)), weighted(c, pick, k));
            }
        }
        true
    }

    /// Queues the k lights picked from a window of about m candidates ([`super::resample`]);
    /// `false` when the receiver reflects nothing towards `v.wo`. Draws two numbers, always.
    #[allow(clippy::too_many_arguments)]
    fn queue_resampled(
        &self,
        v: &Vertex,
        max_vpl_depth: u32,
        m: usize,
        k: usize,
        weighing: &Weighing,
        sampler: &mut Sampler,
        batch: &mut ShadowBatch,
    ) -> bool {
        let sp = &v.sp;
        let fx = PreparedBsdf::new(*v.bsdf, sp.geometry(), v.wo, TransportMode::Radiance);
        let x = OffsetPoint::new(sp.p, sp.ng);
        // The picked lights' contributions one by one: a pick is rarely in the chunk of the
        // one before, and one light's scalar evaluation costs less than the four-wide kernel's
        // of its chunk (the same numbers bit for bit: `lanes.rs`'s tests).
        let lobe = receiver_lobe(v, weighing);
        resample(
            self.lanes.chunks(),
            m,
            k,
            fx.is_active(),
            sampler,
            |cands, window, _| {
                let r = EstimateReceiver {
                    x: sp.p,
                    ng: sp.ng,
                    ns: sp.frame.n,
                    bound: self.bound,
                    max_depth: max_vpl_depth,
                    lobe: lobe.as_ref(),
                };
                self.lanes.push_estimates(cands, window, &r);
            },
            |j, factor, _| {
                let c =
                    point_contribution(sp.p, sp.frame.n, &fx, &self.vpls[j], &self.emitting[j], self.bound);
                if c != Vec3::ZERO {
                    let c = weighing.apply(sp.p, &self.vpls[j], &self.emitting[j], c);
                    batch.push(shadow_segment(&x, self.lanes.end(j)), c * factor);
                }
            },
        );
        fx.is_active()
    }

    /// Queues every light's contribution with its shadow ray; `false` when the receiver
    /// reflects nothing towards `v.wo`.
    fn queue(&self, v: &Vertex, max_vpl_depth: u32, weighing: &Weighing, batch: &mut ShadowBatch) -> bool {
        let sp = &v.sp;
        let fx = PreparedBsdf::new(*v.bsdf, sp.geometry(), v.wo, TransportMode::Radiance);
        if !fx.is_active() {
            return false;
        }
        let x = OffsetPoint::new(sp.p, sp.ng);
        // Lambertian pairs lane by lane, the others one by one, queued in VPL order.
        let receiver = DiffuseReceiver::new(sp, &fx);
        for chunk in 0..self.lanes.chunks() {
            let lanes =
                receiver.map(|r| self.lanes.diffuse_contributions(chunk, &r, self.bound, max_vpl_depth));
            for i in 0..LANES {
                let j = chunk * LANES + i;
                let Some(vpl) = self.vpls.get(j) else { break };
                let c = match (lanes, self.lanes.kind(j)) {
                    (Some(c), LaneKind::Diffuse | LaneKind::Empty) => c[i],
                    _ if vpl.depth > max_vpl_depth => continue,
                    _ => point_contribution(sp.p, sp.frame.n, &fx, vpl, &self.emitting[j], self.bound),
                };
                if c != Vec3::ZERO {
                    let c = weighing.apply(sp.p, vpl, &self.emitting[j], c);
                    batch.push(shadow_segment(&x, self.lanes.end(j)), c);
                }
            }
        }
        true
    }
}

thread_local! {
    /// The contributions a resampled gather of spheres evaluated as candidates: (sphere,
    /// contribution), reused from receiver to receiver so that a gather allocates nothing.
    static EXACT: std::cell::RefCell<Vec<(usize, Vec3)>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl SphereLights {
    /// Queues the sampled spheres' weighted contributions with their shadow rays.
    fn queue_sampled(
        &self,
        v: &Vertex,
        picks: &[Pick],
        k: usize,
        sampler: &mut Sampler,
        batch: &mut ShadowBatch,
    ) -> bool {
        let rx = SphereReceiver::at(v);
        let x = OffsetPoint::new(v.sp.p, v.sp.ng);
        for pick in picks {
            let c = self.contribution(pick.light, &rx, sampler);
            if c != Vec3::ZERO {
                batch.push(shadow_segment(&x, &self.ends[pick.light]), weighted(c, pick, k));
            }
        }
        true
    }

    /// Queues the k spheres picked from a window of m candidates ([`super::resample`]); `false`
    /// when the receiver reflects nothing towards `v.wo`. Draws two numbers before the
    /// candidates' own, always.
    fn queue_resampled(
        &self,
        v: &Vertex,
        max_vpl_depth: u32,
        m: usize,
        k: usize,
        sampler: &mut Sampler,
        batch: &mut ShadowBatch,
    ) -> bool {
        let rx = SphereReceiver::at(v);
        let x = OffsetPoint::new(v.sp.p, v.sp.ng);
        EXACT.with(|exact| {
            exact.borrow_mut().clear();
            // The picked spheres' contributions: those evaluated as candidates (a narrow lobe
            // at either end), the chunk's closed forms and zeros four at a time (picks come in
            // sphere order), the other spheres' cone integrals one by one.
            let mut chunk_done: Option<(usize, [Vec4; 3], u32)> = None;
            resample(
                self.lanes.chunks(),
                m,
                k,
                rx.is_active(),
                sampler,
                |cands, window, sampler| {
                    for block in window.blocks() {
                        let (mut p, narrow) = self.lanes.estimates(block, &rx.end, max_vpl_depth);
                        for i in (0..LANES).filter(|i| narrow >> i & 1 == 1) {
                            let j = block * LANES + i;
                            let c = self.contribution(j, &rx, sampler);
                            p[i] = c.element_sum();
                            exact.borrow_mut().push((j, c));
                        }
                        cands.push(block * LANES, p)
                    }
                },
                |j, factor, sampler| {
                    let evaluated = exact.borrow().iter().find(|e| e.0 == j).map(|e| e.1);
                    let c = match evaluated {
                        Some(c) => c,
                        None => {
                            let (chunk, lane) = (j / LANES, j % LANES);
                            if chunk_done.is_none_or(|(c, ..)| c != chunk) {
                                let (rgb, done) = self.lanes.without_sampling(chunk, &rx.end, max_vpl_depth);
                                chunk_done = Some((chunk, rgb, done));
                            }
                            let (_, rgb, done) = chunk_done.expect("filled just above");
                            // A lane that is not done has an estimate only if the sphere is
                            // within the depth and active, so it is sampled as a whole gather
                            // would sample it.
                            if done >> lane & 1 == 1 {
                                Vec3::new(rgb[0][lane], rgb[1][lane], rgb[2][lane])
                            } else {
                                self.contribution(j, &rx, sampler)
                            }
                        }
                    };
                    if c != Vec3::ZERO {
                        batch.push(shadow_segment(&x, &self.ends[j]), c * factor);
                    }
                },
            );
        });
        rx.is_active()
    }

    /// Queues every sphere's contribution with its shadow ray to the centre; `false` when the
    /// receiver reflects nothing towards `v.wo`.
    fn queue(&self, v: &Vertex, max_vpl_depth: u32, sampler: &mut Sampler, batch: &mut ShadowBatch) -> bool {
        let rx = SphereReceiver::at(v);
        if !rx.is_active() {
            return false;
        }
        let x = OffsetPoint::new(v.sp.p, v.sp.ng);
        for chunk in 0..self.lanes.chunks() {
            let cs = self.chunk_contributions(chunk, &rx, max_vpl_depth, sampler);
            for (i, c) in cs.into_iter().enumerate() {
                if c != Vec3::ZERO {
                    batch.push(shadow_segment(&x, &self.ends[chunk * LANES + i]), c);
                }
            }
        }
        true
    }

    /// The contributions at `rx` of the spheres of chunk `chunk` with at most `max_vpl_depth`
    /// segments (zero for the others and past the last sphere): the diffuse pairs in closed
    /// form and the cones without light four at a time ([`super::sphere_lanes`]), the others
    /// one by one in sphere order, so that they draw their numbers as they would alone.
    #[inline]
    fn chunk_contributions(
        &self,
        chunk: usize,
        rx: &SphereReceiver,
        max_vpl_depth: u32,
        sampler: &mut Sampler,
    ) -> [Vec3; LANES] {
        let (rgb, done) = self.lanes.without_sampling(chunk, &rx.end, max_vpl_depth);
        std::array::from_fn(|i| {
            let j = chunk * LANES + i;
            match self.vpls.get(j) {
                _ if done >> i & 1 == 1 => Vec3::new(rgb[0][i], rgb[1][i], rgb[2][i]),
                Some(vpl) if vpl.depth <= max_vpl_depth => self.contribution(j, rx, sampler),
                _ => Vec3::ZERO,
            }
        })
    }
}

/// Φ f_p cos_p f_x cos_x / d² of one VPL at the receiver x (shading normal `n`), with G
/// clamped at `bound`; zero when either BSDF is. The scalar form of the gather; the four-wide
/// kernel of [`super::lanes`] computes exactly this, bit for bit.
pub(super) fn point_contribution(
    x: Vec3,
    n: Vec3,
    fx: &PreparedBsdf,
    vpl: &Vpl,
    fp: &PreparedBsdf,
    bound: f32,
) -> Vec3 {
    let d = vpl.p - x;
    let dist2 = d.length_squared();
    if dist2 <= 0.0 {
        return Vec3::ZERO;
    }
    let w = d / dist2.sqrt();
    let fx = fx.eval(w);
    if fx == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let fp = fp.eval(-w);
    if fp == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let c = vpl.flux * fx * fp / dist2;
    if bound.is_finite() {
        let g = n.dot(w).abs() * vpl.frame.n.dot(w).abs() / dist2;
        if g > bound {
            return c * (bound / g);
        }
    }
    c
}
