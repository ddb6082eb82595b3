//! Closest-hit and any-hit traversal of the BVH2.
//!
//! Both walk the tree with a fixed stack. At an interior node both children's boxes (one cache
//! line) are tested; closest-hit continues with the nearer one and pushes the other with its
//! entry distance, which is checked again when popped. The slab test is written so that the NaN
//! of `0 · ∞` (a ray with a zero direction component lying in a box's plane) counts as "inside
//! that slab", and the exit distance is widened by a few ulps (Ize 2013) so rounding cannot
//! cull a box that the exact ray touches.

use glam::Vec3;

use super::build::MAX_DEPTH;
use super::{Bvh, Node};
use crate::accel::Hit;
use crate::geometry::{Ray, intersect_triangle};

/// Widening of the exit distance: 1 + 2γ₃ rounded up generously.
const EXIT_SCALE: f32 = 1.0 + 1e-6;
const STACK: usize = MAX_DEPTH + 4;

/// A ray prepared for box tests.
struct RayBoxes {
    o: Vec3,
    inv: Vec3,
    neg: [bool; 3],
    tmin: f32,
}

impl RayBoxes {
    #[inline]
    fn new(ray: &Ray) -> Self {
        // 1 / ±0 = ±∞: the slab then spans everything or nothing, as it should.
        let inv = Vec3::ONE / ray.dir;
        RayBoxes {
            o: ray.origin,
            inv,
            neg: [ray.dir.x.is_sign_negative(), ray.dir.y.is_sign_negative(), ray.dir.z.is_sign_negative()],
            tmin: ray.tmin,
        }
    }

    /// The entry distance into `n`'s box within `(tmin, tmax)`, or `None` for a miss.
    #[inline(always)]
    fn enter(&self, n: &Node, tmax: f32) -> Option<f32> {
        let mut entry = self.tmin;
        let mut exit = tmax;
        for a in 0..3 {
            let (near, far) = if self.neg[a] { (n.max[a], n.min[a]) } else { (n.min[a], n.max[a]) };
            let t0 = (near - self.o[a]) * self.inv[a];
            let t1 = (far - self.o[a]) * self.inv[a];
            // A NaN comparison is false: NaN bounds leave the interval as it is.
            if t0 > entry {
                entry = t0;
            }
            if t1 < exit {
                exit = t1;
            }
        }
        (entry <= exit * EXIT_SCALE).then_some(entry)
    }
}

impl Bvh {
    /// The closest hit of a valid ray.
    pub(super) fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let rb = RayBoxes::new(ray);
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        let root = &self.pairs[0].nodes[0];
        rb.enter(root, tmax)?;
        let mut stack = [(0u32, 0f32); STACK];
        let mut sp = 0;
        let mut node = root;
        loop {
            if node.is_leaf() {
                let first = node.index as usize;
                let last = first + node.count as usize;
                for (tri, &id) in self.tris[first..last].iter().zip(&self.prim_ids[first..last]) {
                    let [a, b, c] = *tri;
                    if let Some(h) = intersect_triangle(ray.origin, ray.dir, ray.tmin, tmax, a, b, c) {
                        tmax = h.t;
                        best = Some(Hit { t: h.t, prim: id, u: h.u, v: h.v });
                    }
                }
            } else {
                let [l, r] = &self.pairs[node.index as usize].nodes;
                match (rb.enter(l, tmax), rb.enter(r, tmax)) {
                    (Some(tl), Some(tr)) => {
                        let (near, far_slot, tf) = if tl <= tr { (l, 1, tr) } else { (r, 0, tl) };
                        stack[sp] = (node.index * 2 + far_slot, tf);
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop the next node that starts before the closest hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (id, t) = stack[sp];
                if t <= tmax * EXIT_SCALE {
                    node = &self.pairs[(id >> 1) as usize].nodes[(id & 1) as usize];
                    break;
                }
            }
        }
    }

    /// Whether a valid ray hits anything.
    pub(super) fn any_hit(&self, ray: &Ray) -> bool {
        let rb = RayBoxes::new(ray);
        let tmax = ray.tmax;
        let root = &self.pairs[0].nodes[0];
        if rb.enter(root, tmax).is_none() {
            return false;
        }
        let mut stack = [0u32; STACK];
        let mut sp = 0;
        let mut node = root;
        loop {
            if node.is_leaf() {
                let first = node.index as usize;
                let last = first + node.count as usize;
                for &[a, b, c] in &self.tris[first..last] {
                    if intersect_triangle(ray.origin, ray.dir, ray.tmin, tmax, a, b, c).is_some() {
                        return true;
                    }
                }
            } else {
                let pair = node.index;
                let [l, r] = &self.pairs[pair as usize].nodes;
                match (rb.enter(l, tmax), rb.enter(r, tmax)) {
                    (Some(tl), Some(tr)) => {
                        // Nearer first: the first surface along the ray ends the search soonest.
                        let (near, far_slot) = if tl <= tr { (l, 1) } else { (r, 0) };
                        stack[sp] = pair * 2 + far_slot;
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            let id = stack[sp];
            node = &self.pairs[(id >> 1) as usize].nodes[(id & 1) as usize];
        }
    }
}
