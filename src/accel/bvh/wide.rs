//! The wide node layout that traversal runs on, collapsed from the binary SAH tree.
//!
//! A [`Node8`] holds the boxes of up to [`WIDTH`] children in structure-of-arrays form (one
//! `[f32; WIDTH]` per bound and axis, an axis' minima and maxima side by side in one cache
//! line: 192 bytes; with the child references 256 bytes, four cache lines, like Embree's 8-wide
//! nodes), so one ray is tested against all of them with one
//! AVX2 operation per plane (see [`traverse`](super::traverse)); with SSE2 only, eight lanes
//! take two operations. Collapsing pulls grandchildren up into a node, always opening the
//! interior child with the largest surface area, until the node is full: this divides the
//! tree's depth, and the number of nodes a ray visits, by about three. Unused lanes hold the
//! empty box (`+∞` min, `−∞` max), which no ray enters.
//!
//! **Quantised boxes, measured and not kept (2026-12-05).** A 128-byte node (two cache
//! lines): per axis an origin (the children's least minimum) and a power-of-two scale (an
//! exponent byte) covering the node's extent in 255 steps, each child bound a byte `q`,
//! decoded as `origin + q · scale` (no fused multiply-add, so the builder could check every
//! decoded bound and step its byte outwards until the decoded box contained the child's:
//! conservative by construction), an occupancy byte for the unused lanes, the child references
//! unchanged. The decoded boxes were on average 1.8 % (conference room) to 2.4 % (bunny,
//! dragon) larger in half area. Binaries alternating, `RAYS=3000000 accel_ratio ratio SCENE
//! WORKLOAD 7`, two runs each (medians; BVH over Embree's rate), current against quantised:
//! dragon occlusion 0.888 against 0.759, 1M scene occlusion 0.959 against 0.894, bunny gather
//! 1.011 against 0.795, conference room gather 0.783 against 0.562. Ylitie, Karras and Laine's
//! cheaper decode, `(origin − o) · inv + q · (scale · inv)` with the two products per node and
//! axis (not conservative as written, timed only), one run: dragon occlusion 0.800 against
//! 0.781, bunny gather 1.003 against 0.812, conference room 0.769 against 0.558. The decode
//! adds a byte-to-float conversion, a product and a sum to every plane of the node-to-node
//! chain, and this traversal waits on that chain more than on memory: the same nodes padded to
//! 512 bytes (twice the footprint, the same lines read) cost less (dragon occlusion 0.828
//! against 0.738, 1M scene 0.975 against 0.925, bunny gather 1.013 against 0.983, conference
//! room 0.765 against 0.756) than the quantised nodes lost.

use super::pages::Pages;
use super::{Node, NodePair};

/// Children per node.
pub(super) const WIDTH: usize = 8;

/// A reference to a child: an interior node (`count == 0`, `index` is its [`Node8`]) or a leaf
/// (`count > 0` triangle packs from `index`, see [`leaf`](super::leaf)).
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub(super) struct ChildRef {
    pub index: u32,
    pub count: u32,
}

impl ChildRef {
    #[inline]
    pub fn is_leaf(self) -> bool {
        self.count > 0
    }
}

/// [`WIDTH`] children's boxes (SoA) and references.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(64))]
pub(super) struct Node8 {
    /// Per axis, the children's minima (`[axis][0]`) and maxima (`[axis][1]`): a ray's near
    /// planes on an axis are `[axis][negative direction]`, an index rather than a select.
    pub bounds: [[[f32; WIDTH]; 2]; 3],
    pub child: [ChildRef; WIDTH],
}

impl Node8 {
    pub const EMPTY: Node8 = Node8 {
        bounds: [[[f32::INFINITY; WIDTH], [f32::NEG_INFINITY; WIDTH]]; 3],
        child: [ChildRef { index: 0, count: 0 }; WIDTH],
    };

    fn set(&mut self, lane: usize, n: &Node, child: ChildRef) {
        for a in 0..3 {
            self.bounds[a][0][lane] = n.min[a];
            self.bounds[a][1][lane] = n.max[a];
        }
        self.child[lane] = child;
    }
}

/// The collapsed tree: `nodes[0]` is the root. A binary root that is itself a leaf becomes a
/// root with one leaf lane.
pub(super) fn collapse(pairs: &[NodePair]) -> Pages<Node8> {
    let mut nodes = Vec::with_capacity(pairs.len() / 2 + 1);
    nodes.push(Node8::EMPTY);
    let root = pairs[0].nodes[0];
    if root.is_leaf() {
        nodes[0].set(0, &root, ChildRef { index: root.index, count: root.count });
    } else if pairs.len() > 1 {
        // (A single pair means an empty scene: the root stays an empty node.)
        fill(pairs, &root, 0, &mut nodes);
    }
    Pages::from_vec(nodes)
}

/// Fills `nodes[at]` with the (up to [`WIDTH`]) descendants of the binary interior node `n`.
fn fill(pairs: &[NodePair], n: &Node, at: usize, nodes: &mut Vec<Node8>) {
    let mut kids = [Node::default(); WIDTH];
    kids[..2].copy_from_slice(&pairs[n.index as usize].nodes);
    let mut len = 2;
    while len < WIDTH {
        // Open the largest interior child.
        let best = kids[..len]
            .iter()
            .enumerate()
            .filter(|(_, k)| !k.is_leaf())
            .max_by(|(_, a), (_, b)| half_area(a).total_cmp(&half_area(b)))
            .map(|(i, _)| i);
        let Some(i) = best else { break };
        // As `Vec::swap_remove` then a push of both grandchildren.
        let k = kids[i];
        kids[i] = kids[len - 1];
        let [l, r] = pairs[k.index as usize].nodes;
        kids[len - 1] = l;
        kids[len] = r;
        len += 1;
    }
    for (lane, k) in kids[..len].iter().enumerate() {
        if k.is_leaf() {
            nodes[at].set(lane, k, ChildRef { index: k.index, count: k.count });
        } else {
            let child = nodes.len();
            nodes.push(Node8::EMPTY);
            nodes[at].set(lane, k, ChildRef { index: child as u32, count: 0 });
            fill(pairs, k, child, nodes);
        }
    }
}

fn half_area(n: &Node) -> f32 {
    let e = [n.max[0] - n.min[0], n.max[1] - n.min[1], n.max[2] - n.min[2]];
    e[0] * e[1] + e[1] * e[2] + e[2] * e[0]
}
