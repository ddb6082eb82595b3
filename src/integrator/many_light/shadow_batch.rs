//! The gather's queue of shadow rays: each ray with the contribution it carries, traced
//! [`BATCH`] at a time through [`Accelerator::occluded_batch`] (Embree's packets), summing
//! the contributions of the unoccluded ones in queue order: where the scalar walker, a
//! bounce's own gather (`pir-mis`) and the batched walker's gathers of more than [`BATCH`]
//! connections trace the gather's connections ([`crate::integrator::deferred::Immediate`]);
//! the batched walker keeps smaller gathers' connections with the bounce's shadow rays
//! instead and sums them in the same batches ([`crate::integrator::deferred::Deferred`]).
//!
//! The queue's arrays are the thread's own, reused from gather to gather
//! ([`with_shadow_batch`]): a receiver that queues four rays (the resampled gather) pays for
//! four, not for building and copying the arrays of a full batch (about 7 % of `pir-bdpt`'s
//! instructions on the Mori knob when they were built per gather).

use std::cell::RefCell;

use glam::Vec3;

use crate::accel::Accelerator;
use crate::geometry::Ray;
use crate::integrator::deferred::Connections;

/// Shadow rays per batch handed to the accelerator.
pub const BATCH: usize = 64;

/// The arrays of a queue.
#[derive(Default)]
struct Queue {
    rays: Vec<Ray>,
    contrib: Vec<Vec3>,
    occluded: Vec<bool>,
}

thread_local! {
    static QUEUE: RefCell<Queue> = RefCell::default();
}

/// Runs `f` with an empty shadow-ray queue for `accel` that uses this thread's arrays (fresh
/// ones if a queue of this thread is in use already), and returns what `f` returns.
pub fn with_shadow_batch<R>(accel: &dyn Accelerator, f: impl FnOnce(&mut ShadowBatch) -> R) -> R {
    QUEUE.with(|q| match q.try_borrow_mut() {
        Ok(mut queue) => f(&mut ShadowBatch::new(accel, &mut queue)),
        Err(_) => f(&mut ShadowBatch::new(accel, &mut Queue::default())),
    })
}

pub struct ShadowBatch<'a> {
    accel: &'a dyn Accelerator,
    queue: &'a mut Queue,
    /// Rays traced so far.
    traced: u64,
    /// The sum over traced batches (each batch summed on its own, then added).
    total: Vec3,
}

impl Connections for ShadowBatch<'_> {
    #[inline]
    fn push(&mut self, ray: Ray, contrib: Vec3) {
        ShadowBatch::push(self, ray, contrib);
    }
}

impl<'a> ShadowBatch<'a> {
    fn new(accel: &'a dyn Accelerator, queue: &'a mut Queue) -> Self {
        queue.rays.clear();
        queue.contrib.clear();
        ShadowBatch { accel, queue, traced: 0, total: Vec3::ZERO }
    }

    /// Queues `contrib`, to be added unless `ray` is occluded.
    #[inline]
    pub fn push(&mut self, ray: Ray, contrib: Vec3) {
        self.queue.rays.push(ray);
        self.queue.contrib.push(contrib);
        if self.queue.rays.len() == BATCH {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let q = &mut *self.queue;
        let n = q.rays.len();
        self.traced += n as u64;
        q.occluded.clear();
        q.occluded.resize(n, false);
        self.accel.occluded_batch(&q.rays, &mut q.occluded);
        let mut sum = Vec3::ZERO;
        for (c, &o) in q.contrib.iter().zip(&q.occluded) {
            if !o {
                sum += *c;
            }
        }
        self.total += sum;
        q.rays.clear();
        q.contrib.clear();
    }

    /// Traces what is queued; returns the sum of the unoccluded contributions and the number
    /// of rays traced.
    pub fn finish(&mut self) -> (Vec3, u64) {
        if !self.queue.rays.is_empty() {
            self.flush();
        }
        (self.total, self.traced)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::BruteForce;
    use crate::accel::testmesh;

    /// A queue sums exactly the unoccluded contributions, over more rays than a batch, and a
    /// queue opened while another is in use starts empty and leaves the other intact.
    #[test]
    fn sums_the_unoccluded_contributions_across_batches_and_nested_queues() {
        let mesh = testmesh::cornell_like();
        let accel = BruteForce::new(&mesh.positions, &mesh.indices);
        let rays = testmesh::random_segments(&mesh.bounds(), 3 * BATCH + 5, 7);
        let expect = |rays: &[Ray]| -> Vec3 {
            rays.iter()
                .enumerate()
                .filter(|(_, r)| !accel.occluded(r))
                .map(|(i, _)| Vec3::splat(i as f32))
                .sum()
        };
        let (want_outer, want_inner) = (expect(&rays), expect(&rays[..BATCH + 1]));
        let unoccluded = rays.iter().filter(|r| !accel.occluded(r)).count();
        assert!(unoccluded > 0 && unoccluded < rays.len(), "{unoccluded} of {}", rays.len());
        for _ in 0..2 {
            let outer = with_shadow_batch(&accel, |outer| {
                for (i, r) in rays.iter().enumerate() {
                    outer.push(*r, Vec3::splat(i as f32));
                    if i == BATCH / 2 {
                        // A nested queue (fresh arrays) while this one holds rays.
                        let inner = with_shadow_batch(&accel, |inner| {
                            for (i, r) in rays[..BATCH + 1].iter().enumerate() {
                                inner.push(*r, Vec3::splat(i as f32));
                            }
                            inner.finish()
                        });
                        assert_eq!(inner, (want_inner, BATCH as u64 + 1));
                    }
                }
                outer.finish()
            });
            assert_eq!(outer, (want_outer, rays.len() as u64));
        }
        // A queue finished with nothing in it traces nothing.
        assert_eq!(with_shadow_batch(&accel, |b| b.finish()), (Vec3::ZERO, 0));
    }
}
