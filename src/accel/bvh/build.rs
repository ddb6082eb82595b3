//! Binned-SAH construction of the BVH2 and its flattening into sibling pairs.
//!
//! Each node's primitives are binned on their centroids into [`BINS`] bins along all three axes
//! in one pass; the split with the lowest surface-area-heuristic cost
//! (`C_TRAV + Σ area·⌈count/4⌉ / area`, in units of tests of a pack of four triangles) wins,
//! or a leaf is made when that is cheaper than intersecting its packs (up to [`MAX_LEAF`]
//! triangles). Nodes whose centroids all coincide are
//! split in the middle of their range so that leaves stay small, and the depth is capped at
//! [`MAX_DEPTH`]. Primitive records (box and id, SIMD-aligned `Vec3A`) are partitioned in
//! place, so every pass reads memory sequentially; the partition also bounds both sides'
//! centroids, which the children's binning needs, so a node costs two passes over its
//! primitives (binning, partition). The partition is branch-free (which side a record goes to
//! is as good as random). The sequential recursion bins into one workspace and resets only the
//! bins a node uses. Subtrees with many primitives are built in parallel with rayon; their
//! pairs stay in per-task segments, laid out once at the end by a parallel copy.
//!
//! Large nodes (the top levels, where the two subtrees are not yet running on their own
//! threads) are also binned and partitioned in parallel: their primitives are cut into chunks
//! of [`CHUNK`] records, each chunk is binned on a rayon task (by runs of one bin: see
//! [`bin_runs`]) and the bins are merged (exact: minima, maxima and integer counts), and the
//! partition is one stable scatter of each chunk's left and right parts, to offsets from the
//! chunks' own bin counts, into the other of two buffers allocated for the whole build. The
//! children stay in the buffer they were written to and are partitioned from there into the
//! first one, and so on down; a range copies its primitives back once, when it becomes too
//! small to be partitioned in parallel (see [`subtree`]). Chunk size and thresholds are
//! constants, so the tree is the same whatever the number of threads.
//!
//! Leaves hold up to [`MAX_LEAF`] = 8 triangles, twice Embree's four: the tree's surface-area
//! sum is then a little above Embree's, all of it in the leaves, but the AVX versions of the
//! traversal test a two-pack leaf at once, and leaves of four traced no faster. Large
//! triangles are not split (no SBVH): on the conference room even Embree's spatial splits gain
//! it only 2–3 %, and the room's gap to Embree lies in the traversal's order, not in the tree
//! (see `traverse.rs`).
//!
//! Measurements of these choices and of the alternatives tried and not kept (two sets of bins,
//! the 2²³ trick, ping-pong at every level, `C_TRAV`, leaf costs, leaves of four, splitting
//! large triangles): `docs/accel/build.md`.

use glam::{BVec3A, BVec4A, Vec3A, Vec4};
use rayon::prelude::*;

use super::pages::Pages;
use super::{Node, NodePair};
use crate::geometry::Aabb;

/// Centroid bins per axis for large nodes; small nodes use fewer (see [`bins_for`]).
const BINS: usize = 32;
/// Most triangles in a leaf (unless the depth cap or coincident centroids force more).
pub(super) const MAX_LEAF: usize = 8;
/// Cost of a box test relative to one test of a pack of four triangles, for the SAH.
const C_TRAV: f32 = 1.0;
/// Deepest node of the binary tree; it bounds the traversal stack.
pub(super) const MAX_DEPTH: usize = 60;
/// Ranges at least this large are built on two rayon tasks.
const PARALLEL_MIN: usize = 16 * 1024;
/// Nodes with at least this many primitives are binned and partitioned in chunks in parallel.
const PARALLEL_PASS_MIN: usize = 64 * 1024;
/// Items below which a parallel iterator runs on the calling thread: a split hands work to
/// the thread pool, which costs more than a small build (tens of microseconds).
pub(super) const SMALL: usize = 4096;
/// Primitives per chunk of a parallel pass (a constant: the result must not depend on the
/// thread count).
const CHUNK: usize = 16 * 1024;

