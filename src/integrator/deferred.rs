//! Terms whose shadow rays wait: what a camera vertex adds to its path, kept by a batched
//! walker until it has traced the shadow rays of all its paths' vertices together
//! ([`Deferred`],
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch)), and where an
//! estimator puts light samples that it sums before weighing them ([`LightSamples`]: tested
//! at once by the scalar walker, [`Summed`], or kept by [`Deferred`]).
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

/// Where an estimator puts light samples that it sums (then weighs by their count).
pub trait LightSamples {
    /// A light sample connected to the vertex (`None`: it adds nothing, visible or not), its
    /// contribution weighed by `weight` where nothing blocks its shadow ray.
    fn add(&mut self, ctx: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32);
}

/// Light samples tested one by one as they come, and summed: the scalar walker's.
#[derive(Clone, Copy, Debug, Default)]
pub struct Summed {
    /// The sum of the samples' values, in their order.
    pub sum: Vec3,
}

impl LightSamples for Summed {
    #[inline(always)]
    fn add(&mut self, ctx: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) {
        self.sum += match c {
            Some(c) if !c.shadow.is_some_and(|ray| ctx.accel.occluded(&ray)) => c.value(weight),
            _ => Vec3::ZERO,
        };
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

impl LightSamples for Deferred {
    /// A light sample of the vertex's sum ([`Deferred::mean`] adds it).
    #[inline(always)]
    fn add(&mut self, _: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) {
        let (shadow, value) = self.connect(c, weight);
        self.keep(Term { path: self.path, shadow, op: Op::Sum, beta: Vec3::ZERO, value });
    }
}

impl Deferred {
    /// The terms given from now on are path `path`'s, none of whose terms waits.
    #[inline(always)]
    pub(crate) fn at(&mut self, path: u32) {
        self.path = path;
        self.waiting = false;
    }

    /// A light sample connected to the vertex (`None`: it adds nothing), added times `beta`
    /// to the path's `radiance` where nothing blocks its shadow ray, weighed by `weight`.
    #[inline(always)]
    pub fn sample(
        &mut self,
        beta: Vec3,
        c: Option<Connection>,
        weight: impl FnOnce(LightSample) -> f32,
        radiance: &mut Vec3,
    ) {
        let (shadow, value) = self.connect(c, weight);
        if shadow == NO_SHADOW && !self.waiting {
            *radiance += beta * value;
        } else {
            self.keep(Term { path: self.path, shadow, op: Op::Add, beta, value });
        }
    }

    /// `beta · value`, added to the path's `radiance` after the terms before it.
    #[inline(always)]
    pub fn add(&mut self, beta: Vec3, value: Vec3, radiance: &mut Vec3) {
        if self.waiting {
            self.keep(Term { path: self.path, shadow: NO_SHADOW, op: Op::Add, beta, value });
        } else {
            *radiance += beta * value;
        }
    }

    /// `beta` times the mean of the `n` light samples given since the last mean
    /// ([`LightSamples::add`]), added after the terms before it.
    #[inline(always)]
    pub fn mean(&mut self, beta: Vec3, n: u32) {
        let value = Vec3::new(n as f32, 0.0, 0.0);
        self.keep(Term { path: self.path, shadow: NO_SHADOW, op: Op::Mean, beta, value });
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
            Some(c) => {
                let shadow = match c.shadow {
                    None => NO_SHADOW,
                    Some(ray) => {
                        self.shadows.push(ray);
                        (self.shadows.len() - 1) as u32
                    }
                };
                (shadow, c.value(weight))
            }
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
