//! Next-event estimation's choice among the emitting triangles by their importance at the
//! receiver, instead of by power alone.
//!
//! A room lit by a handful of panels, windows or lamps: from a point under one panel the
//! panels across the room deliver a small share of its direct light, yet picked by power
//! they take most of its light samples. Here each triangle's importance at the receiver x is
//! its power times a bound on what it can deliver there (after pbrt-v4's light bounds):
//! the cosine at the emitter bounded over the triangle's bounding sphere (zero only where x
//! lies behind the whole sphere's emitting side), over the squared distance to its centre,
//! clamped to the sphere's radius. The choice mixes that distribution with the power one,
//! [`DEFENSIVE`] of the latter, so no triangle's probability falls below that share of its
//! power's: an importance that underestimates a triangle (near its edge, where the distance
//! to the centre overstates the distance to the triangle) costs at most that factor in noise.
//!
//! Unbiased: every emitting triangle keeps a positive probability at every receiver, and the
//! probability is a function of the receiver's position alone, so that the MIS weights of
//! every technique that meets an emitter point ask for it from the point that would sample it
//! ([`super::Emitters::nee_pdf`]). The light paths still start by power
//! ([`super::Emitters::sample`]): next-event estimation's density of a point differs from
//! theirs, as it does where it samples a sphere's cone, and the bidirectional weights take
//! both ([`crate::integrator::direct::LightSample::emission`]).
//!
//! Used where the scene's emitters are triangles only, at least [`MIN_SPATIAL`] of them (one
//! quad, the Cornell boxes, keeps the power table, where the choice could gain nothing).
//! Every light sample evaluates the importance of every entry (and every emitter hit whose
//! weight needs next-event estimation's density, again): up to [`MAX_SPATIAL`] triangles each
//! is an entry; more are split into [`MAX_SPATIAL`] clusters of nearby triangles, top down
//! as a BVH is built, so that a lamp's triangles stay together. A cluster's importance bounds
//! the cosine at its triangles by its cone of normals as well as its bounding sphere
//! ([`Spatial::clusters`], pbrt-v4's bound), and a triangle within it is picked by power.

use glam::Vec3;

use crate::sampling::reuse::ONE_BELOW;

/// Fewest emitting triangles for which next-event estimation picks by importance: one quad's
/// two triangles share a plane, and the choice between them could gain nothing.
pub const MIN_SPATIAL: usize = 3;

/// Most entries among which next-event estimation picks by importance, each light sample
/// evaluating them all: up to this many emitting triangles are each an entry, more are
/// grouped into this many clusters.
pub const MAX_SPATIAL: usize = 64;

/// The share of the power distribution in the mixture.
pub const DEFENSIVE: f32 = 0.1;

/// How next-event estimation picks an emitting triangle (`--emitter-choice`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EmitterChoice {
    /// By importance where a pilot before the render finds it more efficient than by power
    /// ([`crate::integrator::emitter_pilot`]), else by power: the default since estimator
    /// revision 18. The job records the choice made.
    #[default]
    Auto,
    /// By its importance at the receiver where the scene's emitters are at least
    /// [`MIN_SPATIAL`] triangles (and no other lights), else by power. Where a mesh lists an
    /// emitting face twice (the loader warns), light samples count that face twice and
    /// emitter hits once, in any renderer that samples emitters by area; this choice, which
    /// gives light samples more weight near emitters, shows more of it than the choice by
    /// power.
    Importance,
    /// By power alone, as the light paths start.
    Power,
}

impl std::fmt::Display for EmitterChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EmitterChoice::Auto => "auto",
            EmitterChoice::Importance => "importance",
            EmitterChoice::Power => "power",
        })
    }
}

impl std::str::FromStr for EmitterChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(EmitterChoice::Auto),
            "importance" => Ok(EmitterChoice::Importance),
            "power" => Ok(EmitterChoice::Power),
            _ => Err(format!("unknown emitter choice {s:?} (expected auto, importance or power)")),
        }
    }
}

/// Lanes of the bounds: a multiple of sixteen, so that the importances are computed in
/// whole vectors of the widest ISA the walker is compiled for.
const LANES: usize = 16;

