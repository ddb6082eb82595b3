//! Leaf triangles in packs of four, laid out for one SIMD test of all four against a ray.
//!
//! A [`Tri4`] holds the first vertex and the two edges of four triangles in
//! structure-of-arrays form (one `Vec4` per coordinate) and their original indices. A leaf's
//! triangles fill `⌈n/4⌉` consecutive packs; unused lanes are all-zero triangles
//! (`det = 0`: never hit) with the id [`NO_PRIM`].
//!
//! [`Tri4::hit`] is the Möller–Trumbore test of
//! [`intersect_triangle`](crate::geometry::intersect_triangle) on four lanes, with the same
//! operations in the same order (the edges are computed once, at build time, by the same
//! subtractions), so every lane gives bit for bit the distance, barycentrics and verdict the
//! oracle gives for its triangle: the backends still agree hit for hit.
//!
//! Testing a leaf's two packs at once, as eight lanes written as plain loops (for one AVX
//! operation per step, like the box test), did not pay: LLVM kept those loops 4-wide, and the
//! instructions per ray in traversal rose by 4–12 % on the bunny (occlusion 840 → 918, gather
//! 1,085 → 1,219, closest hit 696 → 721).
//!
//! Nor did Embree's division-free form (2026-12-04): the tests on `U`, `V` and `T` against
//! the determinant (`U` between 0 and `det` in either order, and so on), with the oracle
//! changed alike and the division left to the hit lanes, took the division off the path of
//! every pack but not an instruction (bunny occlusion 55.0 → 55.7 M, closest hit 45.6 →
//! 46.0 M), and interleaved `accel_ratio` runs showed no change (bunny occlusion 0.70, 0.70
//! → 0.62, 0.70; dragon 0.667, 0.656 → 0.677, 0.687).

use glam::{BVec4A, Vec3, Vec4};

/// The id of an unused lane.
pub(super) const NO_PRIM: u32 = u32::MAX;

/// Four triangles: vertex `a` and edges `b − a`, `c − a`, each as x, y, z lanes.
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub(super) struct Tri4 {
    pub a: [Vec4; 3],
    pub e1: [Vec4; 3],
    pub e2: [Vec4; 3],
    pub id: [u32; 4],
}

/// A ray splatted over four lanes for [`Tri4::hit`].
pub(super) struct Ray4 {
    pub o: [Vec4; 3],
    pub d: [Vec4; 3],
}

impl Ray4 {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray4 {
            o: [Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z)],
            d: [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)],
        }
    }
}

/// The lanes hit in `(tmin, tmax)` (bit per lane) and their `t`, `u`, `v`.
pub(super) struct Hits4 {
    pub mask: u32,
    pub t: Vec4,
    pub u: Vec4,
    pub v: Vec4,
}

impl Hits4 {
    /// The hit lane with the smallest `t` (the first such lane on ties); `mask != 0`.
    #[inline]
    pub fn nearest(&self) -> usize {
        let t = self.t.to_array();
        let mut m = self.mask;
        let mut best = m.trailing_zeros() as usize;
        m &= m - 1;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            if t[lane] < t[best] {
                best = lane;
            }
        }
        best
    }
}

/// `x · y` with glam's `Vec3::dot` order of operations, on four lanes.
#[inline(always)]
fn dot(x: &[Vec4; 3], y: &[Vec4; 3]) -> Vec4 {
    (x[0] * y[0]) + (x[1] * y[1]) + (x[2] * y[2])
}

/// `x × y` with glam's `Vec3::cross` order of operations, on four lanes.
#[inline(always)]
fn cross(x: &[Vec4; 3], y: &[Vec4; 3]) -> [Vec4; 3] {
    [x[1] * y[2] - y[1] * x[2], x[2] * y[0] - y[2] * x[0], x[0] * y[1] - y[0] * x[1]]
}

impl Tri4 {
    const EMPTY: Tri4 =
        Tri4 { a: [Vec4::ZERO; 3], e1: [Vec4::ZERO; 3], e2: [Vec4::ZERO; 3], id: [NO_PRIM; 4] };

    /// Packs up to four triangles (`(vertices, original index)`; more are an error).
    pub fn new(tris: impl IntoIterator<Item = ([Vec3; 3], u32)>) -> Self {
        let mut p = Tri4::EMPTY;
        for (lane, ([a, b, c], id)) in tris.into_iter().enumerate() {
            let (e1, e2) = (b - a, c - a);
            for k in 0..3 {
                p.a[k][lane] = a[k];
                p.e1[k][lane] = e1[k];
                p.e2[k][lane] = e2[k];
            }
            p.id[lane] = id;
        }
        p
    }

