//! Binned-SAH construction of the BVH2 and its flattening into sibling pairs.
//!
//! Each node's primitives are binned on their centroids into [`BINS`] bins along each axis; the
//! split with the lowest surface-area-heuristic cost (`C_TRAV + Σ area·count / area`) wins, or a
//! leaf is made when that is cheaper than intersecting every triangle (up to [`MAX_LEAF`]).
//! Nodes whose centroids all coincide are split in the middle of their range so that leaves stay
//! small, and the depth is capped at [`MAX_DEPTH`] so that traversal's fixed stack cannot
//! overflow. Subtrees with many primitives are built in parallel with rayon and stitched
//! together afterwards.

use glam::Vec3;

use super::{Node, NodePair};
use crate::geometry::Aabb;

/// Centroid bins per axis.
const BINS: usize = 32;
/// Most triangles in a leaf (unless the depth cap or coincident centroids force more).
pub(super) const MAX_LEAF: usize = 8;
/// Cost of a box test pair relative to one triangle test, for the SAH.
const C_TRAV: f32 = 1.0;
/// Deepest node; traversal's stack holds `MAX_DEPTH + 2` entries.
pub(super) const MAX_DEPTH: usize = 60;
/// Ranges at least this large are built on two rayon tasks.
const PARALLEL_MIN: usize = 16 * 1024;

/// The product of a build: sibling pairs (pair 0 holds the root in slot 0) and the order of the
/// primitives in the leaves.
pub(super) struct Built {
    pub pairs: Vec<NodePair>,
    pub order: Vec<u32>,
    pub leaves: usize,
    pub depth: usize,
}

/// Builds over primitives with the given (padded) bounds and centroids. Primitives listed in
/// `prims` are the ones that take part (callers leave out non-finite triangles).
pub(super) fn build(bounds: &[Aabb], centroids: &[Vec3], mut prims: Vec<u32>) -> Built {
    let ctx = Ctx { bounds, centroids };
    let mut root_pair = NodePair::default();
    if prims.is_empty() {
        // An empty leaf whose box no ray enters.
        root_pair.nodes[0] = Node::leaf(Aabb::EMPTY, 0, 0);
        return Built { pairs: vec![root_pair], order: prims, leaves: 1, depth: 0 };
    }
    let root_bounds = ctx.range_bounds(&prims);
    let sub = ctx.subtree(&mut prims, 0, root_bounds, 0);
    root_pair.nodes[0] = sub.root.shifted(1);
    let mut pairs = Vec::with_capacity(sub.pairs.len() + 1);
    pairs.push(root_pair);
    append_shifted(&mut pairs, sub.pairs);
    Built { pairs, order: prims, leaves: sub.leaves, depth: sub.depth }
}

/// A subtree built on its own: its root node and its pairs, with child links (the root's too)
/// relative to the start of `pairs`; leaf ranges are final.
struct Subtree {
    root: Node,
    pairs: Vec<NodePair>,
    leaves: usize,
    depth: usize,
}

/// Appends `sub` to `pairs`, shifting its relative child links by the insertion point.
fn append_shifted(pairs: &mut Vec<NodePair>, sub: Vec<NodePair>) {
    let base = pairs.len() as u32;
    pairs.extend(sub.into_iter().map(|mut p| {
        p.nodes = p.nodes.map(|n| n.shifted(base));
        p
    }));
}

struct Ctx<'a> {
    bounds: &'a [Aabb],
    centroids: &'a [Vec3],
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Aabb,
    count: u32,
}

/// A chosen split: the axis, the first bin on the right, and the two children's bounds.
struct Split {
    axis: usize,
    bin: usize,
    left: Aabb,
    right: Aabb,
    cost: f32,
    /// Binning parameters: centroid minimum on `axis` and bins per unit length.
    min: f32,
    scale: f32,
}

