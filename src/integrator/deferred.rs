//! Where a camera vertex's terms go ([`Terms`]): added to the path at once, each shadow ray
//! traced as it comes (the scalar walker's [`Immediate`]), or kept by a batched walker until
//! it has traced the shadow rays of all its paths' vertices together ([`Deferred`],
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch)). An estimator
//! writes its vertex once, against [`Terms`], for both walkers.
//!
//! A gather from the virtual lights goes the same way: its connections (a shadow ray and the
//! contribution it carries, [`Connections`]) are traced as they come, in the gather's own
//! batches ([`Immediate`]), or kept with the bounce's shadow rays ([`Deferred`]), and either
//! sums the unoccluded ones in the same order and the same batches.
//!
//! A light sample's value is the one
//! [`sample_emitters_at`](super::direct::sample_emitters_at) gives it (zero where it connects
//! to nothing or is occluded), and a path's terms are added in the order the estimator gave
//! them, each computed as the scalar walker computes it, so that the image does not depend on
//! the walker.

use glam::Vec3;

use super::direct::{Connection, LightSample};
use super::{Counters, RenderContext};
use crate::accel::Accelerator;
use crate::geometry::Ray;
use crate::integrator::many_light::shadow_batch::{BATCH, with_shadow_batch};

/// Where a gather's connections go, one at a time: each one's shadow ray with the
/// contribution it carries where nothing blocks it. The gather's value is the sum of the
/// unoccluded contributions, summed in the order they came, [`BATCH`] at a time (each batch
/// on its own, then added to the total), whoever traces them ([`Terms::gather`]).
pub trait Connections {
    fn push(&mut self, ray: Ray, contrib: Vec3);
}

/// Where the terms of a camera vertex go, each added to the path's `radiance` (times the
/// throughput `beta` it is given) in the order they are given.
pub trait Terms {
    /// A light sample connected to the vertex (`None`: it adds nothing, visible or not),
    /// weighed by `weight`, its value zero where its shadow ray is blocked.
    fn sample(
        &mut self,
        ctx: &RenderContext,
        beta: Vec3,
        c: Option<Connection>,
        weight: impl FnOnce(LightSample) -> f32,
        radiance: &mut Vec3,
    );

    /// A light sample of the vertex's running sum (added by [`Terms::mean`]).
    fn sum(&mut self, ctx: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32);

    /// `beta` times the mean of the `n` light samples summed since the last mean.
    fn mean(&mut self, beta: Vec3, n: u32, radiance: &mut Vec3);

    /// `beta · value`.
    fn add(&mut self, beta: Vec3, value: Vec3, radiance: &mut Vec3);

    /// What [`Terms::gather`] gives [`Terms::add_gathered`].
    type Gathered: Copy;

    /// A gather of at most `most` connections: `queue` gives them ([`Connections`]) and says
    /// whether the receiver gathers at all (where it does not, it gives none and the gather
    /// is zero); their shadow rays are counted in `counters`. What it returns goes to
    /// [`Terms::add_gathered`], which adds the gather times a throughput, in the path's order
    /// of terms.
    fn gather(
        &mut self,
        accel: &dyn Accelerator,
        counters: &mut Counters,
        most: usize,
        queue: impl FnOnce(&mut dyn Connections) -> bool,
    ) -> Self::Gathered;

    /// `beta` times the gather that gave `gathered` ([`Terms::gather`]).
    fn add_gathered(&mut self, beta: Vec3, gathered: Self::Gathered, radiance: &mut Vec3);
}

/// The scalar walker's terms: each shadow ray traced as it comes, each term added at once.
#[derive(Clone, Copy, Debug, Default)]
pub struct Immediate {
    /// The running sum of the vertex's light samples.
    sum: Vec3,
}

impl Immediate {
    /// A light sample's value where nothing blocks its shadow ray, else zero.
    #[inline(always)]
    fn value(ctx: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) -> Vec3 {
        match c {
            Some(c) if !c.shadow.is_some_and(|ray| ctx.accel.occluded(&ray)) => c.value(weight),
            _ => Vec3::ZERO,
        }
    }
}