/// A box in SIMD-friendly form.
#[derive(Clone, Copy, Debug)]
struct Box3 {
    min: Vec3A,
    max: Vec3A,
}

impl Box3 {
    const EMPTY: Box3 = Box3 { min: Vec3A::INFINITY, max: Vec3A::NEG_INFINITY };

    #[inline]
    fn union(self, o: Box3) -> Box3 {
        Box3 { min: self.min.min(o.min), max: self.max.max(o.max) }
    }

    #[inline]
    fn grow(self, p: Vec3A) -> Box3 {
        Box3 { min: self.min.min(p), max: self.max.max(p) }
    }

    /// `self` grown by `p` where `m` is set, unchanged elsewhere (without a branch).
    #[inline]
    fn grow_where(self, m: BVec3A, p: Vec3A) -> Box3 {
        Box3 {
            min: Vec3A::select(m, self.min.min(p), self.min),
            max: Vec3A::select(m, self.max.max(p), self.max),
        }
    }

    /// Half the surface area; 0 for an empty box.
    #[inline]
    fn half_area(self) -> f32 {
        let e = (self.max - self.min).max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    fn aabb(self) -> Aabb {
        Aabb { min: self.min.into(), max: self.max.into() }
    }
}

/// One primitive as the builder sees it: its (padded) box and its index, in 32 bytes (the
/// index's bits ride in the fourth lane of the minimum, which no arithmetic touches): every
/// level of the build streams all primitives through memory, so their size matters.
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct Prim {
    min_id: Vec4,
    max: Vec3A,
}

impl Prim {
    pub fn new(bounds: Aabb, id: u32) -> Self {
        Prim { min_id: bounds.min.extend(f32::from_bits(id)), max: bounds.max.into() }
    }

    /// The minimum with the index bits cleared (a bit mask, not arithmetic: the bits may
    /// read as a subnormal float, which arithmetic can be slow on).
    #[inline]
    fn min(&self) -> Vec3A {
        Vec3A::from_vec4(Vec4::select(BVec4A::new(true, true, true, false), self.min_id, Vec4::ZERO))
    }

    /// Whether the box is empty (the mark of a triangle left out).
    pub fn is_empty(&self) -> bool {
        self.min_id.x > self.max.x
    }

    #[inline]
    fn bounds(&self) -> Box3 {
        Box3 { min: self.min(), max: self.max }
    }

    #[inline]
    fn id(&self) -> u32 {
        self.min_id.w.to_bits()
    }

