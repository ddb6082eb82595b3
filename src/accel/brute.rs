//! The brute-force backend: every ray against every triangle. The oracle that every other
//! backend is tested against; too slow for anything but small scenes and tests.

use glam::Vec3;

use super::{Accelerator, Hit};
use crate::geometry::{Ray, intersect_triangle};

pub struct BruteForce {
    tris: Vec<[Vec3; 3]>,
}

impl BruteForce {
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let tris = indices
            .iter()
            .map(|t| [positions[t[0] as usize], positions[t[1] as usize], positions[t[2] as usize]])
            .collect();
        BruteForce { tris }
    }
}

impl Accelerator for BruteForce {
    fn name(&self) -> &str {
        "brute"
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_valid() {
            return None;
        }
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        for (i, [a, b, c]) in self.tris.iter().enumerate() {
            if let Some(h) = intersect_triangle(ray.origin, ray.dir, ray.tmin, tmax, *a, *b, *c) {
                tmax = h.t;
                best = Some(Hit { t: h.t, prim: i as u32, u: h.u, v: h.v });
            }
        }
        best
    }

    fn occluded(&self, ray: &Ray) -> bool {
        ray.is_valid()
            && self.tris.iter().any(|[a, b, c]| {
                intersect_triangle(ray.origin, ray.dir, ray.tmin, ray.tmax, *a, *b, *c).is_some()
            })
    }
}