impl Terms for Immediate {
    #[inline(always)]
    fn sample(
        &mut self,
        ctx: &RenderContext,
        beta: Vec3,
        c: Option<Connection>,
        weight: impl FnOnce(LightSample) -> f32,
        radiance: &mut Vec3,
    ) {
        // (A zero is added too: β · 0 is NaN where β is not finite, as the batched walk adds.)
        *radiance += beta * Self::value(ctx, c, weight);
    }

    #[inline(always)]
    fn sum(&mut self, ctx: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) {
        self.sum += Self::value(ctx, c, weight);
    }

    #[inline(always)]
    fn mean(&mut self, beta: Vec3, n: u32, radiance: &mut Vec3) {
        *radiance += beta * (self.sum / n as f32);
        self.sum = Vec3::ZERO;
    }

    #[inline(always)]
    fn add(&mut self, beta: Vec3, value: Vec3, radiance: &mut Vec3) {
        *radiance += beta * value;
    }

    /// The gather's value, its shadow rays traced as they come, [`BATCH`] at a time.
    type Gathered = Vec3;

    #[inline(always)]
    fn gather(
        &mut self,
        accel: &dyn Accelerator,
        counters: &mut Counters,
        _: usize,
        queue: impl FnOnce(&mut dyn Connections) -> bool,
    ) -> Vec3 {
        with_shadow_batch(accel, |batch| {
            if !queue(batch) {
                return Vec3::ZERO;
            }
            let (total, traced) = batch.finish();
            counters.shadow_rays += traced;
            total
        })
    }

    #[inline(always)]
    fn add_gathered(&mut self, beta: Vec3, gathered: Vec3, radiance: &mut Vec3) {
        *radiance += beta * gathered;
    }
}

/// Where a term needs no shadow ray.
const NO_SHADOW: u32 = u32::MAX;

/// What a kept term does to its path, its value zero where its shadow ray is blocked.
#[derive(Clone, Copy, Debug)]
enum Op {
    /// Adds `beta · value` to the path's radiance.
    Add,
    /// Adds `value` to the running sum of the vertex's light samples.
    Sum,
    /// Adds `beta · (sum / n)` to the path's radiance and starts a new sum, `n` in the
    /// term's `value.x`.
    Mean,
    /// Adds `value` to the gather's sum of its current batch of [`BATCH`] connections.
    Connection,
    /// Adds `beta` times the gather's total (the sums of its batches) to the path's radiance
    /// and starts a new gather (a receiver that gathers nothing gave no connection: `beta · 0`).
    Gathered,
}

/// A term of a path kept for the batch's shadow rays.
#[derive(Clone, Copy, Debug)]
struct Term {
    path: u32,
    /// The index of its shadow ray, or [`NO_SHADOW`].
    shadow: u32,
    op: Op,
    beta: Vec3,
    value: Vec3,
}

/// The terms of a bounce's vertices, across a batch of paths, with their shadow rays to
/// trace together; buffers kept across bounces. The walker names the path whose vertex it
/// shades ([`Deferred::at`]); the terms an estimator gives are that path's. A term that needs
/// no shadow ray, before the path's first that does, is added to the path's radiance at once
/// (the scalar walker's order is kept either way, and most of `pt`'s light samples that add
/// nothing need no shadow ray); a kept gather's total always waits for its connections.
#[derive(Default)]
pub struct Deferred {
    path: u32,
    /// Whether a term of the current path is kept (the terms after it wait too).
    waiting: bool,
    terms: Vec<Term>,
    shadows: Vec<Ray>,
    blocked: Vec<bool>,
}

impl Terms for Deferred {
    /// Added at once where it needs no shadow ray and no term of the path waits; else kept.
    #[inline(always)]
    fn sample(
        &mut self,
        _: &RenderContext,
        beta: Vec3,
        c: Option<Connection>,
        weight: impl FnOnce(LightSample) -> f32,
        radiance: &mut Vec3,
    ) {
        let (shadow, value) = self.connect(c, weight);
        self.place(beta, shadow, value, radiance);
    }

