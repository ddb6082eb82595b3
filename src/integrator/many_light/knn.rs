//! A kd-tree over points for k-nearest-neighbour distances, rebuilt every iteration for the
//! VPL-density radius of virtual spherical lights.

use glam::Vec3;

pub struct KdTree {
    /// Points reordered so that every subtree is a contiguous range; the median of a range is
    /// its splitting node.
    points: Vec<Vec3>,
}

impl KdTree {
    pub fn new(points: &[Vec3]) -> Self {
        let mut points = points.to_vec();
        build(&mut points, 0);
        KdTree { points }
    }

    /// Distance from `q` to its k-th nearest point (the point `q` itself counts if present).
    /// `None` when there are fewer than k points.
    pub fn kth_distance(&self, q: Vec3, k: usize) -> Option<f32> {
        if k == 0 || self.points.len() < k {
            return None;
        }
        // The k smallest squared distances, kept sorted ascending.
        let mut best: Vec<f32> = Vec::with_capacity(k + 1);
        search(&self.points, 0, q, k, &mut best);
        best.get(k - 1).map(|d2| d2.sqrt())
    }
}

fn build(points: &mut [Vec3], depth: usize) {
    if points.len() <= 1 {
        return;
    }
    let axis = depth % 3;
    let mid = points.len() / 2;
    points.select_nth_unstable_by(mid, |a, b| a[axis].total_cmp(&b[axis]));
    let (left, right) = points.split_at_mut(mid);
    build(left, depth + 1);
    build(&mut right[1..], depth + 1);
}

fn search(points: &[Vec3], depth: usize, q: Vec3, k: usize, best: &mut Vec<f32>) {
    if points.is_empty() {
        return;
    }
    let mid = points.len() / 2;
    let p = points[mid];
    let d2 = (p - q).length_squared();
    if best.len() < k || d2 < best[best.len() - 1] {
        let at = best.partition_point(|&b| b <= d2);
        best.insert(at, d2);
        best.truncate(k);
    }
    let axis = depth % 3;
    let delta = q[axis] - p[axis];
    let (near, far) =
        if delta < 0.0 { (&points[..mid], &points[mid + 1..]) } else { (&points[mid + 1..], &points[..mid]) };
    search(near, depth + 1, q, k, best);
    if best.len() < k || delta * delta < best[best.len() - 1] {
        search(far, depth + 1, q, k, best);
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
        assert!(KdTree::new(&[]).kth_distance(Vec3::ZERO, 1).is_none());
    }
}
