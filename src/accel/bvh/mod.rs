//! The pure-Rust ray-query backend: a bounding volume hierarchy over the scene's triangles.
//!
//! **Build** ([`build`]): binned surface-area heuristic on triangle centroids (32 bins per
//! axis, fewer for small nodes), leaves of at most 8 triangles costed by their packs of four,
//! large subtrees built in parallel with rayon and large nodes binned in parallel. Triangle
//! boxes are padded by a tiny relative margin so that rounding in the box test can never cull a
//! triangle that the exact triangle test would hit.
//!
//! **Layout**: the binary tree is built as 64-byte-aligned sibling pairs of compact 32-byte
//! nodes ([`build`]), then collapsed ([`wide`]) into 8-wide nodes that store their children's
//! boxes in structure-of-arrays form (256 bytes), depth-first; leaves are references inside
//! their parent. A leaf's triangles are copied into consecutive packs of four ([`leaf`]: first
//! vertex and two edges, structure of arrays, with the caller's triangle indices, which
//! [`Hit::prim`] reports). Large node and pack arrays are mappings of their own on transparent huge pages
//! ([`pages`]), as Embree's trees are: a random ray's node visits then rarely miss the TLB.
//!
//! **Traversal** ([`traverse`]): per ray, the inverse direction and direction signs are
//! precomputed; one ray is tested against a node's eight boxes at once, with loops over the
//! lanes that LLVM vectorises (safe code), compiled for SSE2, for AVX2 (one `ymm` operation
//! per plane) and for AVX-512 (the same, with 32 registers), the version picked at run time by
//! the CPU's features. The slab test picks each
//! axis' near and far planes from the sign, with a finite inverse direction so that a ray in a
//! box's plane gives no NaN (`0 · ∞`), and combines the axes as a tree of minima and maxima.
//! Three or more hit children are ordered by rank (an 8-wide comparison each), not by a loop.
//! Closest-hit visits children nearest first, keeps the others on a stack with their entry
//! distances (prefetching them on large trees) and drops any that starts beyond the closest hit
//! so far. `occluded` stops at the first hit. A pack's four triangles are tested at once with
//! the operations of [`intersect_triangle`](crate::geometry::intersect_triangle), the
//! brute-force oracle's test, in the same order, on the same open interval `(tmin, tmax)`, so
//! both agree hit for hit.
//!
//! Why this shape: ray queries are dominated by cache misses, so the design keeps boxes that
//! are tested together in the same cache lines, the tree shallow and leaves contiguous; the
//! ordered traversal with early-out keeps closest hits from visiting what lies behind the first
//! surface. On a 1M-triangle closed scene a 4-wide tree traced about 1.4× as many rays per
//! second as the binary one it comes from, and packing leaves by four (with the SAH costing
//! packs, so leaves hold up to four triangles) another 1.15–1.7× (bunny, dragon, 1M scene).
//! Going from 4 to 8 wide with AVX2 gave 1.1–1.25× more, and prefetching deferred children
//! another 1.05–1.2× on the larger scenes (interleaved runs against Embree on a busy 2-core
//! AVX2 machine). Measurements: `docs/accel/` (build, traversal, huge pages) and, for the
//! backend table's runs, `docs/accel_runs.md`.

mod build;
mod leaf;
mod pages;
mod traverse;
mod wide;

use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use super::{Accelerator, Hit};
use crate::geometry::{Aabb, Ray};
use leaf::Tri4;
use pages::Pages;
use wide::Node8;

/// One node: its box and two indices. For a leaf, `index` is the first pack of triangles
/// ([`build::Built::packs`]) and `count > 0` the packs; for an interior node, `index` is the pair holding its children and
/// `count == 0`.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C)]
struct Node {
    min: [f32; 3],
    max: [f32; 3],
    index: u32,
    count: u32,
}

impl Node {
    fn leaf(b: Aabb, first: u32, count: u32) -> Self {
        Node { min: b.min.to_array(), max: b.max.to_array(), index: first, count }
    }

    fn interior(b: Aabb, pair: u32) -> Self {
        Node { min: b.min.to_array(), max: b.max.to_array(), index: pair, count: 0 }
    }

    /// The node with its link moved by `pairs` pairs (an interior node) or `packs` packs (a
    /// leaf).
    fn shifted(mut self, pairs: u32, packs: u32) -> Self {
        self.index += if self.is_leaf() { packs } else { pairs };
        self
    }

    #[inline]
    fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Two siblings sharing a 64-byte cache line.
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(64))]
struct NodePair {
    nodes: [Node; 2],
}

/// Relative padding of triangle boxes (see the module docs).
const BOX_PAD: f32 = 1e-5;