    #[inline(always)]
    fn sum(&mut self, _: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) {
        let (shadow, value) = self.connect(c, weight);
        self.keep(Term { path: self.path, shadow, op: Op::Sum, beta: Vec3::ZERO, value });
    }

    #[inline(always)]
    fn mean(&mut self, beta: Vec3, n: u32, _: &mut Vec3) {
        let value = Vec3::new(n as f32, 0.0, 0.0);
        self.keep(Term { path: self.path, shadow: NO_SHADOW, op: Op::Mean, beta, value });
    }

    #[inline(always)]
    fn add(&mut self, beta: Vec3, value: Vec3, radiance: &mut Vec3) {
        if self.waiting {
            self.keep(Term { path: self.path, shadow: NO_SHADOW, op: Op::Add, beta, value });
        } else {
            *radiance += beta * value;
        }
    }

    type Gathered = KeptGather;

    /// Kept where it has at most [`BATCH`] connections (the sampled gathers, whose
    /// `--gather-samples` is at most 64; a gather of every VPL where there are few); a larger
    /// one (every VPL of many) is traced at once in its own batches, as the scalar walker
    /// traces it, so that what a bounce keeps stays bounded whatever the number of VPLs.
    #[inline(always)]
    fn gather(
        &mut self,
        accel: &dyn Accelerator,
        counters: &mut Counters,
        most: usize,
        queue: impl FnOnce(&mut dyn Connections) -> bool,
    ) -> KeptGather {
        if most > BATCH {
            return KeptGather::Traced(Immediate::default().gather(accel, counters, most, queue));
        }
        let before = self.shadows.len();
        let gathers = queue(self);
        // (As `Terms::gather` asks: a receiver that does not gather gave no connection, so its
        // total is zero and the count is the scalar walker's.)
        debug_assert!(
            gathers || self.shadows.len() == before,
            "a receiver that does not gather gave connections"
        );
        counters.shadow_rays += (self.shadows.len() - before) as u64;
        KeptGather::Kept
    }

    #[inline(always)]
    fn add_gathered(&mut self, beta: Vec3, gathered: KeptGather, radiance: &mut Vec3) {
        match gathered {
            KeptGather::Kept => {
                self.keep(Term {
                    path: self.path,
                    shadow: NO_SHADOW,
                    op: Op::Gathered,
                    beta,
                    value: Vec3::ZERO,
                });
            }
            KeptGather::Traced(total) => self.add(beta, total, radiance),
        }
    }
}

/// A gather as the batched walker's [`Deferred`] holds it.
#[derive(Clone, Copy, Debug)]
pub enum KeptGather {
    /// Its connections kept with the bounce's shadow rays.
    Kept,
    /// Traced at once (too many connections to keep): its value.
    Traced(Vec3),
}

/// A gather's connection, kept with its shadow ray for the batch's queries.
impl Connections for Deferred {
    #[inline(always)]
    fn push(&mut self, ray: Ray, contrib: Vec3) {
        let shadow = self.push_shadow(Some(ray));
        self.keep(Term { path: self.path, shadow, op: Op::Connection, beta: Vec3::ZERO, value: contrib });
    }
}

impl Deferred {
    /// The terms given from now on are path `path`'s, none of whose terms waits.
    #[inline(always)]
    pub(crate) fn at(&mut self, path: u32) {
        self.path = path;
        self.waiting = false;
    }

    /// A light sample computed elsewhere (`pt`'s Lambertian lanes,
    /// [`super::diffuse_lanes`]): what [`Terms::sample`] does with a connection whose
    /// segment is `shadow` (`None`: it connects to nothing) and whose value is `value`.
    #[inline(always)]
    pub(crate) fn sample_connected(
        &mut self,
        beta: Vec3,
        shadow: Option<Ray>,
        value: Vec3,
        radiance: &mut Vec3,
    ) {
        let shadow = self.push_shadow(shadow);
        self.place(beta, shadow, value, radiance);
    }