/// An emitting triangle as [`Spatial::new`] takes it: its corners, unit geometric normal,
/// probability in the power table and area.
pub type Triangle = ([Vec3; 3], Vec3, f32, f32);

/// How the importance of an entry is bounded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bound {
    /// Each entry is one triangle: its normal and bounding sphere ([`Spatial::triangles`]).
    Triangles,
    /// Each entry is a cluster of triangles: a cone of normals and a bounding sphere
    /// ([`Spatial::clusters`]).
    Clusters,
}

/// The bounds of the emitting triangles, one entry per triangle where they are at most
/// [`MAX_SPATIAL`], else per cluster of nearby triangles ([`MAX_SPATIAL`] of them), in
/// structure of arrays padded to a multiple of [`LANES`] (padding: power zero). A cluster
/// is picked by importance and a triangle within it by power.
#[derive(Clone, Debug)]
pub struct Spatial {
    /// Each triangle's area, in the order of the power table: their number is its length.
    area: Vec<f32>,
    /// Each triangle's entry.
    entry_of: Vec<u32>,
    /// Each triangle's share of its entry's power (1 where the entry is the triangle).
    within: Vec<f32>,
    /// The triangles of each entry, entry by entry: those of entry k are
    /// `members[start[k]..start[k + 1]]`.
    members: Vec<u32>,
    start: Vec<u32>,
    /// Each member's cumulative share of its entry's power before it, as `members`.
    below: Vec<f64>,
    bound: Bound,
    /// The centre of each entry's bounding sphere, by coordinate.
    centre: [Vec<f32>; 3],
    /// Its unit normal (a triangle's geometric normal, a cluster's cone axis), by coordinate:
    /// it emits on this side.
    normal: [Vec<f32>; 3],
    /// The cosine and sine of a cluster's cone of normals about the axis (a cosine of −1: the
    /// normals spread over a half-space or more, and the cone bounds nothing).
    cos_spread: Vec<f32>,
    sin_spread: Vec<f32>,
    /// The radius of its bounding sphere.
    radius: Vec<f32>,
    /// Its probability in the power table.
    power: Vec<f32>,
}

impl Spatial {
    /// The bounds of `triangles` in the power table's order; `None` where there are fewer
    /// than [`MIN_SPATIAL`].
    pub fn new(triangles: impl ExactSizeIterator<Item = Triangle>) -> Option<Spatial> {
        let triangles: Vec<Triangle> = triangles.collect();
        let len = triangles.len();
        if len < MIN_SPATIAL || len > u32::MAX as usize {
            return None;
        }
        let entries: Vec<Vec<u32>> = if len <= MAX_SPATIAL {
            (0..len as u32).map(|i| vec![i]).collect()
        } else {
            clusters(&triangles)
        };
        let bound = if len <= MAX_SPATIAL { Bound::Triangles } else { Bound::Clusters };
        let padded = entries.len().div_ceil(LANES) * LANES;
        let lanes = |v: f32| vec![v; padded];
        let mut s = Spatial {
            area: triangles.iter().map(|t| t.3).collect(),
            entry_of: vec![0; len],
            within: vec![1.0; len],
            members: Vec::with_capacity(len),
            start: vec![0],
            below: Vec::with_capacity(len),
            bound,
            centre: [lanes(0.0), lanes(0.0), lanes(0.0)],
            normal: [lanes(0.0), lanes(0.0), lanes(1.0)],
            cos_spread: lanes(1.0),
            sin_spread: lanes(0.0),
            radius: lanes(1.0),
            power: lanes(0.0),
        };
        for (k, members) in entries.iter().enumerate() {
            let tris = || members.iter().map(|&i| &triangles[i as usize]);
            let corners = || tris().flat_map(|t| t.0);
            // A triangle's sphere is about its centroid, a cluster's about its box's centre.
            let centre = if members.len() == 1 {
                corners().sum::<Vec3>() / 3.0
            } else {
                let (lo, hi) = corners()
                    .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
                (lo + hi) / 2.0
            };
            let r = corners().map(|v| (v - centre).length()).fold(0.0f32, f32::max);
            let axis = tris().map(|t| t.1 * t.3).sum::<Vec3>().normalize_or_zero();
            let cos = tris().map(|t| t.1.dot(axis)).fold(1.0f32, f32::min);
            let power: f32 = tris().map(|t| t.2).sum();
            let normal = if let [i] = members[..] { triangles[i as usize].1 } else { axis };
            for c in 0..3 {
                s.centre[c][k] = centre[c];
                s.normal[c][k] = normal[c];
            }
            (s.cos_spread[k], s.sin_spread[k]) = if axis != Vec3::ZERO && cos > 0.0 {
                (cos.min(1.0), (1.0 - cos * cos).max(0.0).sqrt())
            } else {
                (-1.0, 0.0)
            };
            s.radius[k] = r.max(f32::MIN_POSITIVE.sqrt());
            s.power[k] = power;
            let mut below = 0.0f64;
            for &i in members {
                s.entry_of[i as usize] = k as u32;
                if members.len() > 1 {
                    s.within[i as usize] = if power > 0.0 {
                        triangles[i as usize].2 / power
                    } else {
                        1.0 / members.len() as f32
                    };
                }
                s.below.push(below);
                below += s.within[i as usize] as f64;
            }
            s.members.extend_from_slice(members);
            s.start.push(s.members.len() as u32);
        }
        Some(s)
    }