    /// Twice the centroid (the factor does not matter for binning).
    #[inline]
    fn centroid2(&self) -> Vec3A {
        self.min() + self.max
    }
}

/// A leaf's pack of up to four triangles: its first position in the leaf order and its
/// triangles.
pub(super) type PackRange = (u32, u32);

/// The product of a build: sibling pairs (pair 0 holds the root in slot 0), whose leaves refer
/// to their packs (`index`: first pack, `count`: packs), the packs, leaf by leaf in the
/// triangle order, and the order of the primitives in the leaves.
pub(super) struct Built {
    pub pairs: Vec<NodePair>,
    pub packs: Vec<PackRange>,
    pub order: Vec<u32>,
    pub leaves: usize,
    pub depth: usize,
}

/// Builds over `prims` (callers leave out triangles with non-finite vertices).
pub(super) fn build(prims: &mut [Prim]) -> Built {
    let mut root_pair = NodePair::default();
    if prims.is_empty() {
        // An empty leaf whose box no ray enters.
        root_pair.nodes[0] = Node::leaf(Aabb::EMPTY, 0, 0);
        return Built { pairs: vec![root_pair], packs: Vec::new(), order: Vec::new(), leaves: 1, depth: 0 };
    }
    let root = Bounds::of(prims);
    // The parallel partitions' other buffer, allocated once for the whole build (on huge
    // pages when large, like the primitives: see `Bvh::new`).
    let mut scratch = Pages::<Prim>::zeroed(if prims.len() >= PARALLEL_PASS_MIN { prims.len() } else { 0 });
    let sub = subtree(prims, &mut scratch, false, 0, root, 0);
    // The first segment's packs start at 0.
    root_pair.nodes[0] = sub.root.shifted(1, 0);
    let (pairs, packs) = flatten(root_pair, &sub.segments);
    let order = prims.par_iter().with_min_len(SMALL).map(Prim::id).collect();
    Built { pairs, packs, order, leaves: sub.leaves, depth: sub.depth }
}

/// Pairs and leaf packs built on one task, laid out after those of the tasks before it. Its
/// child links are relative to the start of its pairs and its leaves' packs to the start of its
/// packs.
struct Segment {
    pairs: Vec<NodePair>,
    packs: Vec<PackRange>,
}

/// A subtree built on its own: its root node and its segments, to be laid out one after the
/// other (depth-first); the root's link is relative to the first segment's start (pairs and
/// packs). Leaves' triangle ranges are final.
struct Subtree {
    root: Node,
    segments: Vec<Segment>,
    /// Pairs in all segments.
    len: usize,
    /// Packs in all segments.
    packs: usize,
    leaves: usize,
    depth: usize,
}

impl Subtree {
    /// A subtree built in one segment; its sizes are the segment's.
    fn single(root: Node, segment: Segment, leaves: usize, depth: usize) -> Subtree {
        let (len, packs) = (segment.pairs.len(), segment.packs.len());
        Subtree { root, segments: vec![segment], len, packs, leaves, depth }
    }
}

/// The root's pair followed by the segments' pairs, and all the segments' packs, with their
/// links made absolute, copied in parallel: stitching subtrees by copying their pairs at every
/// join put a copy of all pairs on one thread at the top join (and of half of them at the next
/// level, and so on), and assigning the leaves their packs by a walk of the whole tree was
/// sequential too.
fn flatten(root_pair: NodePair, segments: &[Segment]) -> (Vec<NodePair>, Vec<PackRange>) {
    // Where each segment's pairs and packs start; pair 0 is the root's.
    let (mut pair_at, mut pack_at) = (Vec::with_capacity(segments.len()), Vec::with_capacity(segments.len()));
    let (mut pairs, mut packs) = (1, 0);
    for s in segments {
        pair_at.push(pairs);
        pack_at.push(packs);
        pairs += s.pairs.len();
        packs += s.packs.len();
    }
    // The last segment starting at or before `g` (empty segments share their start with the
    // next one, which comes later in the list).
    let find = |starts: &[usize], g: usize| starts.partition_point(|&s| s <= g) - 1;
    let pairs = (0..pairs)
        .into_par_iter()
        .with_min_len(SMALL)
        .map(|g| {
            if g == 0 {
                return root_pair;
            }
            let k = find(&pair_at, g);
            let mut p = segments[k].pairs[g - pair_at[k]];
            p.nodes = p.nodes.map(|n| n.shifted(pair_at[k] as u32, pack_at[k] as u32));
            p
        })
        .collect();
    let packs = (0..packs)
        .into_par_iter()
        .with_min_len(SMALL)
        .map(|g| {
            let k = find(&pack_at, g);
            segments[k].packs[g - pack_at[k]]
        })
        .collect();
    (pairs, packs)
}

/// Pairs and packs built sequentially (see [`build_into`]).
struct Seq {
    segment: Segment,
    leaves: usize,
    depth: usize,
}

/// A leaf over the `n` primitives from `offset`, its packs appended to `packs`, which it
/// refers to from the list's start.
fn leaf(b: Box3, offset: usize, n: usize, packs: &mut Vec<PackRange>) -> Node {
    let first = packs.len();
    packs.extend((offset..offset + n).step_by(4).map(|p| (p as u32, (offset + n - p).min(4) as u32)));
    Node::leaf(b.aabb(), first as u32, n.div_ceil(4) as u32)
}

/// A node's bounds: of its primitives' boxes and of their doubled centroids (which binning
/// needs; the partition computes the children's, saving a pass over their primitives).
#[derive(Clone, Copy)]
struct Bounds {
    prims: Box3,
    centroids: Box3,
}

impl Bounds {
    /// The bounds of `prims`, in one pass (in parallel chunks for many).
    fn of(prims: &[Prim]) -> Bounds {
        let union = |a: Bounds, b: Bounds| Bounds {
            prims: a.prims.union(b.prims),
            centroids: a.centroids.union(b.centroids),
        };
        let empty = Bounds { prims: Box3::EMPTY, centroids: Box3::EMPTY };
        if prims.len() >= PARALLEL_PASS_MIN {
            return prims.par_chunks(CHUNK).map(Bounds::of).reduce(|| empty, union);
        }
        prims.iter().fold(empty, |b, p| Bounds {
            prims: b.prims.union(p.bounds()),
            centroids: b.centroids.grow(p.centroid2()),
        })
    }
}

/// A split node: the size of the left part, both children's bounds, and whether the children's
/// primitives were written to the other buffer (a parallel partition) or stayed in place.
struct Parts {
    mid: usize,
    left: Bounds,
    right: Bounds,
    moved: bool,
}

#[derive(Clone, Copy)]
struct Bin {
    bounds: Box3,
    count: u32,
}

impl Bin {
    /// Adds `count` primitives whose boxes are bounded by `bounds`.
    #[inline]
    fn add(&mut self, bounds: Box3, count: u32) {
        self.bounds = self.bounds.union(bounds);
        self.count += count;
    }
}

/// A chosen split: the axis, the first bin on the right, and the two children's bounds.
struct Split {
    axis: usize,
    bin: usize,
    left: Box3,
    right: Box3,
    cost: f32,
    /// Binning parameters: doubled-centroid minimum, bins per unit length (per axis), bins.
    min: Vec3A,
    scale: Vec3A,
    bins: usize,
    /// For a node binned in parallel chunks: each chunk's counts per axis and bin, in chunk
    /// order (empty otherwise). The parallel partition places each chunk's primitives from
    /// them.
    chunks: Vec<ChunkCounts>,
}

/// One chunk's primitives per axis and bin.
type ChunkCounts = [[u32; BINS]; 3];

type Bins = [[Bin; BINS]; 3];
const EMPTY_BINS: Bins = [[Bin { bounds: Box3::EMPTY, count: 0 }; BINS]; 3];

/// Bins `prims` on all three axes into the first `nb` bins of each axis of `bins` (`nb` bins
/// from `min`, `scale` bins per unit); the other bins are left as they are. Filling the
/// caller's bins, and resetting only those used, spares small nodes copying all [`BINS`].
/// Nodes of [`PARALLEL_PASS_MIN`] primitives or more are binned in chunks of [`CHUNK`] in
/// parallel (all of `bins` is then reset and merged into), and each chunk's counts are
/// returned (in chunk order) for the partition; for others the list is empty.
fn bin_prims(prims: &[Prim], min: Vec3A, scale: Vec3A, nb: usize, bins: &mut Bins) -> Vec<ChunkCounts> {
    if prims.len() >= PARALLEL_PASS_MIN {
        let per_chunk: Vec<Bins> = prims
            .par_chunks(CHUNK)
            .map(|c| {
                let mut b = EMPTY_BINS;
                bin_runs(c, min, scale, nb, &mut b);
                b
            })
            .collect();
        *bins = EMPTY_BINS;
        for b in &per_chunk {
            for (aa, ba) in bins.iter_mut().zip(b) {
                for (x, y) in aa.iter_mut().zip(ba) {
                    x.add(y.bounds, y.count);
                }
            }
        }
        return per_chunk.iter().map(|b| b.map(|axis| axis.map(|bin| bin.count))).collect();
    }
    for axis_bins in bins.iter_mut() {
        axis_bins[..nb].fill(EMPTY_BINS[0][0]);
    }
    for p in prims {
        let idx = bin_index(p.centroid2(), min, scale, nb);
        for (axis, axis_bins) in bins.iter_mut().enumerate() {
            let b = &mut axis_bins[idx[axis]];
            b.add(p.bounds(), 1);
        }
    }
    Vec::new()
}

/// Bins `prims` as [`bin_prims`] does, for primitives in the mesh's order, which the top
/// levels see (the parallel partition is stable): consecutive primitives mostly fall in the
/// same bins, and a bin updated in memory right after the previous update of the same bin
/// stalls the loop, so each axis accumulates its current run of one bin in registers and adds
/// it to the bin when the run ends (the same bins: minima, maxima and counts are exact). On
/// the 1M-triangle scene's top levels it took 0.75 of the time of updating the bins
/// primitive by primitive; below them, where the in-place partition has shuffled the
/// primitives, it was slower.
fn bin_runs(prims: &[Prim], min: Vec3A, scale: Vec3A, nb: usize, bins: &mut Bins) {
    // Per axis: the run's bin (`usize::MAX` before the first), bounds and count.
    let mut run = [(usize::MAX, Box3::EMPTY, 0u32); 3];
    let flush = |bins: &mut Bins, axis: usize, (bin, bounds, count): (usize, Box3, u32)| {
        if bin != usize::MAX {
            let b = &mut bins[axis][bin];
            b.add(bounds, count);
        }
    };
    for p in prims {
        let idx = bin_index(p.centroid2(), min, scale, nb);
        let pb = p.bounds();
        for axis in 0..3 {
            let r = &mut run[axis];
            if idx[axis] == r.0 {
                r.1 = r.1.union(pb);
                r.2 += 1;
            } else {
                flush(bins, axis, *r);
                *r = (idx[axis], pb, 1);
            }
        }
    }
    for (axis, r) in run.into_iter().enumerate() {
        flush(bins, axis, r);
    }
}

/// Where to split the node over `prims` (partitioning them), or `None` for a leaf. `scratch`
/// is as long as `prims` for nodes partitioned in parallel, which write the children's
/// primitives there ([`Parts::moved`]); others partition in place and leave it unused.
/// `bins` is a workspace (its contents do not matter).
fn choose_split(
    prims: &mut [Prim],
    scratch: &mut [Prim],
    bins: &mut Bins,
    b: Bounds,
    depth: usize,
) -> Option<Parts> {
    let n = prims.len();
    // A split costs more than C_TRAV = one pack test, which is what a leaf of up to four costs:
    // such nodes are always leaves, without binning them.
    if n <= 4 || depth >= MAX_DEPTH {
        return None;
    }
    match best_split(prims, b, bins) {
        Some(s) if s.cost < leaf_cost(n) || n > MAX_LEAF => {
            let moved = n >= PARALLEL_PASS_MIN;
            let (mid, lc, rc) =
                if moved { partition_parallel(prims, scratch, &s) } else { partition(prims, &s) };
            Some(Parts {
                mid,
                left: Bounds { prims: s.left, centroids: lc },
                right: Bounds { prims: s.right, centroids: rc },
                moved,
            })
        }
        // The SAH prefers a leaf and the leaf is small enough.
        Some(_) => None,
        None if n <= MAX_LEAF => None,
        // Coincident centroids: split the range in the middle.
        None => {
            let mid = n / 2;
            Some(Parts {
                mid,
                left: Bounds::of(&prims[..mid]),
                right: Bounds::of(&prims[mid..]),
                moved: false,
            })
        }
    }
}

/// Builds the subtree over the range `home` of the build's primitives, whose first element
/// sits at `offset` in the final order: large ranges as two rayon tasks whose segment lists
/// are joined, small ones sequentially into one segment. The range's primitives are in
/// `away` (the other buffer, as long as `home` for ranges partitioned in parallel) when
/// `in_away`, else in `home`; a parallel partition writes the children's primitives to the
/// buffer they are not in, and a range copies them back to `home` once, before it is
/// partitioned in place, so they all end up there (in the leaves' order).
fn subtree(
    home: &mut [Prim],
    away: &mut [Prim],
    in_away: bool,
    offset: usize,
    b: Bounds,
    depth: usize,
) -> Subtree {
    let n = home.len();
    if in_away && n < PARALLEL_PASS_MIN {
        home.copy_from_slice(away);
        return subtree(home, &mut [], false, offset, b, depth);
    }
    let (prims, scratch) = if in_away { (away, home) } else { (home, away) };
    if n < PARALLEL_MIN {
        let mut seq = Seq { segment: Segment { pairs: Vec::new(), packs: Vec::new() }, leaves: 0, depth };
        let mut bins = EMPTY_BINS;
        let root = build_into(prims, offset, b, depth, &mut seq, &mut bins);
        return Subtree::single(root, seq.segment, seq.leaves, seq.depth);
    }
    let Some(Parts { mid, left, right, moved }) = choose_split(prims, scratch, &mut { EMPTY_BINS }, b, depth)
    else {
        if in_away {
            scratch.copy_from_slice(prims);
        }
        let mut packs = Vec::new();
        let root = leaf(b.prims, offset, n, &mut packs);
        return Subtree::single(root, Segment { pairs: Vec::new(), packs }, 1, depth);
    };
    let (home, away) = if in_away { (scratch, prims) } else { (prims, scratch) };
    // Where the children's primitives are now: moved to the other buffer, or in place.
    let in_away = in_away != moved;
    let (lh, rh) = home.split_at_mut(mid);
    let (la, ra) = if away.is_empty() { (&mut [][..], &mut [][..]) } else { away.split_at_mut(mid) };
    let (l, r) = rayon::join(
        || subtree(lh, la, in_away, offset, left, depth + 1),
        || subtree(rh, ra, in_away, offset + mid, right, depth + 1),
    );
    // Layout (depth-first over pairs): [children pair][left subtree][right subtree]. The
    // children pair is a segment of its own, without packs, so its links are relative to its
    // start: the left subtree's packs start where its own do.
    let mut segments = Vec::with_capacity(1 + l.segments.len() + r.segments.len());
    let nodes = [l.root.shifted(1, 0), r.root.shifted(1 + l.len as u32, l.packs as u32)];
    segments.push(Segment { pairs: vec![NodePair { nodes }], packs: Vec::new() });
    segments.extend(l.segments);
    segments.extend(r.segments);
    Subtree {
        root: Node::interior(b.prims.aabb(), 0),
        segments,
        len: 1 + l.len + r.len,
        packs: l.packs + r.packs,
        leaves: l.leaves + r.leaves,
        depth: l.depth.max(r.depth),
    }
}

/// Builds sequentially, appending pairs depth-first to `out.segment.pairs` and leaf packs to
/// `out.segment.packs` (links relative to their starts); returns the node.
/// `bins` is a workspace shared by the whole recursion.
fn build_into(
    prims: &mut [Prim],
    offset: usize,
    b: Bounds,
    depth: usize,
    out: &mut Seq,
    bins: &mut Bins,
) -> Node {
    // Sequential subtrees are below the size of a parallel pass, which needs `scratch`.
    debug_assert!(prims.len() < PARALLEL_PASS_MIN);
    let Some(Parts { mid, left, right, .. }) = choose_split(prims, &mut [], bins, b, depth) else {
        out.leaves += 1;
        out.depth = out.depth.max(depth);
        return leaf(b.prims, offset, prims.len(), &mut out.segment.packs);
    };
    let at = out.segment.pairs.len();
    out.segment.pairs.push(NodePair::default());
    let (lp, rp) = prims.split_at_mut(mid);
    let l = build_into(lp, offset, left, depth + 1, out, bins);
    let r = build_into(rp, offset + mid, right, depth + 1, out, bins);
    out.segment.pairs[at].nodes = [l, r];
    Node::interior(b.prims.aabb(), at as u32)
}

/// The best binned-SAH split, in units of triangle tests, or `None` when all centroids
/// coincide.
fn best_split(prims: &[Prim], b: Bounds, bins: &mut Bins) -> Option<Split> {
    let (bounds, cb) = (b.prims, b.centroids);
    let ext = cb.max - cb.min;
    // Axes without extent get scale 0: everything lands in bin 0 and no split is proposed.
    let nb = bins_for(prims.len());
    let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), Vec3A::splat(nb as f32) / ext, Vec3A::ZERO);
    let chunks = bin_prims(prims, cb.min, scale, nb, bins);
    // The sweeps look for the lowest cost only (weighted by area, before the division by the
    // parent's, which keeps the order); the winner's two boxes are gathered from its bins
    // afterwards.
    let n = prims.len() as u32;
    let (mut best_cost, mut best_axis, mut best_bin) = (f32::INFINITY, 0, 0);
    for (axis, bins) in bins.iter().enumerate() {
        // Sweep from the right: the cost of the right side for each split position.
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut cnt) = (Box3::EMPTY, 0u32);
        for i in (1..nb).rev() {
            acc = acc.union(bins[i].bounds);
            cnt += bins[i].count;
            right_cost[i] = acc.half_area() * leaf_cost(cnt as usize);
        }
        let (mut acc, mut cnt) = (Box3::EMPTY, 0u32);
        for i in 1..nb {
            acc = acc.union(bins[i - 1].bounds);
            cnt += bins[i - 1].count;
            let cost = acc.half_area() * leaf_cost(cnt as usize) + right_cost[i];
            // A side without primitives is no split.
            if cost < best_cost && cnt != 0 && cnt != n {
                (best_cost, best_axis, best_bin) = (cost, axis, i);
            }
        }
    }
    if best_bin == 0 {
        return None;
    }
    let side =
        |r: std::ops::Range<usize>| bins[best_axis][r].iter().fold(Box3::EMPTY, |a, b| a.union(b.bounds));
    let parent_area = bounds.half_area().max(f32::MIN_POSITIVE);
    Some(Split {
        axis: best_axis,
        bin: best_bin,
        left: side(0..best_bin),
        right: side(best_bin..nb),
        cost: C_TRAV + best_cost / parent_area,
        min: cb.min,
        scale,
        bins: nb,
        chunks,
    })
}