    /// Nothing kept (what a batch leaves behind is gone).
    pub(crate) fn clear(&mut self) {
        self.waiting = false;
        self.terms.clear();
        self.shadows.clear();
    }

    /// Keeps `shadow` for the batch's occlusion queries: its index, or [`NO_SHADOW`].
    #[inline(always)]
    fn push_shadow(&mut self, shadow: Option<Ray>) -> u32 {
        match shadow {
            None => NO_SHADOW,
            Some(ray) => {
                self.shadows.push(ray);
                (self.shadows.len() - 1) as u32
            }
        }
    }

    /// A light sample's term, added at once where it needs no shadow ray and no term of the
    /// path waits; else kept.
    #[inline(always)]
    fn place(&mut self, beta: Vec3, shadow: u32, value: Vec3, radiance: &mut Vec3) {
        if shadow == NO_SHADOW && !self.waiting {
            *radiance += beta * value;
        } else {
            self.keep(Term { path: self.path, shadow, op: Op::Add, beta, value });
        }
    }

    #[inline(always)]
    fn keep(&mut self, term: Term) {
        self.terms.push(term);
        self.waiting = true;
    }

    /// A light sample's shadow ray (kept) and its value where unoccluded.
    #[inline(always)]
    fn connect(&mut self, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) -> (u32, Vec3) {
        match c {
            None => (NO_SHADOW, Vec3::ZERO),
            Some(c) => (self.push_shadow(c.shadow), c.value(weight)),
        }
    }