    /// The number of entries among which the importance picks (triangles or clusters).
    pub fn entries(&self) -> usize {
        self.start.len() - 1
    }

    /// The area density of a point of triangle `i` picked with probability `pmf`.
    #[inline(always)]
    pub fn pdf_area(&self, i: usize, pmf: f32) -> f32 {
        pmf / self.area[i]
    }

    /// Every entry's importance at `x`, up to a common factor, into `out` (padding
    /// included).
    #[inline(always)]
    fn importances(&self, x: Vec3, out: &mut [f32]) {
        match self.bound {
            Bound::Triangles => self.triangles(x, out),
            Bound::Clusters => self.clusters(x, out),
        }
    }

    /// A triangle's importance: its power times a bound on the emitter's cosine towards `x`
    /// over the squared distance to its centre. For a point y of the bounding sphere (centre
    /// c, radius r) at distance d = |x − c| > r, n · (x − y) ≤ n · (x − c) + r and
    /// |x − y| ≥ d − r, so the cosine is at most (n · (x − c) + r) / (d − r), and at most 1.
    /// One square root and one division per triangle, without branches, so that it runs in
    /// vectors.
    #[inline(always)]
    fn triangles(&self, x: Vec3, out: &mut [f32]) {
        let [cx, cy, cz] = &self.centre;
        let [nx, ny, nz] = &self.normal;
        let lanes =
            out.iter_mut().zip(cx).zip(cy).zip(cz).zip(nx).zip(ny).zip(nz).zip(&self.radius).zip(&self.power);
        for ((((((((o, &cx), &cy), &cz), &nx), &ny), &nz), &r), &p) in lanes {
            let (dx, dy, dz) = (x.x - cx, x.y - cy, x.z - cz);
            let d2 = dx * dx + dy * dy + dz * dz;
            let gap = d2.sqrt() - r;
            let facing = (nx * dx + ny * dy + nz * dz + r).max(0.0);
            // p · min(1, facing / gap) / d², and within the bounding sphere (gap ≤ 0) any
            // cosine with the distance clamped to the radius: p / r².
            let value = if gap > 0.0 { p * facing.min(gap) / (gap * d2) } else { p / (r * r) };
            *o = if value.is_finite() { value } else { 0.0 };
        }
    }

