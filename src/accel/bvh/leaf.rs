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
//! A leaf of two packs is tested eight lanes at once in the AVX2 and AVX-512 versions of the
//! traversal ([`hit_pair_avx`], AVX intrinsics: each vector is a pack's four lanes and the
//! other's, joined as they are loaded), with the same operations as [`Tri4::hit`], so the
//! lanes agree bit for bit; the SSE2 version tests the two packs one after the other
//! ([`Hits8::from_halves`]). The eight lanes are written with intrinsics, not as plain loops:
//! LLVM kept such loops 4-wide. The test divides by the determinant, as the oracle does;
//! Embree's division-free form traced no faster. Measurements: `docs/accel/traversal.md`.

use glam::{BVec4A, Vec3, Vec4};
use rayon::prelude::*;

use super::build::PackRange;

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

/// The lanes of a leaf's two packs hit in `(tmin, tmax)` (bit per lane, the first pack's in bits
/// 0–3) and their `t`, `u`, `v`.
pub(super) struct Hits8 {
    pub mask: u32,
    pub t: [f32; 8],
    pub u: [f32; 8],
    pub v: [f32; 8],
}

impl Hits8 {
    /// Both packs' [`Tri4::hit`] as one result.
    #[inline(always)]
    pub fn from_halves(a: Hits4, b: Hits4) -> Self {
        let cat = |x: Vec4, y: Vec4| {
            let (x, y) = (x.to_array(), y.to_array());
            [x[0], x[1], x[2], x[3], y[0], y[1], y[2], y[3]]
        };
        Hits8 { mask: a.mask | b.mask << 4, t: cat(a.t, b.t), u: cat(a.u, b.u), v: cat(a.v, b.v) }
    }

    /// The hit lane with the smallest `t` (the first such lane on ties); `mask != 0`.
    #[inline]
    pub fn nearest(&self) -> usize {
        let mut m = self.mask;
        let mut best = m.trailing_zeros() as usize;
        m &= m - 1;
        while m != 0 {
            let lane = m.trailing_zeros() as usize;
            m &= m - 1;
            if self.t[lane] < self.t[best] {
                best = lane;
            }
        }
        best
    }
}

