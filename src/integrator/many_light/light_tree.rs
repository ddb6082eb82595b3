//! A light tree over one iteration's virtual lights, for the sampled gather of
//! [`super::tree_gather`] (stochastic lightcuts: Yuksel 2019, Lin and Yuksel 2020; node
//! bounds as in Conty Estevez and Kulla 2018 and pbrt-v4's `BVHLightSampler`).
//!
//! # Layout
//! A complete binary tree in heap order: the root is node 1, node i has children 2i and
//! 2i + 1, and the 2^L leaves are nodes 2^L … 2^(L+1) − 1, with L = ⌈log₂ n⌉ for n lights. The
//! leaves hold the lights sorted along a space-filling curve; the 2^L − n leaves past the last
//! light are empty (no light, zero intensity) and are never sampled. Every descent takes
//! exactly L steps, the node array is flat and its topology implicit, and each level is one
//! contiguous range built from the level below.
//!
//! # Order of the leaves
//! Each light gets a 63-bit key: a Morton code of its position quantised to 2^20 cells per
//! axis in the box of all lights, with three bits of its geometric normal's direction (the
//! dominant axis and its sign) inserted after the first six bits per axis. So neighbours on
//! the curve are near in space, and inside cells of 1/64 of the box per axis the lights are
//! grouped by orientation first (a crease's two walls end up in different subtrees, whose
//! normal cones stay tight). Keys are sorted together with the light's index, so the order,
//! and the whole tree, is a function of the lights alone whatever the thread count.
//!
//! # Nodes
//! A node bounds the lights below it:
//! - `intensity`: the sum of its lights' scalar intensities (the caller's choice; the light
//!   set uses Σ over RGB of flux × reflectance, zero only for a light that emits nothing);
//! - the box of the lights' positions, each grown by its sphere's radius (zero for points);
//! - a cone (axis, cos θ) containing every light's geometric normal, merged as in pbrt-v4's
//!   `DirectionCone` union with a small angular margin against rounding, and sin θ (so that the
//!   importance of [`super::tree_gather`] needs no trigonometry: pbrt-v4's
//!   `CompactLightBounds` stores cos θ the same way);
//! - the half-diagonal |h| of the box (the radius of its bounding sphere about the centre);
//! - the smallest depth (segments from the emitter) and the smallest radius of its lights.
//!
//! A node is 64 bytes, aligned to 64: a node is one cache line, and the two children a
//! descent evaluates together (2i and 2i + 1) are two adjacent lines.
//!
//! Building costs a parallel sort of n keys and O(n) merges, level by level in parallel.

use glam::{Quat, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

use crate::geometry::Aabb;

/// A virtual light as the tree sees it.
#[derive(Clone, Copy, Debug)]
pub struct TreeLight {
    pub p: Vec3,
    /// Unit geometric normal.
    pub ng: Vec3,
    /// The scalar the sampling is proportional to (≥ 0, zero only for a light that provably
    /// contributes nothing).
    pub intensity: f32,
    /// Segments from the emitter.
    pub depth: u32,
    /// Sphere radius (0 for point lights).
    pub radius: f32,
}

/// A cone of directions: unit `axis` and cos of the half-angle (`cos_theta` > 1: empty).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cone {
    pub axis: Vec3,
    pub cos_theta: f32,
}

/// Extra half-angle (radians) given to a merged cone, against the rounding of the merge.
const CONE_MARGIN: f32 = 1e-4;

impl Cone {
    pub const EMPTY: Cone = Cone { axis: Vec3::Z, cos_theta: 2.0 };

    pub fn is_empty(&self) -> bool {
        self.cos_theta > 1.0
    }

    /// The smallest cone (up to the margin) containing both: pbrt-v4's `Union`.
    pub fn union(a: Cone, b: Cone) -> Cone {
        if a.is_empty() {
            return b;
        }
        if b.is_empty() {
            return a;
        }
        let (ta, tb) = (a.cos_theta.clamp(-1.0, 1.0).acos(), b.cos_theta.clamp(-1.0, 1.0).acos());
        let td = angle_between(a.axis, b.axis);
        if (td + tb).min(PI) <= ta {
            return a;
        }
        if (td + ta).min(PI) <= tb {
            return b;
        }
        let to = 0.5 * (ta + td + tb);
        let everything = Cone { axis: a.axis, cos_theta: -1.0 };
        if to + CONE_MARGIN >= PI {
            return everything;
        }
        let wr = a.axis.cross(b.axis);
        if wr.length_squared() < 1e-12 {
            return everything;
        }
        let axis = (Quat::from_axis_angle(wr.normalize(), to - ta) * a.axis).normalize();
        Cone { axis, cos_theta: (to + CONE_MARGIN).cos() }
    }
}

/// The angle between two unit vectors, accurate at both ends (2 atan2(|a − b|, |a + b|)).
fn angle_between(a: Vec3, b: Vec3) -> f32 {
    2.0 * (a - b).length().atan2((a + b).length())
}

