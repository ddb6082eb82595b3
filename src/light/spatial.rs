//! Next-event estimation's choice among a few emitting triangles by their importance at the
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
//! Used where the scene's emitters are triangles only, [`MIN_SPATIAL`] to [`MAX_SPATIAL`] of
//! them: every light sample evaluates every triangle's importance (and every emitter hit
//! whose weight needs next-event estimation's density, again), which pays for a few; one
//! quad (the Cornell boxes) keeps the power table, where the choice could gain nothing.

use glam::Vec3;

use crate::sampling::reuse::ONE_BELOW;

/// Fewest emitting triangles for which next-event estimation picks by importance: one quad's
/// two triangles share a plane, and the choice between them could gain nothing.
pub const MIN_SPATIAL: usize = 3;

/// Most emitting triangles for which next-event estimation picks by importance: each light
/// sample evaluates them all.
pub const MAX_SPATIAL: usize = 64;

/// The share of the power distribution in the mixture.
pub const DEFENSIVE: f32 = 0.1;

/// How next-event estimation picks an emitting triangle (`--emitter-choice`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EmitterChoice {
    /// By its importance at the receiver where the scene's emitters are [`MIN_SPATIAL`] to
    /// [`MAX_SPATIAL`] triangles, else by power. Not the default yet: it gives next-event
    /// estimation more weight near emitters, and where a mesh lists an emitting face twice
    /// (McGuire's Cornell boxes list one face of each box twice, which the glowing box of
    /// `tests/data/` makes emit) light samples count that face twice and emitter hits once,
    /// so its image is further from Mitsuba 3's there than by power. It waits for a clean
    /// many-light scene measured against Mitsuba.
    Importance,
    /// By power alone, as the light paths start.
    #[default]
    Power,
}

impl std::fmt::Display for EmitterChoice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EmitterChoice::Importance => "importance",
            EmitterChoice::Power => "power",
        })
    }
}

impl std::str::FromStr for EmitterChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "importance" => Ok(EmitterChoice::Importance),
            "power" => Ok(EmitterChoice::Power),
            _ => Err(format!("unknown emitter choice {s:?} (expected importance or power)")),
        }
    }
}

/// Lanes of the bounds: a multiple of sixteen, so that the importances are computed in
/// whole vectors of the widest ISA the walker is compiled for.
const LANES: usize = 16;

/// The bounds of the emitting triangles, in the order of the scene's power table, in
/// structure of arrays padded to a multiple of [`LANES`] (padding: power zero).
#[derive(Clone, Debug)]
pub struct Spatial {
    /// Each triangle's area, not padded: their number is its length.
    area: Vec<f32>,
    /// The centre of each triangle's bounding sphere (the centroid), by coordinate.
    centre: [Vec<f32>; 3],
    /// Its unit geometric normal, by coordinate: it emits on this side.
    normal: [Vec<f32>; 3],
    /// The radius of its bounding sphere about the centroid.
    radius: Vec<f32>,
    /// Its probability in the power table.
    power: Vec<f32>,
}

impl Spatial {
    /// The bounds of triangles given by their corners, unit normals, probabilities in the
    /// power table and areas; `None` where there are fewer than [`MIN_SPATIAL`] or more than
    /// [`MAX_SPATIAL`].
    pub fn new(triangles: impl ExactSizeIterator<Item = ([Vec3; 3], Vec3, f32, f32)>) -> Option<Spatial> {
        let len = triangles.len();
        if !(MIN_SPATIAL..=MAX_SPATIAL).contains(&len) {
            return None;
        }
        let padded = len.div_ceil(LANES) * LANES;
        let lanes = |v: f32| vec![v; padded];
        let mut s = Spatial {
            area: vec![0.0; len],
            centre: [lanes(0.0), lanes(0.0), lanes(0.0)],
            normal: [lanes(0.0), lanes(0.0), lanes(1.0)],
            radius: lanes(1.0),
            power: lanes(0.0),
        };
        for (i, ([a, b, c], n, pmf, area)) in triangles.enumerate() {
            let centre = (a + b + c) / 3.0;
            let r = [a, b, c].iter().map(|&v| (v - centre).length()).fold(0.0f32, f32::max);
            for k in 0..3 {
                s.centre[k][i] = centre[k];
                s.normal[k][i] = n[k];
            }
            s.radius[i] = r.max(f32::MIN_POSITIVE.sqrt());
            s.power[i] = pmf;
            s.area[i] = area;
        }
        Some(s)
    }

    /// The area density of a point of triangle `i` picked with probability `pmf`.
    #[inline(always)]
    pub fn pdf_area(&self, i: usize, pmf: f32) -> f32 {
        pmf / self.area[i]
    }

    /// Every triangle's importance at `x`, up to a common factor, into `out` (padding
    /// included): its power times a bound on the emitter's cosine towards `x` over the
    /// squared distance to its centre. For a point y of the bounding sphere (centre c,
    /// radius r) at distance d = |x − c| > r, n · (x − y) ≤ n · (x − c) + r and
    /// |x − y| ≥ d − r, so the cosine is at most (n · (x − c) + r) / (d − r), and at most 1.
    /// One square root and one division per triangle, without branches, so that it runs in
    /// vectors.
    #[inline(always)]
    fn importances(&self, x: Vec3, out: &mut [f32]) {
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

    /// The probability of each triangle for a receiver at `x` into `out[..len]`: the
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
    /// picks it.
    #[inline]
    pub fn pmf(&self, x: Vec3, i: usize) -> f32 {
        let mut pmfs = [0.0f32; MAX_SPATIAL];
        self.pmfs(x, &mut pmfs);
        pmfs[i]
    }

    /// A triangle for a receiver at `x` from the number `u` in [0, 1), by the inverse of the
    /// cumulative distribution in the table's order: its index, its probability and what is
    /// left of `u`, uniform in [0, 1) given the choice (sample reuse, as the power table's
    /// [`crate::sampling::AliasTable::sample_reuse`]). The last triangle of positive
    /// probability takes what rounding leaves over.
    #[inline(always)]
    pub fn pick(&self, x: Vec3, u: f64) -> (usize, f32, f64) {
        let mut pmfs = [0.0f32; MAX_SPATIAL];
        self.pmfs(x, &mut pmfs);
        let n = self.area.len();
        let last = (0..n).rev().find(|&i| pmfs[i] > 0.0).unwrap_or(n - 1);
        let mut lo = 0.0f64;
        for (i, &p) in pmfs[..n].iter().enumerate() {
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
    fn a_quad_or_too_many_triangles_keep_the_power_table() {
        let tri = ([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::Z, 0.5, 0.5);
        assert!(Spatial::new([tri, tri].into_iter()).is_none());
        assert!(Spatial::new(std::iter::repeat_n(tri, MAX_SPATIAL + 1)).is_none());
        assert!(Spatial::new(std::iter::repeat_n(tri, MAX_SPATIAL)).is_some());
    }
}