impl Ctx<'_> {
    fn range_bounds(&self, prims: &[u32]) -> Aabb {
        prims.iter().fold(Aabb::EMPTY, |b, &p| b.union(self.bounds[p as usize]))
    }

    /// Builds the subtree over `prims`, whose first element sits at `offset` in the final order.
    fn subtree(&self, prims: &mut [u32], offset: usize, bounds: Aabb, depth: usize) -> Subtree {
        let n = prims.len();
        let leaf = || Subtree {
            root: Node::leaf(bounds, offset as u32, n as u32),
            pairs: Vec::new(),
            leaves: 1,
            depth,
        };
        if n <= 2 || depth >= MAX_DEPTH {
            return leaf();
        }
        let (mid, lb, rb) = match self.best_split(prims, bounds) {
            Some(s) if s.cost < n as f32 || n > MAX_LEAF => {
                let mid = self.partition(prims, &s);
                (mid, s.left, s.right)
            }
            // The SAH prefers a leaf and the leaf is small enough.
            Some(_) => return leaf(),
            None if n <= MAX_LEAF => return leaf(),
            // Coincident centroids: split the range in the middle.
            None => {
                let mid = n / 2;
                (mid, self.range_bounds(&prims[..mid]), self.range_bounds(&prims[mid..]))
            }
        };
        let (lp, rp) = prims.split_at_mut(mid);
        let (l, r) = if n >= PARALLEL_MIN {
            rayon::join(
                || self.subtree(lp, offset, lb, depth + 1),
                || self.subtree(rp, offset + mid, rb, depth + 1),
            )
        } else {
            (self.subtree(lp, offset, lb, depth + 1), self.subtree(rp, offset + mid, rb, depth + 1))
        };
        // Layout (depth-first over pairs): [children pair][left subtree][right subtree].
        // Child links are relative to the start of each subtree's own pairs.
        let mut pairs = Vec::with_capacity(1 + l.pairs.len() + r.pairs.len());
        pairs.push(NodePair { nodes: [l.root.shifted(1), r.root.shifted(1 + l.pairs.len() as u32)] });
        append_shifted(&mut pairs, l.pairs);
        append_shifted(&mut pairs, r.pairs);
        Subtree {
            root: Node::interior(bounds, 0),
            pairs,
            leaves: l.leaves + r.leaves,
            depth: l.depth.max(r.depth),
        }
    }

    /// The best binned-SAH split, in units of triangle tests relative to this node's area, or
    /// `None` when all centroids coincide.
    fn best_split(&self, prims: &[u32], bounds: Aabb) -> Option<Split> {
        let cb = prims.iter().fold(Aabb::EMPTY, |b, &p| b.grow(self.centroids[p as usize]));
        let ext = cb.max - cb.min;
        let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
        let mut best: Option<Split> = None;
        for axis in 0..3 {
            if ext[axis] <= 0.0 || ext[axis].is_nan() {
                continue;
            }
            let scale = BINS as f32 / ext[axis];
            let mut bins = [Bin { bounds: Aabb::EMPTY, count: 0 }; BINS];
            for &p in prims {
                let b = &mut bins[bin_of(self.centroids[p as usize][axis], cb.min[axis], scale)];
                b.bounds = b.bounds.union(self.bounds[p as usize]);
                b.count += 1;
            }
            // Sweep from the right: cost of the right side for each split position.
            let mut right_cost = [0.0f32; BINS];
            let mut right_bounds = [Aabb::EMPTY; BINS];
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0u32);
            for i in (1..BINS).rev() {
                acc = acc.union(bins[i].bounds);
                cnt += bins[i].count;
                right_bounds[i] = acc;
                right_cost[i] = acc.half_area() * cnt as f32;
            }
            let (mut acc, mut cnt) = (Aabb::EMPTY, 0u32);
            for i in 1..BINS {
                acc = acc.union(bins[i - 1].bounds);
                cnt += bins[i - 1].count;
                if cnt == 0 || cnt as usize == prims.len() {
                    continue;
                }
                let cost = C_TRAV + (acc.half_area() * cnt as f32 + right_cost[i]) / parent_area;
                if best.as_ref().is_none_or(|b| cost < b.cost) {
                    best = Some(Split {
                        axis,
                        bin: i,
                        left: acc,
                        right: right_bounds[i],
                        cost,
                        min: cb.min[axis],
                        scale,
                    });
                }
            }
        }
        best
    }

    /// Moves the primitives left of the split to the front; returns how many there are.
    fn partition(&self, prims: &mut [u32], s: &Split) -> usize {
        let goes_left = |p: u32| bin_of(self.centroids[p as usize][s.axis], s.min, s.scale) < s.bin;
        let mut i = 0;
        let mut j = prims.len();
        while i < j {
            if goes_left(prims[i]) {
                i += 1;
            } else {
                j -= 1;
                prims.swap(i, j);
            }
        }
        i
    }
}

/// The bin of centroid coordinate `c`; the same function decides binning and partitioning.
#[inline]
fn bin_of(c: f32, min: f32, scale: f32) -> usize {
    (((c - min) * scale) as usize).min(BINS - 1)
}
