//! Light samples whose shadow rays wait: where an estimator puts the light samples of a
//! camera vertex ([`LightSamples`]), either tested at once ([`Summed`], the scalar walker's)
//! or parked with the vertex's other terms until a batched walker has traced the shadow rays
//! of all its paths' vertices together ([`Deferred`],
//! [`Accelerator::occluded_batch`](crate::accel::Accelerator::occluded_batch)).
//!
//! Both give each sample the value [`sample_emitters_at`](super::direct::sample_emitters_at)
//! gives it (zero where it connects to nothing or is occluded), and a parked vertex's values
//! come back in the order its samples were added, so that an estimator adds the same terms
//! in the same order either way ([`super::walker::Estimator::finish_vertex`]): the image does
//! not depend on the walker.

use glam::Vec3;

use super::RenderContext;
use super::direct::{Connection, LightSample};
use crate::geometry::Ray;

/// Where an estimator puts the light samples of a camera vertex.
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

/// Where a shadow ray is not needed ([`Parked`]).
const NO_SHADOW: u32 = u32::MAX;

/// The terms of one camera vertex waiting for its light samples' shadow rays.
#[derive(Clone, Copy, Debug)]
struct Parked {
    /// The path's index in the batch.
    path: u32,
    /// The path throughput at the vertex.
    beta: Vec3,
    /// The vertex's samples, `Deferred::samples[start..end]`.
    start: u32,
    end: u32,
    /// What the estimator adds after the light samples (e.g. its gather), if anything.
    then: Option<Vec3>,
}

/// The light samples of a bounce's vertices, across a batch of paths, with their shadow rays
/// to trace together; buffers kept across bounces.
#[derive(Default)]
pub struct Deferred {
    vertices: Vec<Parked>,
    /// Each sample's value where unoccluded and its shadow ray's index (or [`NO_SHADOW`]).
    samples: Vec<(Vec3, u32)>,
    shadows: Vec<Ray>,
    blocked: Vec<bool>,
    values: Vec<Vec3>,
}

impl LightSamples for Deferred {
    #[inline(always)]
    fn add(&mut self, _: &RenderContext, c: Option<Connection>, weight: impl FnOnce(LightSample) -> f32) {
        let sample = match c {
            None => (Vec3::ZERO, NO_SHADOW),
            Some(c) => {
                let shadow = match c.shadow {
                    None => NO_SHADOW,
                    Some(ray) => {
                        self.shadows.push(ray);
                        (self.shadows.len() - 1) as u32
                    }
                };
                (c.value(weight), shadow)
            }
        };
        self.samples.push(sample);
    }
}

impl Deferred {
    /// Forgets every parked vertex (the buffers are kept).
    pub(crate) fn clear(&mut self) {
        self.vertices.clear();
        self.samples.clear();
        self.shadows.clear();
    }

    /// Starts parking a vertex of path `path` whose throughput is `beta`: what
    /// [`LightSamples::add`] and [`Deferred::then`] add until [`Deferred::close`] is its.
    #[inline(always)]
    pub(crate) fn open(&mut self, path: u32, beta: Vec3) {
        let start = self.samples.len() as u32;
        self.vertices.push(Parked { path, beta, start, end: start, then: None });
    }

    /// What the open vertex adds after its light samples: the estimator's own term.
    #[inline(always)]
    pub fn then(&mut self, value: Vec3) {
        if let Some(v) = self.vertices.last_mut() {
            v.then = Some(value);
        }
    }

    /// Ends the open vertex; one that parked nothing is forgotten.
    #[inline(always)]
    pub(crate) fn close(&mut self) {
        let end = self.samples.len() as u32;
        if let Some(v) = self.vertices.last_mut() {
            v.end = end;
            if v.start == end && v.then.is_none() {
                self.vertices.pop();
            }
        }
    }

    /// Traces the parked shadow rays as one batch and hands each parked vertex, in the order
    /// they were parked, to `add`: its path, throughput, samples' values (zero where
    /// occluded), in the order they were added, and its own term. Then clears.
    pub(crate) fn finish(
        &mut self,
        ctx: &RenderContext,
        mut add: impl FnMut(u32, Vec3, &[Vec3], Option<Vec3>),
    ) {
        if !self.shadows.is_empty() {
            self.blocked.clear();
            self.blocked.resize(self.shadows.len(), false);
            ctx.accel.occluded_batch(&self.shadows, &mut self.blocked);
        }
        for v in &self.vertices {
            self.values.clear();
            self.values.extend(self.samples[v.start as usize..v.end as usize].iter().map(
                |&(value, shadow)| {
                    if shadow != NO_SHADOW && self.blocked[shadow as usize] { Vec3::ZERO } else { value }
                },
            ));
            add(v.path, v.beta, &self.values, v.then);
        }
        self.clear();
    }
}