    /// Traces the kept shadow rays as one batch and gives each path's terms, in the order
    /// they were kept, to `add` (the path, and what it adds to the path's radiance); then
    /// forgets them.
    #[inline(always)]
    pub(crate) fn finish(&mut self, accel: &dyn Accelerator, mut add: impl FnMut(u32, Vec3)) {
        if !self.shadows.is_empty() {
            self.blocked.clear();
            self.blocked.resize(self.shadows.len(), false);
            accel.occluded_batch(&self.shadows, &mut self.blocked);
        }
        // (A vertex's samples and their mean are consecutive terms of one path, and so are a
        // gather's connections and its total.)
        let mut sum = Vec3::ZERO;
        // The gather's: its total, the sum of its current batch and that batch's connections.
        let (mut total, mut batch, mut in_batch) = (Vec3::ZERO, Vec3::ZERO, 0);
        for t in &self.terms {
            let value =
                if t.shadow != NO_SHADOW && self.blocked[t.shadow as usize] { Vec3::ZERO } else { t.value };
            match t.op {
                Op::Add => add(t.path, t.beta * value),
                Op::Sum => sum += value,
                Op::Mean => {
                    add(t.path, t.beta * (sum / t.value.x));
                    sum = Vec3::ZERO;
                }
                // As `ShadowBatch` sums: each batch from zero, then added to the total. (A blocked
                // connection adds +0 where `ShadowBatch` leaves it out: the same bits, since a sum
                // that starts at +0 is never −0.)
                Op::Connection => {
                    batch += value;
                    in_batch += 1;
                    if in_batch == BATCH {
                        total += batch;
                        (batch, in_batch) = (Vec3::ZERO, 0);
                    }
                }
                Op::Gathered => {
                    if in_batch > 0 {
                        total += batch;
                    }
                    add(t.path, t.beta * total);
                    (total, batch, in_batch) = (Vec3::ZERO, Vec3::ZERO, 0);
                }
            }
        }
        self.terms.clear();
        self.shadows.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{BruteForce, testmesh};
    use crate::integrator::many_light::shadow_batch::ShadowBatch;

    /// A gather's connections kept by the batched walker sum, bit for bit, as the gather's own
    /// batches sum them ([`ShadowBatch`]): over more connections than a batch, some blocked,
    /// of contributions whose sum depends on the order and the batches; each path's gather
    /// on its own, after its light samples' mean; and a receiver that gathers nothing adds
    /// `beta · 0`.
    #[test]
    fn kept_connections_sum_as_the_gathers_batches() {
        let mesh = testmesh::cornell_like();
        let accel = BruteForce::new(&mesh.positions, &mesh.indices);
        let rays = testmesh::random_segments(&mesh.bounds(), 3 * BATCH + 5, 11);
        let blocked = rays.iter().filter(|r| accel.occluded(r)).count();
        assert!(blocked > 0 && blocked < rays.len(), "{blocked} of {}", rays.len());
        // Contributions from 1e-4 to 1e4, so that where each batch's sum starts shows.
        let contrib = |i: usize| {
            let x = (i as f32 * 0.618_034).fract();
            Vec3::new(10f32.powf(8.0 * x - 4.0), 1.0 / (1.0 + i as f32), 3.0 + x)
        };
        let gathers: [&[Ray]; 3] = [&rays, &rays[..BATCH], &rays[7..20]];
        let expected: Vec<Vec3> = gathers
            .iter()
            .map(|g| {
                with_shadow_batch(&accel, |b| {
                    for (i, r) in g.iter().enumerate() {
                        ShadowBatch::push(b, *r, contrib(i));
                    }
                    b.finish().0
                })
            })
            .collect();
        // The per-batch sums are not the plain running sum.
        let mut running = Vec3::ZERO;
        for (i, r) in rays.iter().enumerate() {
            if !accel.occluded(r) {
                running += contrib(i);
            }
        }
        assert_ne!(running, expected[0]);

        let mut d = Deferred::default();
        let beta = Vec3::new(1.0, 0.5, 2.0);
        let mut unused = Vec3::ZERO;
        for (path, g) in gathers.iter().enumerate() {
            d.at(path as u32);
            // (A light sample's mean before the gather, as `pir-bdpt` gives them.)
            d.keep(Term {
                path: path as u32,
                shadow: NO_SHADOW,
                op: Op::Sum,
                beta: Vec3::ZERO,
                value: Vec3::ONE,
            });
            for (i, r) in g.iter().enumerate() {
                Connections::push(&mut d, *r, contrib(i));
            }
            d.mean(beta, 1, &mut unused);
            d.add_gathered(beta, KeptGather::Kept, &mut unused);
        }
        // A receiver that gathers nothing.
        d.at(3);
        d.add_gathered(beta, KeptGather::Kept, &mut unused);
        // Through `Terms::gather`: a gather of at most a batch is kept, its rays counted; a
        // larger one is traced at once and added at once, nothing of the path waiting.
        let mut counters = Counters::default();
        fn queue_all(
            g: &[Ray],
            contrib: impl Fn(usize) -> Vec3,
        ) -> impl FnOnce(&mut dyn Connections) -> bool {
            move |q| {
                for (i, r) in g.iter().enumerate() {
                    q.push(*r, contrib(i));
                }
                true
            }
        }
        d.at(4);
        let kept = d.gather(&accel, &mut counters, BATCH, queue_all(gathers[2], contrib));
        assert!(matches!(kept, KeptGather::Kept), "{kept:?}");
        d.add_gathered(beta, kept, &mut unused);
        assert_eq!(counters.shadow_rays, gathers[2].len() as u64);
        let mut radiance = Vec3::ZERO;
        d.at(5);
        let traced = d.gather(&accel, &mut counters, rays.len(), queue_all(&rays, contrib));
        assert!(matches!(traced, KeptGather::Traced(t) if t == expected[0]), "{traced:?}");
        d.add_gathered(beta, traced, &mut radiance);
        assert_eq!(radiance, beta * expected[0]);
        assert_eq!(counters.shadow_rays, (gathers[2].len() + rays.len()) as u64);
        let mut added = vec![];
        d.finish(&accel, |path, term| added.push((path, term)));
        let mut want = vec![];
        for (path, e) in expected.iter().enumerate() {
            want.push((path as u32, beta * Vec3::ONE));
            want.push((path as u32, beta * *e));
        }
        want.push((3, beta * Vec3::ZERO));
        want.push((4, beta * expected[2]));
        assert_eq!(added, want);
        assert_eq!(unused, Vec3::ZERO);
    }
}
