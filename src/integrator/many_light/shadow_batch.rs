//! The gather's queue of shadow rays: each ray with the contribution it carries, traced
//! [`BATCH`] at a time through [`Accelerator::occluded_batch`] (Embree's packets), summing
//! the contributions of the unoccluded ones in queue order.

use glam::Vec3;

use crate::accel::Accelerator;
use crate::geometry::Ray;

/// Shadow rays per batch handed to the accelerator.
pub const BATCH: usize = 64;

pub struct ShadowBatch<'a> {
    accel: &'a dyn Accelerator,
    rays: [Ray; BATCH],
    contrib: [Vec3; BATCH],
    occluded: [bool; BATCH],
    len: usize,
    /// Rays traced so far.
    pub traced: u64,
    /// The sum over traced batches (each batch summed on its own, then added).
    total: Vec3,
}

impl<'a> ShadowBatch<'a> {
    pub fn new(accel: &'a dyn Accelerator) -> Self {
        ShadowBatch {
            accel,
            rays: [Ray::new(Vec3::ZERO, Vec3::Z); BATCH],
            contrib: [Vec3::ZERO; BATCH],
            occluded: [false; BATCH],
            len: 0,
            traced: 0,
            total: Vec3::ZERO,
        }
    }

    /// Queues `contrib`, to be added unless `ray` is occluded.
    #[inline]
    pub fn push(&mut self, ray: Ray, contrib: Vec3) {
        self.rays[self.len] = ray;
        self.contrib[self.len] = contrib;
        self.len += 1;
        if self.len == BATCH {
            self.flush();
        }
    }

    fn flush(&mut self) {
        let n = self.len;
        self.traced += n as u64;
        self.accel.occluded_batch(&self.rays[..n], &mut self.occluded[..n]);
        let mut sum = Vec3::ZERO;
        for (c, &o) in self.contrib[..n].iter().zip(&self.occluded[..n]) {
            if !o {
                sum += *c;
            }
        }
        self.total += sum;
        self.len = 0;
    }

    /// Traces what is queued; returns the sum of the unoccluded contributions.
    pub fn finish(mut self) -> (Vec3, u64) {
        if self.len > 0 {
            self.flush();
        }
        (self.total, self.traced)
    }
}