/// What a node knows of the lights below it (see the module docs).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node {
    pub bounds: Aabb,
    pub cone: Cone,
    /// sin θ of the cone's half-angle θ (cos θ clamped to [−1, 1]; 0 for an empty cone).
    pub sin_theta: f32,
    /// |h|, h the box's half-extent (0 for an empty box).
    pub half_diagonal: f32,
    pub intensity: f32,
    pub min_depth: u32,
    pub min_radius: f32,
}

impl Node {
    /// No light: zero intensity, never sampled.
    pub const EMPTY: Node = Node {
        bounds: Aabb::EMPTY,
        cone: Cone::EMPTY,
        sin_theta: 0.0,
        half_diagonal: 0.0,
        intensity: 0.0,
        min_depth: u32::MAX,
        min_radius: f32::INFINITY,
    };

    fn leaf(l: &TreeLight) -> Node {
        let r = Vec3::splat(l.radius);
        Node::with_derived(Node {
            bounds: Aabb { min: l.p - r, max: l.p + r },
            cone: Cone { axis: l.ng, cos_theta: 1.0 },
            intensity: l.intensity,
            min_depth: l.depth,
            min_radius: l.radius,
            ..Node::EMPTY
        })
    }

    fn merge(a: &Node, b: &Node) -> Node {
        Node::with_derived(Node {
            bounds: a.bounds.union(b.bounds),
            cone: Cone::union(a.cone, b.cone),
            intensity: a.intensity + b.intensity,
            min_depth: a.min_depth.min(b.min_depth),
            min_radius: a.min_radius.min(b.min_radius),
            ..Node::EMPTY
        })
    }

    /// The node with sin θ and |h| computed from its cone and box.
    fn with_derived(self) -> Node {
        let c = self.cone.cos_theta.clamp(-1.0, 1.0);
        let sin_theta = if self.cone.is_empty() { 0.0 } else { (1.0 - c * c).max(0.0).sqrt() };
        let half_diagonal =
            if self.bounds.is_empty() { 0.0 } else { (0.5 * (self.bounds.max - self.bounds.min)).length() };
        Node { sin_theta, half_diagonal, ..self }
    }
}

/// The tree (see the module docs).
#[derive(Clone, Debug)]
pub struct LightTree {
    /// L: every leaf is L steps below the root.
    levels: u32,
    /// Heap order; index 0 unused.
    nodes: Vec<Node>,
    /// The light of each leaf (`u32::MAX` for the empty leaves).
    leaf_light: Vec<u32>,
}

/// Levels at or below this size are merged on one thread (rayon's split overhead dominates).
const PAR_MIN: usize = 4096;

impl LightTree {
    pub fn new(lights: &[TreeLight]) -> LightTree {
        let n = lights.len();
        assert!(n < u32::MAX as usize);
        let levels = if n <= 1 { 0 } else { usize::BITS - (n - 1).leading_zeros() };
        let leaves = 1usize << levels;
        let bounds =
            lights.par_iter().map(|l| Aabb { min: l.p, max: l.p }).reduce(|| Aabb::EMPTY, Aabb::union);
        let mut keyed: Vec<(u64, u32)> =
            lights.par_iter().enumerate().map(|(i, l)| (key(l, &bounds), i as u32)).collect();
        keyed.par_sort_unstable();
        let mut nodes = vec![Node::EMPTY; 2 * leaves];
        nodes[leaves..leaves + n]
            .par_iter_mut()
            .zip(keyed.par_iter())
            .with_min_len(PAR_MIN)
            .for_each(|(node, &(_, i))| *node = Node::leaf(&lights[i as usize]));
        for level in (0..levels).rev() {
            let (upper, lower) = nodes.split_at_mut(1 << (level + 1));
            upper[1 << level..]
                .par_iter_mut()
                .with_min_len(PAR_MIN)
                .enumerate()
                .for_each(|(i, node)| *node = Node::merge(&lower[2 * i], &lower[2 * i + 1]));
        }
        let mut leaf_light = vec![u32::MAX; leaves];
        for (slot, &(_, i)) in leaf_light.iter_mut().zip(&keyed) {
            *slot = i;
        }
        LightTree { levels, nodes, leaf_light }
    }

    /// L: the number of steps from the root to every leaf.
    pub fn levels(&self) -> u32 {
        self.levels
    }

    /// Node `i` (heap order, root 1).
    #[inline]
    pub fn node(&self, i: usize) -> &Node {
        &self.nodes[i]
    }

    /// The light at the leaf node `i` (heap order), if any.
    #[inline]
    pub fn light_of(&self, i: usize) -> Option<usize> {
        let l = self.leaf_light[i - self.leaf_light.len()];
        (l != u32::MAX).then_some(l as usize)
    }

    /// The index of the first leaf node (2^L).
    #[inline]
    pub fn first_leaf(&self) -> usize {
        self.leaf_light.len()
    }
}