    /// A cluster's importance: its power times a bound on the cosine at any of its
    /// triangles towards `x` over the squared distance to its centre (at least its radius),
    /// after pbrt-v4's light bounds. With θ the angle between the cone's axis and the
    /// direction from the centre to `x`, θ_o the cone's spread and θ_b the angle under which
    /// the bounding sphere is seen from `x`, no normal of the cluster makes an angle below
    /// θ − θ_o − θ_b with the direction from any of its points to `x`, so the cosine is at
    /// most cos(max(0, θ − θ_o − θ_b)), by the angle-sum formulas (θ_o < π/2 and θ_b < π/2
    /// where the cone bounds: the sum stays below π). Within the sphere, or where the cone
    /// bounds nothing, the bound is 1.
    #[inline(always)]
    fn clusters(&self, x: Vec3, out: &mut [f32]) {
        let [cx, cy, cz] = &self.centre;
        let [nx, ny, nz] = &self.normal;
        let lanes = out
            .iter_mut()
            .zip(cx)
            .zip(cy)
            .zip(cz)
            .zip(nx)
            .zip(ny)
            .zip(nz)
            .zip(&self.cos_spread)
            .zip(&self.sin_spread)
            .zip(&self.radius)
            .zip(&self.power);
        for ((((((((((o, &cx), &cy), &cz), &nx), &ny), &nz), &cos_o), &sin_o), &r), &p) in lanes {
            let (dx, dy, dz) = (x.x - cx, x.y - cy, x.z - cz);
            let d2 = dx * dx + dy * dy + dz * dz;
            let d = d2.sqrt();
            let cos_t = (nx * dx + ny * dy + nz * dz) / d;
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            let sin_b = (r / d).min(1.0);
            let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
            let cos_a = cos_o * cos_b - sin_o * sin_b;
            let sin_a = sin_o * cos_b + cos_o * sin_b;
            let beyond = (cos_t * cos_a + sin_t * sin_a).max(0.0);
            let cone = if cos_t < cos_a && d > r && cos_o > -0.5 { beyond } else { 1.0 };
            let value = p * cone / d2.max(r * r);
            *o = if value.is_finite() { value } else { 0.0 };
        }
    }

    /// The probability of each entry for a receiver at `x` into `out[..padded]`: the
    /// importance's share mixed with the power table's, [`DEFENSIVE`] of it (the power
    /// table's alone where no importance is positive and finite).
    #[inline(always)]
    fn pmfs(&self, x: Vec3, out: &mut [f32; MAX_SPATIAL]) {
        let padded = self.power.len();
        let out = &mut out[..padded];
        self.importances(x, out);
        let total: f32 = out.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            out.copy_from_slice(&self.power);
            return;
        }
        for (o, &p) in out.iter_mut().zip(&self.power) {
            *o = (1.0 - DEFENSIVE) * (*o / total) + DEFENSIVE * p;
        }
    }

    /// The probability of picking triangle `i` for a receiver at `x`, as [`Spatial::pick`]
    /// picks it: its entry's, times its share of the entry's power.
    #[inline]
    pub fn pmf(&self, x: Vec3, i: usize) -> f32 {
        let mut pmfs = [0.0f32; MAX_SPATIAL];
        self.pmfs(x, &mut pmfs);
        pmfs[self.entry_of[i] as usize] * self.within[i]
    }

    /// A triangle for a receiver at `x` from the number `u` in [0, 1): an entry by the
    /// inverse of the cumulative distribution of the entries' probabilities, then a triangle
    /// of it by the inverse of their shares of its power, from what is left of `u`. Its
    /// index, its probability and what is left of `u`, uniform in [0, 1) given the choice
    /// (sample reuse, as the power table's [`crate::sampling::AliasTable::sample_reuse`]).
    #[inline(always)]
    pub fn pick(&self, x: Vec3, u: f64) -> (usize, f32, f64) {
        let mut pmfs = [0.0f32; MAX_SPATIAL];
        self.pmfs(x, &mut pmfs);
        let (k, p, rest) = invert(&pmfs[..self.entries()], u);
        let range = self.start[k] as usize..self.start[k + 1] as usize;
        if range.len() == 1 {
            return (self.members[range.start] as usize, p, rest);
        }
        // Within the cluster by its cumulative shares (`below[0]` = 0 ≤ rest).
        let below = &self.below[range.clone()];
        let mut j = below.partition_point(|&c| c <= rest) - 1;
        // (Past the end by rounding onto a member of no share: the last one with a share.)
        while j > 0 && self.within[self.members[range.start + j] as usize] <= 0.0 {
            j -= 1;
        }
        let i = self.members[range.start + j] as usize;
        let w = self.within[i];
        (i, p * w, ((rest - below[j]) / w as f64).clamp(0.0, ONE_BELOW))
    }
}

