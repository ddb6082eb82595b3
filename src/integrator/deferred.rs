//! Where a camera vertex's terms go ([`Terms`]): added to the path at once, each shadow ray
//! traced as it comes (the scalar walker's [`Immediate`]), or kept by a batched walker until
//! it has traced the shadow rays of all its paths' vertices together ([`Deferred`],
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch)). An estimator
//! writes its vertex once, against [`Terms`], for both walkers.
//!
//! A light sample's value is the one
//! [`sample_emitters_at`](super::direct::sample_emitters_at) gives it (zero where it connects
//! to nothing or is occluded), and a path's terms are added in the order the estimator gave
//! them, each computed as the scalar walker computes it, so that the image does not depend on
//! the walker.

use glam::Vec3;

use super::RenderContext;
use super::direct::{Connection, LightSample};
use crate::geometry::Ray;

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
/// nothing need no shadow ray).
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
    pub(crate) fn finish(&mut self, ctx: &RenderContext, mut add: impl FnMut(u32, Vec3)) {
        if !self.shadows.is_empty() {
            self.blocked.clear();
            self.blocked.resize(self.shadows.len(), false);
            ctx.accel.occluded_batch(&self.shadows, &mut self.blocked);
        }
        // (A vertex's samples and their mean are consecutive terms of one path.)
        let mut sum = Vec3::ZERO;
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
            }
        }
        self.terms.clear();
        self.shadows.clear();
    }
}
