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
//! Boxes are stored as plain `f32`, not quantised: decoding quantised bounds adds a
//! conversion, a product and a sum to every plane on the node-to-node chain, which this
//! traversal waits on more than on memory, and quantised nodes traced slower
//! (`docs/accel/traversal.md`, "Quantised boxes").

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
