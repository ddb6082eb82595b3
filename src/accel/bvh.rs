//! Placeholder: the pure-Rust BVH (binned SAH) is being written; it delegates to brute force.
use glam::Vec3;

use super::{Accelerator, BruteForce, Hit};
use crate::geometry::Ray;

pub struct Bvh {
    inner: BruteForce,
}

impl Bvh {
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        Bvh { inner: BruteForce::new(positions, indices) }
    }
}

impl Accelerator for Bvh {
    fn name(&self) -> &str {
        "bvh"
    }
    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.inner.intersect(ray)
    }
    fn occluded(&self, ray: &Ray) -> bool {
        self.inner.occluded(ray)
    }
}