/// [`Tri4::hit`] on both packs of a two-pack leaf at once, eight lanes per AVX operation (each
/// vector holds the first pack's four lanes, then the second's): the same operations in the same
/// order, so every lane gives bit for bit what `Tri4::hit` gives. The intrinsics are safe to
/// call here, where AVX is enabled; so is this function, from code where it is.
#[cfg(target_arch = "x86_64")]
#[cfg_attr(target_feature = "avx2", allow(dead_code))]
#[target_feature(enable = "avx")]
#[inline]
pub(super) fn hit_pair_avx(p: &Tri4, q: &Tri4, r: &Ray4, tmin: f32, tmax: f32) -> Hits8 {
    use std::arch::x86_64::*;
    type V = __m256;
    let join = |a: Vec4, b: Vec4| -> V { _mm256_set_m128(b.into(), a.into()) };
    let three = |a: &[Vec4; 3], b: &[Vec4; 3]| [join(a[0], b[0]), join(a[1], b[1]), join(a[2], b[2])];
    let splat3 = |a: &[Vec4; 3]| three(a, a);
    let (mul, add, sub) = (_mm256_mul_ps, _mm256_add_ps, _mm256_sub_ps);
    let dot = |x: &[V; 3], y: &[V; 3]| add(add(mul(x[0], y[0]), mul(x[1], y[1])), mul(x[2], y[2]));
    let cross = |x: &[V; 3], y: &[V; 3]| {
        [
            sub(mul(x[1], y[2]), mul(y[1], x[2])),
            sub(mul(x[2], y[0]), mul(y[2], x[0])),
            sub(mul(x[0], y[1]), mul(y[0], x[1])),
        ]
    };
    let (o, d) = (splat3(&r.o), splat3(&r.d));
    let (a, e1, e2) = (three(&p.a, &q.a), three(&p.e1, &q.e1), three(&p.e2, &q.e2));
    let pv = cross(&d, &e2);
    let det = dot(&e1, &pv);
    let inv = _mm256_div_ps(_mm256_set1_ps(1.0), det);
    let s = [sub(o[0], a[0]), sub(o[1], a[1]), sub(o[2], a[2])];
    let u = mul(dot(&s, &pv), inv);
    let qv = cross(&s, &e1);
    let v = mul(dot(&d, &qv), inv);
    let t = mul(dot(&e2, &qv), inv);
    // The comparisons of `Tri4::hit` (glam's: `!=` unordered, the others ordered).
    let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
    let abs = _mm256_and_ps(det, _mm256_castsi256_ps(_mm256_set1_epi32(i32::MAX)));
    let det_ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_NEQ_UQ>(det, zero),
        _mm256_cmp_ps::<_CMP_LT_OQ>(abs, _mm256_set1_ps(f32::INFINITY)),
    );
    let u_ok = _mm256_and_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(u, zero), _mm256_cmp_ps::<_CMP_LE_OQ>(u, one));
    let v_bad =
        _mm256_or_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(v, zero), _mm256_cmp_ps::<_CMP_GT_OQ>(add(u, v), one));
    let t_ok = _mm256_and_ps(
        _mm256_cmp_ps::<_CMP_GT_OQ>(t, _mm256_set1_ps(tmin)),
        _mm256_cmp_ps::<_CMP_LT_OQ>(t, _mm256_set1_ps(tmax)),
    );
    let ok = _mm256_andnot_ps(v_bad, _mm256_and_ps(_mm256_and_ps(det_ok, u_ok), t_ok));
    Hits8 {
        mask: _mm256_movemask_ps(ok) as u32,
        t: bytemuck::cast(t),
        u: bytemuck::cast(u),
        v: bytemuck::cast(v),
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

/// Packs written per batch by [`write_packs`].
const BATCH: usize = 64;

/// Writes `packs[i]`, the triangles at `order[first..first + count]` of `ranges[i] = (first,
/// count)` (`indices` into `positions`; the original indices are the packs' ids), in parallel.
///
/// A batch of [`BATCH`] packs first gathers its triangles' indices, then their vertices, into
/// local arrays, and only then builds its packs. The leaves' order has little to do with the
/// mesh's, so each triangle's index and vertices are loads from all over two arrays (the
/// dragon's: 2.4 and 1.2 MB) that mostly miss the first levels of cache. Built pack by pack,
/// a pack's few hundred instructions stood between one triangle's loads and the next's, and
/// the core waited on one miss after another (three quarters of the samples of `Tri4::new` on
/// the two loads); the gathering loops are a handful of instructions per load, so the core
/// issues the next dozens of loads while the first are on their way (measurements:
/// `docs/accel/build.md`).
pub(super) fn write_packs(
    packs: &mut [Tri4],
    ranges: &[PackRange],
    order: &[u32],
    positions: &[Vec3],
    indices: &[[u32; 3]],
) {
    assert_eq!(packs.len(), ranges.len());
    packs.par_chunks_mut(BATCH).zip(ranges.par_chunks(BATCH)).with_min_len(16).for_each(|(packs, ranges)| {
        let mut tris = [(0u32, [0u32; 3]); 4 * BATCH];
        let mut n = 0;
        for &(first, count) in ranges {
            for &id in &order[first as usize..(first + count) as usize] {
                tris[n] = (id, indices[id as usize]);
                n += 1;
            }
        }
        let mut verts = [[Vec3::ZERO; 3]; 4 * BATCH];
        for (v, (_, t)) in verts.iter_mut().zip(&tris[..n]) {
            *v = t.map(|i| positions[i as usize]);
        }
        let mut at = 0;
        for (pack, &(_, count)) in packs.iter_mut().zip(ranges) {
            let lanes = at..at + count as usize;
            *pack = Tri4::new(verts[lanes.clone()].iter().zip(&tris[lanes]).map(|(&v, &(id, _))| (v, id)));
            at += count as usize;
        }
    });
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

    /// [`write_packs`]'s batches give, byte for byte, the packs made one by one from the
    /// triangles each range names: over several batches and a partial last one, packs of one
    /// to four triangles, ranges out of order, and an order unlike the mesh's.
    #[test]
    fn batched_packs_are_the_packs_made_one_by_one() {
        let m = testmesh::sphere(24, 48);
        let tris = m.indices.len() as u32;
        // A permutation far from the identity (the leaves' order is not the mesh's): 1,031 is
        // a prime that does not divide the count.
        assert!(!tris.is_multiple_of(1031));
        let order: Vec<u32> = (0..tris).map(|i| i * 1031 % tris).collect();
        let mut sorted = order.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), tris as usize, "order is a permutation");
        let mut ranges: Vec<PackRange> = Vec::new();
        let mut first = 0;
        while first < tris {
            let count = (1 + ranges.len() as u32 % 4).min(tris - first);
            ranges.push((first, count));
            first += count;
        }
        assert!(ranges.len() > 3 * BATCH && !ranges.len().is_multiple_of(BATCH), "{} packs", ranges.len());
        // Packs in the reverse order of their ranges, so that a range's start is not the
        // running total of the counts before it.
        ranges.reverse();
        let mut packs = vec![Tri4::EMPTY; ranges.len()];
        write_packs(&mut packs, &ranges, &order, &m.positions, &m.indices);
        for (pack, &(first, count)) in packs.iter().zip(&ranges) {
            let ids = &order[first as usize..(first + count) as usize];
            let want = Tri4::new(ids.iter().map(|&id| (m.triangle(id as usize), id)));
            assert_eq!(bytemuck::bytes_of(pack), bytemuck::bytes_of(&want), "pack of {ids:?}");
        }
    }
}