/// The cost of intersecting a leaf of `n` triangles: one test per pack of four (see
/// [`leaf`](super::leaf)), so leaves of up to four cost the same.
#[inline]
fn leaf_cost(n: usize) -> f32 {
    n.div_ceil(4) as f32
}

/// Moves the primitives left of the split to the front; returns how many there are and the
/// bounds of the doubled centroids of both sides.
fn partition(prims: &mut [Prim], s: &Split) -> (usize, Box3, Box3) {
    let (min, scale) = (s.min[s.axis], s.scale[s.axis]);
    let goes_left = |c: Vec3A| bin_of(c[s.axis], min, scale, s.bins) < s.bin;
    // Branch-free (Lomuto): every record is swapped with the first right one and the left
    // count advances by 0 or 1, so the side, which is as good as random, is never a branch.
    let mut i = 0;
    let (mut cl, mut cr) = (Box3::EMPTY, Box3::EMPTY);
    for j in 0..prims.len() {
        let p = prims[j];
        let c = p.centroid2();
        let left = goes_left(c);
        let m = BVec3A::splat(left);
        cl = cl.grow_where(m, c);
        cr = cr.grow_where(!m, c);
        prims[j] = prims[i];
        prims[i] = p;
        i += usize::from(left);
    }
    (i, cl, cr)
}

