//! A kd-tree over points, rebuilt every iteration: k-nearest-neighbour distances (the
//! VPL-density radius of virtual spherical lights) and the points within a radius (the
//! photons of vertex merging, [`super::merging`]).

use glam::Vec3;

/// What the tree holds: anything with a position.
pub trait Located {
    fn position(&self) -> Vec3;
}

impl Located for Vec3 {
    #[inline]
    fn position(&self) -> Vec3 {
        *self
    }
}

pub struct KdTree<T = Vec3> {
    /// Items reordered so that every subtree is a contiguous range; the median of a range is
    /// its splitting node.
    items: Vec<T>,
}

impl<T: Located + Clone> KdTree<T> {
    pub fn new(items: &[T]) -> Self {
        Self::from_vec(items.to_vec())
    }
}

impl<T: Located> KdTree<T> {
    pub fn from_vec(mut items: Vec<T>) -> Self {
        build(&mut items, 0);
        KdTree { items }
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// Distance from `q` to its k-th nearest point (the point `q` itself counts if present).
    /// `None` when there are fewer than k points.
    pub fn kth_distance(&self, q: Vec3, k: usize) -> Option<f32> {
        if k == 0 || self.items.len() < k {
            return None;
        }
        // The k smallest squared distances, kept sorted ascending.
        let mut best: Vec<f32> = Vec::with_capacity(k + 1);
        search(&self.items, 0, q, k, &mut best);
        best.get(k - 1).map(|d2| d2.sqrt())
    }

    /// Calls `f` with every item whose squared distance from `q` is at most `r2`, in an order
    /// that depends on the tree and `q` alone.
    pub fn within(&self, q: Vec3, r2: f32, mut f: impl FnMut(&T)) {
        within(&self.items, 0, q, r2, &mut f);
    }
}

fn build<T: Located>(items: &mut [T], depth: usize) {
    if items.len() <= 1 {
        return;
    }
    let axis = depth % 3;
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.position()[axis].total_cmp(&b.position()[axis]));
    let (left, right) = items.split_at_mut(mid);
    build(left, depth + 1);
    build(&mut right[1..], depth + 1);
}

fn search<T: Located>(items: &[T], depth: usize, q: Vec3, k: usize, best: &mut Vec<f32>) {
    if items.is_empty() {
        return;
    }
    let mid = items.len() / 2;
    let p = items[mid].position();
    let d2 = (p - q).length_squared();
    if best.len() < k || d2 < best[best.len() - 1] {
        let at = best.partition_point(|&b| b <= d2);
        best.insert(at, d2);
        best.truncate(k);
    }
    let axis = depth % 3;
    let delta = q[axis] - p[axis];
    let (near, far) =
        if delta < 0.0 { (&items[..mid], &items[mid + 1..]) } else { (&items[mid + 1..], &items[..mid]) };
    search(near, depth + 1, q, k, best);
    if best.len() < k || delta * delta < best[best.len() - 1] {
        search(far, depth + 1, q, k, best);
    }
}

fn within<T: Located>(items: &[T], depth: usize, q: Vec3, r2: f32, f: &mut impl FnMut(&T)) {
    if items.is_empty() {
        return;
    }
    let mid = items.len() / 2;
    let p = items[mid].position();
    if (p - q).length_squared() <= r2 {
        f(&items[mid]);
    }
    let axis = depth % 3;
    let delta = q[axis] - p[axis];
    if delta <= 0.0 || delta * delta <= r2 {
        within(&items[..mid], depth + 1, q, r2, f);
    }
    if delta >= 0.0 || delta * delta <= r2 {
        within(&items[mid + 1..], depth + 1, q, r2, f);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Domain, Sampler};

    #[test]
    fn agrees_with_brute_force() {
        let mut s = Sampler::new(5, 0, Domain::Iteration, 0);
        let pts: Vec<Vec3> =
            (0..500).map(|_| Vec3::new(s.next_f32(), s.next_f32(), s.next_f32() * 0.1)).collect();
        let tree = KdTree::new(&pts);
        for i in 0..50 {
            let q = if i % 2 == 0 { pts[i] } else { Vec3::new(s.next_f32(), s.next_f32(), 0.5) };
            for k in [1, 10, 37] {
                let mut d: Vec<f32> = pts.iter().map(|p| (*p - q).length()).collect();
                d.sort_by(f32::total_cmp);
                let got = tree.kth_distance(q, k).unwrap();
                assert!((got - d[k - 1]).abs() < 1e-6, "k {k}: {got} vs {}", d[k - 1]);
            }
        }
        assert!(tree.kth_distance(Vec3::ZERO, 501).is_none());
        assert!(KdTree::<Vec3>::new(&[]).kth_distance(Vec3::ZERO, 1).is_none());
    }

    /// The points within a radius are exactly those a scan finds, each once, whatever the
    /// radius (none, some, all), at the points themselves and between them.
    #[test]
    fn finds_what_a_scan_finds_within_a_radius() {
        let mut s = Sampler::new(6, 0, Domain::Iteration, 0);
        let pts: Vec<Vec3> =
            (0..700).map(|_| Vec3::new(s.next_f32(), s.next_f32() * 0.3, s.next_f32())).collect();
        let tree = KdTree::new(&pts);
        assert_eq!(tree.len(), 700);
        for i in 0..60 {
            let q = if i % 3 == 0 { pts[i] } else { Vec3::new(s.next_f32(), s.next_f32(), s.next_f32()) };
            for r in [0.0, 0.01, 0.07, 0.3, 2.0] {
                let mut got = Vec::new();
                tree.within(q, r * r, |p| got.push(p.to_array().map(f32::to_bits)));
                got.sort();
                let mut expected: Vec<_> = pts
                    .iter()
                    .filter(|p| (**p - q).length_squared() <= r * r)
                    .map(|p| p.to_array().map(f32::to_bits))
                    .collect();
                expected.sort();
                assert_eq!(got, expected, "query {i}, radius {r}");
            }
        }
        let mut none = 0;
        KdTree::<Vec3>::new(&[]).within(Vec3::ZERO, 1.0, |_| none += 1);
        assert_eq!(none, 0);
    }
}
