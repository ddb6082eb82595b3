//! Closest-hit and any-hit traversal of the 4-wide tree.
//!
//! At a node the ray is tested against all four child boxes at once (`Vec4` lanes). One hit
//! child is entered directly; with several, they are sorted by entry distance, the nearest is
//! entered and the others are pushed (farthest first) with their entry distance, which
//! closest-hit checks again when it pops them: anything starting beyond the closest hit so far
//! is skipped. Any-hit uses the same nearest-first order and stops at the first hit.
//!
//! The slab test picks each axis' near and far planes from the direction's sign, and is written
//! so that the NaN of `0 · ∞` (a ray with a zero direction component lying in a box's plane)
//! leaves the interval unchanged, i.e. counts as inside that slab: `t.max(acc)` returns `acc`
//! when `t` is NaN both for SSE2 `maxps` and for the scalar `f32::max` fallback. The exit
//! distance is widened by a few ulps (Ize 2013) so rounding cannot cull a box the exact ray
//! touches.

use glam::{Vec3, Vec4};

use super::Bvh;
use super::build::MAX_DEPTH;
use super::wide::{ChildRef, Node4};
use crate::accel::Hit;
use crate::geometry::{Ray, intersect_triangle};

/// Widening of the exit distance: 1 + 2γ₃ rounded up generously.
const EXIT_SCALE: f32 = 1.0 + 1e-6;
/// Each level pushes at most three children; the binary depth bounds the wide depth.
const STACK: usize = 3 * MAX_DEPTH + 4;

/// A ray prepared for box tests: origin and inverse direction splatted over four lanes.
struct RayBoxes {
    o: [Vec4; 3],
    inv: [Vec4; 3],
    neg: [bool; 3],
    tmin: f32,
}

impl RayBoxes {
    #[inline]
    fn new(ray: &Ray) -> Self {
        // 1 / ±0 = ±∞: the slab then spans everything or nothing, as it should.
        let inv = Vec3::ONE / ray.dir;
        let o = ray.origin;
        RayBoxes {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            inv: [Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z)],
            neg: [ray.dir.x.is_sign_negative(), ray.dir.y.is_sign_negative(), ray.dir.z.is_sign_negative()],
            tmin: ray.tmin,
        }
    }

    /// Which of `n`'s four boxes the ray enters within `(tmin, tmax)` (bit per lane), and the
    /// entry distances.
    #[inline(always)]
    fn enter(&self, n: &Node4, tmax: f32) -> (u32, [f32; 4]) {
        let mut entry = Vec4::splat(self.tmin);
        let mut exit = Vec4::splat(tmax);
        for a in 0..3 {
            let (near, far) = if self.neg[a] { (n.max[a], n.min[a]) } else { (n.min[a], n.max[a]) };
            let t0 = (near - self.o[a]) * self.inv[a];
            let t1 = (far - self.o[a]) * self.inv[a];
            // NaN in t0 / t1 keeps the accumulated value (see the module docs).
            entry = t0.max(entry);
            exit = t1.min(exit);
        }
        (entry.cmple(exit * EXIT_SCALE).bitmask(), entry.to_array())
    }
}

/// Pushes all hit children of `n` (lanes in `mask`, at least two) on the stack, farthest first,
/// and returns the nearest one, which is not pushed.
#[inline(always)]
fn push_sorted(
    n: &Node4,
    mut mask: u32,
    entry: &[f32; 4],
    stack: &mut [(ChildRef, f32); STACK],
    sp: &mut usize,
) -> ChildRef {
    let mut hits = [(0.0f32, ChildRef::default()); 4];
    let mut k = 0;
    while mask != 0 {
        let lane = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        // Insertion sort, farthest first.
        let item = (entry[lane], n.child[lane]);
        let mut j = k;
        while j > 0 && hits[j - 1].0 < item.0 {
            hits[j] = hits[j - 1];
            j -= 1;
        }
        hits[j] = item;
        k += 1;
    }
    for &(t, c) in &hits[..k - 1] {
        stack[*sp] = (c, t);
        *sp += 1;
    }
    hits[k - 1].1
}

impl Bvh {
    /// The closest hit of a valid ray.
    pub(super) fn closest_hit(&self, ray: &Ray) -> Option<Hit> {
        let rb = RayBoxes::new(ray);
        let mut best: Option<Hit> = None;
        let mut tmax = ray.tmax;
        let mut stack = [(ChildRef::default(), 0f32); STACK];
        let mut sp = 0;
        let mut cur = ChildRef { index: 0, count: 0 };
        loop {
            if cur.is_leaf() {
                let first = cur.index as usize;
                let last = first + cur.count as usize;
                for (tri, &id) in self.tris[first..last].iter().zip(&self.prim_ids[first..last]) {
                    let [a, b, c] = *tri;
                    if let Some(h) = intersect_triangle(ray.origin, ray.dir, ray.tmin, tmax, a, b, c) {
                        tmax = h.t;
                        best = Some(Hit { t: h.t, prim: id, u: h.u, v: h.v });
                    }
                }
            } else {
                let n = &self.nodes[cur.index as usize];
                let (mask, entry) = rb.enter(n, tmax);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        n.child[mask.trailing_zeros() as usize]
                    } else {
                        push_sorted(n, mask, &entry, &mut stack, &mut sp)
                    };
                    continue;
                }
            }
            // Pop the next child that starts before the closest hit.
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, t) = stack[sp];
                if t <= tmax * EXIT_SCALE {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Whether a valid ray hits anything.
    pub(super) fn any_hit(&self, ray: &Ray) -> bool {
        let rb = RayBoxes::new(ray);
        let tmax = ray.tmax;
        let mut stack = [(ChildRef::default(), 0f32); STACK];
        let mut sp = 0;
        let mut cur = ChildRef { index: 0, count: 0 };
        loop {
            if cur.is_leaf() {
                let first = cur.index as usize;
                let last = first + cur.count as usize;
                for &[a, b, c] in &self.tris[first..last] {
                    if intersect_triangle(ray.origin, ray.dir, ray.tmin, tmax, a, b, c).is_some() {
                        return true;
                    }
                }
            } else {
                let n = &self.nodes[cur.index as usize];
                let (mask, entry) = rb.enter(n, tmax);
                if mask != 0 {
                    cur = if mask & (mask - 1) == 0 {
                        n.child[mask.trailing_zeros() as usize]
                    } else {
                        push_sorted(n, mask, &entry, &mut stack, &mut sp)
                    };
                    continue;
                }
            }
            if sp == 0 {
                return false;
            }
            sp -= 1;
            cur = stack[sp].0;
        }
    }
}