/// A stable partition of a node binned in parallel ([`Split::chunks`]) into `scratch` (as long
/// as `prims`), in one pass: each chunk, on its own rayon task, copies its left primitives
/// after those of the chunks before it, and its right ones after all left ones and the right
/// ones before it, the places known from the binning's counts, and bounds both sides'
/// centroids. The side is decided by [`bin_index`], as the binning decided the counts, so the
/// parts fill their places exactly. Returns the left part's size and the sides' bounds.
fn partition_parallel(prims: &[Prim], scratch: &mut [Prim], s: &Split) -> (usize, Box3, Box3) {
    assert_eq!(prims.len(), scratch.len());
    let lefts: Vec<usize> =
        s.chunks.iter().map(|c| c[s.axis][..s.bin].iter().sum::<u32>() as usize).collect();
    let n_left = lefts.iter().sum();
    let (mut left, mut right) = scratch.split_at_mut(n_left);
    let mut jobs = Vec::with_capacity(lefts.len());
    for (chunk, &l) in prims.chunks(CHUNK).zip(&lefts) {
        let (l_out, l_rest) = std::mem::take(&mut left).split_at_mut(l);
        let (r_out, r_rest) = std::mem::take(&mut right).split_at_mut(chunk.len() - l);
        left = l_rest;
        right = r_rest;
        jobs.push((chunk, l_out, r_out));
    }
    let (cl, cr) = jobs
        .into_par_iter()
        .map(|(chunk, l_out, r_out)| {
            let (mut l_out, mut r_out) = (l_out.iter_mut(), r_out.iter_mut());
            let (mut cl, mut cr) = (Box3::EMPTY, Box3::EMPTY);
            for p in chunk {
                let c = p.centroid2();
                let (out, bounds) = if bin_index(c, s.min, s.scale, s.bins)[s.axis] < s.bin {
                    (l_out.next(), &mut cl)
                } else {
                    (r_out.next(), &mut cr)
                };
                *out.expect("the binning's count of each side of a chunk") = *p;
                *bounds = bounds.grow(c);
            }
            (cl, cr)
        })
        .reduce(|| (Box3::EMPTY, Box3::EMPTY), |a, b| (a.0.union(b.0), a.1.union(b.1)));
    (n_left, cl, cr)
}