    /// The four triangles against one ray on `(tmin, tmax)`: `intersect_triangle` per lane.
    #[inline(always)]
    pub fn hit(&self, r: &Ray4, tmin: f32, tmax: f32) -> Hits4 {
        let p = cross(&r.d, &self.e2);
        let det = dot(&self.e1, &p);
        let inv = Vec4::ONE / det;
        let s = [r.o[0] - self.a[0], r.o[1] - self.a[1], r.o[2] - self.a[2]];
        let u = dot(&s, &p) * inv;
        let q = cross(&s, &self.e1);
        let v = dot(&r.d, &q) * inv;
        let t = dot(&self.e2, &q) * inv;
        // The scalar test's rejections, lane by lane; NaNs fail every comparison, as there.
        let det_ok = det.cmpne(Vec4::ZERO) & det.abs().cmplt(Vec4::INFINITY);
        let u_ok = u.cmpge(Vec4::ZERO) & u.cmple(Vec4::ONE);
        let v_bad = v.cmplt(Vec4::ZERO) | (u + v).cmpgt(Vec4::ONE);
        let t_ok = t.cmpgt(Vec4::splat(tmin)) & t.cmplt(Vec4::splat(tmax));
        let ok: BVec4A = det_ok & u_ok & !v_bad & t_ok;
        Hits4 { mask: ok.bitmask(), t, u, v }
    }

    /// Vertices of lane `lane` as the test sees them (`a`, `a + e1`, `a + e2`).
    #[cfg(test)]
    pub fn vertices(&self, lane: usize) -> [Vec3; 3] {
        let a = Vec3::new(self.a[0][lane], self.a[1][lane], self.a[2][lane]);
        let e1 = Vec3::new(self.e1[0][lane], self.e1[1][lane], self.e1[2][lane]);
        let e2 = Vec3::new(self.e2[0][lane], self.e2[1][lane], self.e2[2][lane]);
        [a, a + e1, a + e2]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::testmesh;
    use crate::geometry::intersect_triangle;

    /// Every lane agrees bit for bit with the scalar test, on random rays against a dense
    /// sphere plus degenerate (zero-area, collinear) and axis-aligned triangles.
    #[test]
    fn lanes_match_the_scalar_test() {
        let m = testmesh::sphere(12, 24);
        let mut tris: Vec<[Vec3; 3]> = (0..m.indices.len()).map(|i| m.triangle(i)).collect();
        tris.push([Vec3::ZERO; 3]);
        tris.push([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
        tris.push([Vec3::ZERO, Vec3::X, Vec3::Y]);
        tris.push([Vec3::new(0.0, 0.0, 0.5), Vec3::new(1.0, 0.0, 0.5), Vec3::new(0.0, 0.0, 1.5)]);
        let b = m.bounds();
        let rays = testmesh::random_rays(&b, 300, 3);
        let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
            .map(|d| crate::geometry::Ray::new(Vec3::new(0.25, 0.25, 0.75) - d * 3.0, d));
        let mut hits = 0;
        for chunk in tris.chunks(4) {
            let pack = Tri4::new(chunk.iter().map(|&t| (t, 0)));
            for r in rays.iter().chain(&axis) {
                let h = pack.hit(&Ray4::new(r.origin, r.dir), r.tmin, r.tmax);
                for (lane, t) in chunk.iter().enumerate() {
                    let [a, b, c] = *t;
                    let want = intersect_triangle(r.origin, r.dir, r.tmin, r.tmax, a, b, c);
                    let got = (h.mask >> lane & 1 == 1).then(|| (h.t[lane], h.u[lane], h.v[lane]));
                    let want = want.map(|w| (w.t, w.u, w.v));
                    assert_eq!(got.map(|g| g.0.to_bits()), want.map(|w| w.0.to_bits()));
                    assert_eq!(
                        got.map(|g| (g.1.to_bits(), g.2.to_bits())),
                        want.map(|w| (w.1.to_bits(), w.2.to_bits()))
                    );
                    hits += usize::from(want.is_some());
                }
                assert_eq!(h.mask >> chunk.len(), 0, "padding lanes never hit");
            }
        }
        assert!(hits > 100, "{hits}");
    }
}