/// The index of `pmfs` that the number `u` in [0, 1) picks by the inverse of the cumulative
/// sums, its probability and what is left of `u`, uniform in [0, 1) given the choice. The
/// last index of positive probability takes what rounding leaves over.
#[inline(always)]
fn invert(pmfs: &[f32], u: f64) -> (usize, f32, f64) {
    let n = pmfs.len();
    let last = (0..n).rev().find(|&i| pmfs[i] > 0.0).unwrap_or(n - 1);
    let mut lo = 0.0f64;
    for (i, &p) in pmfs.iter().enumerate() {
        if p <= 0.0 {
            continue;
        }
        let hi = lo + p as f64;
        if u < hi || i == last {
            let rest = ((u - lo) / p as f64).clamp(0.0, ONE_BELOW);
            return (i, p, rest);
        }
        lo = hi;
    }
    (last, pmfs[last], 0.0)
}

/// The triangles split into [`MAX_SPATIAL`] clusters of nearby ones: the cluster whose
/// centroids spread furthest is halved at the median along its longest axis, until there
/// are as many clusters (or none can be split: each is one triangle, or its centroids
/// coincide). Top down, as a BVH's build, so that a lamp's triangles stay together.
fn clusters(triangles: &[Triangle]) -> Vec<Vec<u32>> {
    let centroid = |i: u32| triangles[i as usize].0.iter().sum::<Vec3>() / 3.0;
    // A cluster's extent: its centroids' bounding box diagonal and longest axis.
    let extent = |members: &[u32]| {
        let (lo, hi) = members
            .iter()
            .map(|&i| centroid(i))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), c| (lo.min(c), hi.max(c)));
        let size = hi - lo;
        (size.length(), size.max_position())
    };
    let all: Vec<u32> = (0..triangles.len() as u32).collect();
    let mut leaves = vec![(extent(&all), all)];
    while leaves.len() < MAX_SPATIAL {
        let widest = leaves
            .iter()
            .enumerate()
            .filter(|(_, ((size, _), m))| m.len() > 1 && *size > 0.0)
            .max_by(|a, b| a.1.0.0.total_cmp(&b.1.0.0))
            .map(|(j, _)| j);
        let Some(j) = widest else { break };
        let ((_, axis), mut members) = leaves.swap_remove(j);
        members.sort_by(|&a, &b| centroid(a)[axis].total_cmp(&centroid(b)[axis]).then(a.cmp(&b)));
        let right = members.split_off(members.len() / 2);
        leaves.push((extent(&members), members));
        leaves.push((extent(&right), right));
    }
    leaves.into_iter().map(|(_, m)| m).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three unit right triangles facing +z, at x = 0, 5 and 10 on the plane z = 0, the last
    /// with three times the power; and one facing −z.
    fn panels() -> Spatial {
        let tri = |x: f32, n: Vec3| {
            ([Vec3::new(x, 0.0, 0.0), Vec3::new(x + 1.0, 0.0, 0.0), Vec3::new(x, 1.0, 0.0)], n)
        };
        let t = [tri(0.0, Vec3::Z), tri(5.0, Vec3::Z), tri(10.0, Vec3::Z), tri(15.0, -Vec3::Z)];
        let power = [1.0 / 6.0, 1.0 / 6.0, 3.0 / 6.0, 1.0 / 6.0];
        Spatial::new(t.into_iter().zip(power).map(|((c, n), p)| (c, n, p, 0.5))).unwrap()
    }

    #[test]
    fn the_nearest_panel_in_front_is_preferred_and_every_panel_keeps_its_defensive_share() {
        let s = panels();
        let x = Vec3::new(0.3, 0.3, 1.0);
        let p: Vec<f32> = (0..4).map(|i| s.pmf(x, i)).collect();
        assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{p:?}");
        assert!(p[0] > 0.8, "{p:?}");
        for (i, &pi) in p.iter().enumerate() {
            assert!(pi >= DEFENSIVE * s.power[i] * (1.0 - 1e-5), "{i}: {p:?}");
        }
        // Behind every panel's emitting side but the last's: that one takes the importance.
        let below = Vec3::new(15.3, 0.3, -1.0);
        assert!(s.pmf(below, 3) > 0.9);
        // Within a triangle's bounding sphere, on its plane, and beyond the padding.
        for x in [Vec3::new(0.2, 0.2, 0.0), Vec3::new(0.3, 0.3, 1e-30), Vec3::new(3.0, 0.5, 0.0)] {
            let p: Vec<f32> = (0..4).map(|i| s.pmf(x, i)).collect();
            assert!(p.iter().all(|p| p.is_finite() && *p > 0.0), "{x}: {p:?}");
            assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-5, "{x}: {p:?}");
        }
    }

    /// Picking by the cumulative sums gives each triangle its probability, and the rest of
    /// the number is uniform within the choice.
    #[test]
    fn picks_follow_the_pmf_and_reuse_the_number() {
        let s = panels();
        let x = Vec3::new(6.0, -2.0, 3.0);
        let n = 100_000;
        let mut counts = [0usize; 4];
        let mut rest_sum = [0.0f64; 4];
        for k in 0..n {
            let u = (k as f64 + 0.5) / n as f64;
            let (i, p, rest) = s.pick(x, u);
            assert_eq!(p, s.pmf(x, i));
            assert!((0.0..1.0).contains(&rest));
            counts[i] += 1;
            rest_sum[i] += rest;
        }
        for i in 0..4 {
            let want = s.pmf(x, i) as f64;
            assert!((counts[i] as f64 / n as f64 - want).abs() < 1e-3, "{i}: {counts:?}");
            assert!((rest_sum[i] / counts[i] as f64 - 0.5).abs() < 1e-2, "{i}");
        }
    }

    #[test]
    fn a_quad_keeps_the_power_table_and_many_triangles_are_clustered() {
        let tri = ([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::Z, 0.5, 0.5);
        assert!(Spatial::new([tri, tri].into_iter()).is_none());
        let s = Spatial::new(std::iter::repeat_n(tri, MAX_SPATIAL)).unwrap();
        assert_eq!((s.bound, s.entries()), (Bound::Triangles, MAX_SPATIAL));
        // Coincident triangles cannot be split: one cluster.
        let s = Spatial::new(std::iter::repeat_n(tri, MAX_SPATIAL + 1)).unwrap();
        assert_eq!((s.bound, s.entries()), (Bound::Clusters, 1));
        let s = bulbs();
        assert_eq!((s.bound, s.entries()), (Bound::Clusters, MAX_SPATIAL));
    }

    /// 30 bulbs on a 6 × 5 grid 3 apart at height 2, each an octahedron of half-width 0.2 (8
    /// triangles facing out, 240 in all), of powers 1 to 5 by column.
    fn bulbs() -> Spatial {
        let mut t = Vec::new();
        for i in 0..6 {
            for j in 0..5 {
                let c = Vec3::new(3.0 * i as f32, 2.0, 3.0 * j as f32);
                let h = 0.2;
                for sx in [-1.0f32, 1.0] {
                    for sy in [-1.0f32, 1.0] {
                        for sz in [-1.0f32, 1.0] {
                            let mut v = [c + Vec3::X * sx * h, c + Vec3::Y * sy * h, c + Vec3::Z * sz * h];
                            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                            if n.dot(v[0] - c) < 0.0 {
                                v.swap(1, 2);
                            }
                            let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize();
                            let area = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
                            t.push((v, n, (1 + i % 5) as f32, area));
                        }
                    }
                }
            }
        }
        let total: f32 = t.iter().map(|t| t.2).sum();
        Spatial::new(t.into_iter().map(|(v, n, p, a)| (v, n, p / total, a))).unwrap()
    }

    /// With clusters: the triangles' probabilities sum to one and keep their defensive
    /// share, the picks follow them, and the rest of the number is uniform.
    #[test]
    fn clustered_picks_follow_the_pmf_and_keep_the_defensive_share() {
        let s = bulbs();
        for x in [
            Vec3::new(0.1, 0.0, 0.2),
            Vec3::new(7.5, 2.0, 6.0),
            Vec3::new(3.0, 2.0, 3.0),
            Vec3::new(-30.0, 9.0, 4.0),
        ] {
            let p: Vec<f32> = (0..240).map(|i| s.pmf(x, i)).collect();
            assert!((p.iter().sum::<f32>() - 1.0).abs() < 1e-4, "{x}");
            let total: f32 = s.power.iter().sum();
            for (i, &pi) in p.iter().enumerate() {
                let power = s.power[s.entry_of[i] as usize] * s.within[i] / total;
                assert!(pi >= DEFENSIVE * power * (1.0 - 1e-4), "{x}, {i}: {pi} against {power}");
            }
            let n = 200_000;
            let (mut counts, mut rest_sum) = (vec![0usize; 240], vec![0.0f64; 240]);
            for k in 0..n {
                let (i, pi, rest) = s.pick(x, (k as f64 + 0.5) / n as f64);
                assert!((pi - p[i]).abs() <= 1e-6 * p[i], "{x}, {i}");
                assert!((0.0..1.0).contains(&rest));
                counts[i] += 1;
                rest_sum[i] += rest;
            }
            for i in 0..240 {
                assert!((counts[i] as f64 / n as f64 - p[i] as f64).abs() < 2e-4, "{x}, {i}: {}", counts[i]);
                if counts[i] > 100 {
                    assert!((rest_sum[i] / counts[i] as f64 - 0.5).abs() < 0.02, "{x}, {i}");
                }
            }
        }
        // Under a bulb, its triangles take several times their share of the power (2 / 80).
        let under = Vec3::new(3.0, 0.0, 3.0);
        let near: f32 = (0..240).filter(|&i| i / 8 == 6).map(|i| s.pmf(under, i)).sum();
        assert!(near > 4.0 * 2.0 / 80.0, "{near}");
    }

    /// A cluster's bound holds: at no point of its triangles does the cosine towards the
    /// receiver exceed the bound that its importance takes (random clusters of tilted
    /// triangles, receivers near and far, in front and behind).
    #[test]
    fn the_cone_bound_is_never_below_a_cosine_it_bounds() {
        let mut seed = 1u64;
        let mut rnd = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        for _ in 0..200 {
            // 80 triangles: a patch of 2 × 2 around a random centre, normals tilted from +z.
            let tilt = rnd() * 1.2;
            let mut t = Vec::new();
            for k in 0..80 {
                let c = Vec3::new(rnd() * 2.0, rnd() * 2.0, rnd() * 0.3);
                let n = Vec3::new(tilt * (rnd() - 0.5), tilt * (rnd() - 0.5), 1.0).normalize();
                let f = crate::geometry::Frame::from_normal(n);
                let v = [c, c + f.s * 0.1, c + f.t * 0.1];
                t.push((v, n, 1.0 / 80.0, 0.005 + k as f32 * 0.0));
            }
            let s = Spatial::new(t.clone().into_iter()).unwrap();
            let mut out = [0.0f32; MAX_SPATIAL];
            for _ in 0..20 {
                let x = Vec3::new(rnd() * 8.0 - 3.0, rnd() * 8.0 - 3.0, rnd() * 8.0 - 4.0);
                s.clusters(x, &mut out);
                for (i, (v, n, ..)) in t.iter().enumerate() {
                    let k = s.entry_of[i] as usize;
                    let (c, r) = (Vec3::new(s.centre[0][k], s.centre[1][k], s.centre[2][k]), s.radius[k]);
                    let bound = out[k] * (x - c).length_squared().max(r * r) / s.power[k];
                    for w in [1.0f32, 0.0, 0.5] {
                        let y = v[0] * (1.0 - w) + (v[1] + v[2]) * (w / 2.0);
                        let cos = n.dot((x - y).normalize());
                        assert!(
                            cos <= bound + 1e-4,
                            "{x}: cosine {cos} at triangle {i} above the bound {bound}"
                        );
                    }
                }
            }
        }
    }
}