/// A binned-SAH BVH over triangles (see the module docs).
pub struct Bvh {
    /// The 8-wide tree; `nodes[0]` is the root. On huge pages when large, as are the packs
    /// ([`pages`]).
    nodes: Pages<Node8>,
    /// Nodes of the binary tree it was collapsed from.
    binary_nodes: usize,
    /// Leaf triangles in packs of four, leaf by leaf in depth-first order.
    packs: Pages<Tri4>,
    /// Triangles in the tree.
    triangles: usize,
    leaves: usize,
    depth: usize,
    build_time: Duration,
    /// Whether traversal prefetches the children it defers: only for trees larger than a
    /// core's L2 cache, where they are likely to miss (see [`traverse`]).
    prefetch: bool,
}

/// Trees of more bytes than this are prefetched.
const PREFETCH_BYTES: usize = 256 << 10;

impl Bvh {
    /// Builds the hierarchy over the triangles `indices` of `positions`. Accepts an empty list
    /// and degenerate triangles; triangles with non-finite vertices are left out (they can never
    /// be hit). Panics if an index is out of range, like the other backends.
    pub fn new(positions: &[Vec3], indices: &[[u32; 3]]) -> Self {
        let start = Instant::now();
        let verts = |t: &[u32; 3]| t.map(|i| positions[i as usize]);
        // One record per triangle, written in place in parallel: the result does not depend on
        // the threads. Triangles with non-finite vertices get an empty box and are dropped
        // afterwards. The records are streamed through at every level of the build: on huge
        // pages ([`pages`], from 8 MiB) their first touch costs 16 page faults instead of about
        // 8,000 (1M triangles).
        let mut prims = Pages::<build::Prim>::zeroed(indices.len());
        prims.par_iter_mut().zip(indices).enumerate().with_min_len(build::SMALL).for_each(
            |(i, (prim, t))| {
                let v = verts(t);
                let b = if v.iter().all(|p| p.is_finite()) {
                    let b = Aabb::from_points(&v);
                    let pad = Vec3::splat(BOX_PAD * b.min.abs().max(b.max.abs()).max_element())
                        + Vec3::splat(f32::MIN_POSITIVE);
                    Aabb { min: b.min - pad, max: b.max + pad }
                } else {
                    Aabb::EMPTY
                };
                *prim = build::Prim::new(b, i as u32);
            },
        );
        if prims.par_iter().with_min_len(build::SMALL).any(|p| p.is_empty()) {
            prims = Pages::from_vec(prims.iter().filter(|p| !p.is_empty()).copied().collect());
        }
        let built = build::build(&mut prims);
        let make_packs = || {
            let mut packs = Pages::<Tri4>::zeroed(built.packs.len());
            leaf::write_packs(&mut packs, &built.packs, &built.order, positions, indices);
            packs
        };
        // The collapse is sequential: on large trees it runs on this thread while the others
        // write the packs (1M scene on 2 threads: 4 % of the build's time).
        let (nodes, packs) = if built.order.len() >= build::SMALL {
            rayon::join(|| wide::collapse(&built.pairs), make_packs)
        } else {
            (wide::collapse(&built.pairs), make_packs())
        };
        let bytes = std::mem::size_of_val(&nodes[..]) + std::mem::size_of_val(&packs[..]);
        Bvh {
            nodes,
            // Every pair but the root's holds two nodes.
            binary_nodes: 2 * built.pairs.len() - 1,
            packs,
            triangles: built.order.len(),
            leaves: built.leaves,
            depth: built.depth,
            build_time: start.elapsed(),
            prefetch: bytes > PREFETCH_BYTES,
        }
    }

    /// Number of 8-wide nodes (leaves are references inside them, not nodes).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    /// Number of leaves.
    pub fn leaf_count(&self) -> usize {
        self.leaves
    }

    /// Time spent in [`Bvh::new`].
    pub fn build_time(&self) -> Duration {
        self.build_time
    }
}

impl Accelerator for Bvh {
    fn name(&self) -> &str {
        "bvh"
    }

    fn describe(&self) -> String {
        format!(
            "bvh (binned SAH, collapsed to 8-wide: {} triangles, {} wide nodes from {} binary, \
             {} leaves, binary depth {}, built in {:.1} ms)",
            self.triangles,
            self.node_count(),
            self.binary_nodes,
            self.leaves,
            self.depth,
            self.build_time.as_secs_f64() * 1e3
        )
    }

    fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_valid() || self.triangles == 0 {
            return None;
        }
        self.view().closest_hit(ray)
    }

    fn occluded(&self, ray: &Ray) -> bool {
        ray.is_valid() && self.triangles > 0 && self.view().any_hit(ray)
    }

    /// Ray by ray, with the tree's arrays borrowed once.
    fn intersect_batch(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len());
        if self.triangles == 0 {
            return hits.fill(None);
        }
        let v = self.view();
        for (r, h) in rays.iter().zip(hits.iter_mut()) {
            *h = if r.is_valid() { v.closest_hit(r) } else { None };
        }
    }

    /// Ray by ray (the batched traversals measured: `docs/accel/traversal.md`), with the tree's
    /// arrays borrowed once.
    fn occluded_batch(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len());
        if self.triangles == 0 {
            return occluded.fill(false);
        }
        let v = self.view();
        for (r, o) in rays.iter().zip(occluded.iter_mut()) {
            *o = r.is_valid() && v.any_hit(r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::leaf::NO_PRIM;
    use super::*;
    use crate::accel::testmesh;

    /// Walks the tree checking that child boxes lie inside their parents' lanes, every triangle
    /// is in exactly one leaf and the leaf count matches.
    fn validate(bvh: &Bvh, n_tris: usize) {
        let mut seen = vec![0u32; n_tris];
        let mut leaves = 0;
        let inside = |lo: [f32; 3], hi: [f32; 3], n: &Node8, lane: usize| {
            (0..3).all(|a| n.bounds[a][0][lane] <= lo[a] && hi[a] <= n.bounds[a][1][lane])
        };
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = &bvh.nodes[i];
            for lane in 0..wide::WIDTH {
                let c = n.child[lane];
                if c.is_leaf() {
                    leaves += 1;
                    for pack in &bvh.packs[c.index as usize..(c.index + c.count) as usize] {
                        for (k, &id) in pack.id.iter().enumerate().filter(|(_, id)| **id != NO_PRIM) {
                            seen[id as usize] += 1;
                            for p in pack.vertices(k) {
                                assert!(inside(p.to_array(), p.to_array(), n, lane));
                            }
                        }
                    }
                } else if n.bounds[0][0][lane] <= n.bounds[0][1][lane] {
                    let child = &bvh.nodes[c.index as usize];
                    for l in 0..wide::WIDTH {
                        if child.bounds[0][0][l] <= child.bounds[0][1][l] {
                            let lo = child.bounds.map(|b| b[0][l]);
                            let hi = child.bounds.map(|b| b[1][l]);
                            assert!(inside(lo, hi, n, lane));
                        }
                    }
                    stack.push(c.index as usize);
                }
            }
        }
        assert_eq!(leaves, bvh.leaf_count());
        assert_eq!(bvh.binary_nodes, 2 * leaves - 1);
        assert!(seen.iter().all(|&k| k == 1), "every triangle in exactly one leaf");
    }

    #[test]
    fn tree_is_well_formed() {
        for m in [testmesh::cornell_like(), testmesh::sphere(100, 200), testmesh::heightfield(30)] {
            let bvh = Bvh::new(&m.positions, &m.indices);
            validate(&bvh, m.indices.len());
            let mean = m.indices.len() as f32 / bvh.leaf_count() as f32;
            assert!(mean <= build::MAX_LEAF as f32, "mean leaf size {mean}");
        }
    }

    /// Large nodes are binned and partitioned in parallel chunks: the tree must be the same
    /// whatever the number of threads, and well formed.
    #[test]
    fn tree_is_the_same_for_any_thread_count() {
        let m = testmesh::closed_scene(200_000);
        let with = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| Bvh::new(&m.positions, &m.indices))
        };
        let one = with(1);
        validate(&one, m.indices.len());
        for threads in [2, 3] {
            let other = with(threads);
            assert!(*one.nodes == *other.nodes, "{threads} threads: nodes differ");
            assert!(*one.packs == *other.packs, "{threads} threads: leaves differ");
        }
    }

    #[test]
    fn coincident_centroids_make_small_leaves() {
        // 1,000 copies of one triangle: no SAH split exists; the range is halved instead.
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let indices = vec![[0, 1, 2]; 1000];
        let bvh = Bvh::new(&positions, &indices);
        validate(&bvh, indices.len());
        assert!(bvh.leaf_count() >= 1000 / build::MAX_LEAF);
    }

    /// A range of coincident centroids large enough to be partitioned in parallel, below a node
    /// that was: its primitives are in the other buffer, where it is split in the middle, and
    /// its halves are copied back; every triangle is still in exactly one leaf.
    #[test]
    fn coincident_centroids_below_a_parallel_partition() {
        let mut m = testmesh::closed_scene(100_000);
        let first = m.positions.len() as u32;
        let far = Vec3::splat(10.0);
        m.positions.extend([far, far + Vec3::X, far + Vec3::Y]);
        m.indices.extend(std::iter::repeat_n([first, first + 1, first + 2], 100_000));
        let bvh = Bvh::new(&m.positions, &m.indices);
        validate(&bvh, m.indices.len());
    }

    #[test]
    fn pairs_are_cache_line_sized() {
        assert_eq!(std::mem::size_of::<Node>(), 32);
        assert_eq!(std::mem::size_of::<NodePair>(), 64);
        assert_eq!(std::mem::align_of::<NodePair>(), 64);
        assert_eq!(std::mem::size_of::<Node8>(), 32 * wide::WIDTH);
        assert_eq!(std::mem::align_of::<Node8>(), 64);
    }
}