/// The bins of doubled centroid `c` on all three axes: [`bin_of`] on three lanes at once.
#[inline]
fn bin_index(c: Vec3A, min: Vec3A, scale: Vec3A, bins: usize) -> [usize; 3] {
    let f = ((c - min) * scale).max(Vec3A::ZERO).min(Vec3A::splat((bins - 1) as f32));
    // Four lanes converted together. LLVM does not make one `cvttps2dq` of the saturating
    // conversions: under callgrind this line is a fifth of the build's instructions (1M scene),
    // but the intrinsic needs `unsafe` outside a `#[target_feature]` function, and the 2²³
    // trick, which avoids the conversion, did not make the build faster (`docs/accel/build.md`).
    let i = f.extend(0.0).to_array().map(|x| x as i32);
    [i[0] as usize, i[1] as usize, i[2] as usize]
}

/// Bins per axis for a node of `n` primitives: the sweep over bins costs as much as binning
/// a small node, and a few bins already find its good splits (Embree uses `4 + n/20`). Four
/// bins below 16 primitives instead of eight cut the build's time by about 5 % and changed
/// the traversal's instructions by less than 0.3 % (bunny, dragon).
#[inline]
fn bins_for(n: usize) -> usize {
    match n {
        0..16 => 4,
        16..64 => 8,
        64..1024 => 16,
        _ => BINS,
    }
}

/// The bin of coordinate `c`, as [`bin_index`] gives it for each axis (which decides the
/// binning; this decides the partition). The position is clamped to `[0, bins − 1]` as a
/// float (a NaN becomes 0) and then truncated through `i32`: a saturating float-to-`usize`
/// conversion costs a dozen instructions on x86-64, and was a third of the build's
/// instructions.
#[inline]
fn bin_of(c: f32, min: f32, scale: f32, bins: usize) -> usize {
    ((c - min) * scale).max(0.0).min((bins - 1) as f32) as i32 as usize
}