/// Bits per axis of the Morton code, and of its coarse part (before the normal's bits).
const AXIS_BITS: u32 = 20;
const COARSE_BITS: u32 = 6;

/// The sort key of a light: coarse Morton bits, the normal's octant, fine Morton bits.
fn key(l: &TreeLight, bounds: &Aabb) -> u64 {
    let scale = (1u32 << AXIS_BITS) as f32;
    let ext = bounds.extent().max(Vec3::splat(1e-30));
    let q = ((l.p - bounds.min) / ext * scale).clamp(Vec3::ZERO, Vec3::splat(scale - 1.0));
    let m = spread(q.x as u64) << 2 | spread(q.y as u64) << 1 | spread(q.z as u64);
    let fine = 3 * (AXIS_BITS - COARSE_BITS);
    let a = l.ng.abs();
    let axis = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let dir = 2 * axis + u64::from(l.ng[axis as usize] < 0.0);
    (m >> fine) << (fine + 3) | dir << fine | (m & ((1u64 << fine) - 1))
}

/// The bits of a 21-bit number spread to every third bit.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x001f_0000_0000_ffff;
    x = (x | x << 16) & 0x001f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Domain, Sampler};

    fn unit(s: &mut Sampler) -> Vec3 {
        Vec3::new(s.next_f32() - 0.5, s.next_f32() - 0.5, s.next_f32() - 0.5).normalize_or(Vec3::Z)
    }

    pub(crate) fn random_lights(n: usize, seed: u64) -> Vec<TreeLight> {
        let mut s = Sampler::new(seed, 0, Domain::Iteration, 0);
        (0..n)
            .map(|j| TreeLight {
                p: Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) * 2.0,
                ng: unit(&mut s),
                intensity: if j % 13 == 5 { 0.0 } else { s.next_f32() },
                depth: 1 + (j % 3) as u32,
                radius: 0.01 * s.next_f32(),
            })
            .collect()
    }

    #[test]
    fn spread_interleaves() {
        assert_eq!(spread(0b111), 0b1001001);
        assert_eq!(spread(0x1f_ffff).count_ones(), 21);
    }

    #[test]
    fn cone_union_contains_both() {
        let mut s = Sampler::new(3, 0, Domain::Iteration, 0);
        for _ in 0..2000 {
            let a = Cone { axis: unit(&mut s), cos_theta: 1.0 - 2.0 * s.next_f32() * s.next_f32() };
            let b = Cone { axis: unit(&mut s), cos_theta: 1.0 - 2.0 * s.next_f32() * s.next_f32() };
            let u = Cone::union(a, b);
            for c in [a, b] {
                // The whole of c lies within u: the angle between axes plus c's half-angle.
                let t = angle_between(u.axis, c.axis) + c.cos_theta.acos();
                assert!(
                    t <= u.cos_theta.clamp(-1.0, 1.0).acos() + 1e-4 || u.cos_theta <= -1.0,
                    "{a:?} {b:?} {u:?}"
                );
            }
        }
    }

    /// Every node bounds its lights, its intensity is their sum, and every light sits in one
    /// leaf; the tree is the same on one thread and on two.
    #[test]
    fn nodes_bound_their_lights_and_the_build_is_thread_independent() {
        for n in [0usize, 1, 2, 3, 10, 257, 5000] {
            let lights = random_lights(n, n as u64);
            let tree = LightTree::new(&lights);
            assert_eq!(tree.first_leaf(), 1 << tree.levels());
            let mut seen = vec![false; n];
            // Every node against the lights below it.
            for i in 1..tree.first_leaf() * 2 {
                let node = tree.node(i);
                let depth_below = tree.levels() - (usize::BITS - 1 - i.leading_zeros());
                let first = i << depth_below;
                let mut sum = 0.0f64;
                for leaf in first..first + (1 << depth_below) {
                    let Some(j) = tree.light_of(leaf) else { continue };
                    let l = &lights[j];
                    if depth_below == 0 {
                        assert!(!seen[j]);
                        seen[j] = true;
                    }
                    sum += l.intensity as f64;
                    assert!(
                        node.bounds.min.cmple(l.p - l.radius).all()
                            && node.bounds.max.cmpge(l.p + l.radius).all()
                    );
                    let t = angle_between(node.cone.axis, l.ng);
                    assert!(node.cone.cos_theta <= -1.0 || t <= node.cone.cos_theta.acos() + 1e-4);
                    assert!(node.min_depth <= l.depth && node.min_radius <= l.radius);
                }
                assert!((node.intensity as f64 - sum).abs() <= 1e-4 * sum.max(1.0));
            }
            assert!(seen.iter().all(|&s| s));
            let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
            let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
            let (a, b) = (one.install(|| LightTree::new(&lights)), two.install(|| LightTree::new(&lights)));
            assert_eq!(a.leaf_light, b.leaf_light);
            for (x, y) in a.nodes.iter().zip(&b.nodes) {
                assert_eq!(format!("{x:?}"), format!("{y:?}"));
            }
        }
    }
}
