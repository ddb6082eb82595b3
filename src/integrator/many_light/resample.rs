//! The resampled gather: a receiver estimates the unoccluded contribution of a random window
//! of about m candidate lights (cheap: an eight-wide kernel, no ray), then evaluates and traces
//! shadow rays to only k of them, drawn in proportion to those estimates.
//!
//! Two stages, each unbiased given the one before, so the estimate is unbiased for the
//! iteration's full gather Σ_j c_j V_j (c_j the unoccluded contribution of light j with the
//! iteration's bound or radius, V_j its visibility):
//!
//! 1. **The window.** The lights are stored path by path; the window is an aligned run of g
//!    consecutive light paths (g a power of two), one of the W runs of the iteration,
//!    uniformly ([`super::window`]). Every light lies in exactly one run, so
//!    W Σ_{j ∈ window} c_j V_j is unbiased for the full sum (Horvitz–Thompson with inclusion
//!    probability 1 / W). With Sobol points such a run's paths are a net, as evenly spread as
//!    an iteration of g paths. Where the iteration has two runs or fewer, the window is all the
//!    lights.
//! 2. **The picks.** Within the window, with p̂_j an estimate of light j's unoccluded
//!    contribution and T = Σ p̂_j, k picks by systematic sampling of the cumulative sums at
//!    (u + i) T / k: light j is picked n_j times with E\[n_j\] = k p̂_j / T, and
//!    Σ_j n_j c_j V_j T / (k p̂_j) is unbiased for Σ_{window} c_j V_j as long as every light
//!    with c_j ≠ 0 has p̂_j > 0. Only the picked lights' contributions c_j are evaluated.
//!    For points p̂ is `VplLanes::push_estimates` (power × the clamped geometry term, eight
//!    at a time, with a bound on a glossy receiver's lobe where the gather weighs by it,
//!    [`super::lobe`], and `pir-bdpt`'s connection weight,
//!    [`super::bidirectional::DrawWeights`]; the VPLs' BSDF shapes left out). For spheres it is `SphereLanes::estimates`, in the
//!    contribution's units: both ends taken as Lambertian of their reflectance, each cosine
//!    at its largest over the cone, which bounds a Lambertian pair's contribution from above
//!    (a pick's weight is then at most T / k); where either end has a narrow glossy lobe
//!    (GGX α below `NARROW_LOBE`, whose peak no such bound follows), the sphere's
//!    contribution itself is evaluated as its p̂ and kept as its value, so its weight is
//!    T / k exactly.
//!
//! A glossy sphere's cone integral is stochastic ([`super::spheres`]): an estimate ĉ_j with
//! E\[ĉ_j\] = c_j. Drawn after the pick, from numbers that did not choose it, or as the
//! candidate's own p̂ and value (n_j ĉ_j T / (k ĉ_j), whose expectation given ĉ_j is ĉ_j), the
//! estimate stays unbiased. Only the k picked spheres and the narrow-lobed candidates pay for
//! their integrals, not all m candidates (`docs/measurements.md`: 3.3× fewer instructions for
//! `pir-vsl` on the glossy Cornell box than when every candidate's integral was its p̂).
//!
//! Why it pays: an iteration can hold many more light paths than a full gather affords, since a
//! receiver's cost is m kernel evaluations and k rays, not one ray per light; the light paths'
//! noise falls with their number, and within the window the rays go where the light is. What
//! is left is the noise of visibility among the k picks and of the window's choice of paths.

use glam::Vec4;

use super::window::{LightPaths, Window};
use crate::sampling::Sampler;

/// Most candidates per receiver (`--gather-candidates`).
pub const MAX_CANDIDATES: usize = 1024;

/// Lights per chunk (a block of candidates, a chunk of the lanes of [`super::lanes`]): the
/// width of `Vec4`.
pub const LANES: usize = 4;

/// The resampled gather over the lights of `paths` with about `m` candidates and `k` picks:
/// draws the window ([`LightPaths::draw`]) and the picks' number (two numbers of `sampler`,
/// always, before any the candidates draw), lets `candidate` push the window's chunks in
/// light order ([`Window::chunks`]), then calls `emit(j, factor, sampler)` for every light
/// picked, with the window's scale W in the factor ([`Candidates::pick`]); `emit` may draw
/// numbers of its own (a picked sphere's cone integral). With `active` false (a receiver
/// that reflects nothing) only the numbers are drawn.
pub fn resample(
    paths: &LightPaths,
    m: usize,
    k: usize,
    active: bool,
    sampler: &mut Sampler,
    mut candidate: impl FnMut(&mut Candidates, &Window, &mut Sampler),
    mut emit: impl FnMut(usize, f32, &mut Sampler),
) {
    let window = paths.draw(paths.window_paths(m), sampler);
    let u = sampler.next_f32();
    if !active || window.lights.is_empty() {
        return;
    }
    let scale = window.scale;
    with_candidates(|cands| {
        candidate(cands, &window, sampler);
        cands.pick(k, u, scale, |j, factor| emit(j, factor, sampler));
    });
}

/// The candidates of one receiver in blocks of [`LANES`] lights (a chunk of the lanes of
/// points or of spheres): p̂ lane by lane, and the lane-wise sum of p̂ over the blocks. Blocks whose lights all contribute
/// nothing are left out. Reused from receiver to receiver (`with_candidates`), so that a
/// gather allocates nothing. Pushing is branch-light and sums lane-wise; the cumulative sums
/// are formed only while picking, and only up to the last pick.
#[derive(Default)]
pub struct Candidates {
    /// The first light of each block.
    first: Vec<u32>,
    /// p̂ of each block's lanes.
    p: Vec<Vec4>,
    /// Σ p̂ over the blocks, lane by lane.
    sum: Vec4,
}

thread_local! {
    static CANDIDATES: std::cell::RefCell<Candidates> = std::cell::RefCell::default();
}

/// Runs `f` with this thread's candidates, emptied.
fn with_candidates<R>(f: impl FnOnce(&mut Candidates) -> R) -> R {
    CANDIDATES.with(|c| {
        let mut c = c.borrow_mut();
        c.clear();
        f(&mut c)
    })
}

impl Candidates {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn clear(&mut self) {
        self.first.clear();
        self.p.clear();
        self.sum = Vec4::ZERO;
    }

    /// Blocks held.
    pub fn len(&self) -> usize {
        self.first.len()
    }

    pub fn is_empty(&self) -> bool {
        self.first.is_empty()
    }

    /// Adds the block of lights `first`, `first` + 1, … with estimates `p` (p̂ by lane). A
    /// lane whose p̂ is not a positive finite number is left out (a non-finite one is a light
    /// that would make the pixel infinite in a full gather).
    #[inline]
    pub fn push(&mut self, first: usize, p: Vec4) {
        if let Some(p) = Self::kept(p) {
            self.first.push(first as u32);
            self.p.push(p);
            self.sum += p;
        }
    }

    /// The lanes of `p` that are positive and finite (the others zero), unless none is.
    #[inline]
    fn kept(p: Vec4) -> Option<Vec4> {
        let keep = p.cmpgt(Vec4::ZERO) & p.is_finite_mask();
        keep.any().then(|| Vec4::select(keep, p, Vec4::ZERO))
    }

    /// The blocks held: each one's first light and p̂.
    #[cfg(test)]
    pub fn blocks(&self) -> impl Iterator<Item = (u32, Vec4)> + '_ {
        self.first.iter().copied().zip(self.p.iter().copied())
    }

    /// T = Σ p̂.
    pub fn total(&self) -> f32 {
        self.sum.element_sum()
    }

    /// The k picks for the number `u` in [0, 1), by systematic sampling of the cumulative p̂
    /// at (u + i) T / k: `emit(j, factor)` once per distinct light picked, with
    /// factor = n_j T / (k p̂_j) · `scale` (the window's W), so that c_j · factor is the
    /// light's share of the estimate. The cumulative sums are
    /// formed here in block order; their rounding differs from T's by ulps, and the last light
    /// takes any pick that rounding leaves over, so k picks are always made.
    pub fn pick(&self, k: usize, u: f32, scale: f32, mut emit: impl FnMut(usize, f32)) {
        let total = self.total();
        if !(total > 0.0 && total.is_finite()) || k == 0 {
            return;
        }
        let step = total / k as f32;
        let mut picked = 0;
        let mut pos = u * step;
        let mut base = 0.0f32;
        let blocks = self.p.len();
        for (b, &p) in self.p.iter().enumerate() {
            let hi = base + p.element_sum();
            let last_block = b + 1 == blocks;
            if pos >= hi && !last_block {
                base = hi;
                continue;
            }
            let last_lane = if last_block { (0..LANES).rev().find(|&l| p[l] > 0.0) } else { None };
            let mut lo = base;
            for lane in 0..LANES {
                let pl = p[lane];
                if pl <= 0.0 {
                    continue;
                }
                let lane_hi = lo + pl;
                let last = last_lane == Some(lane);
                let mut n = 0u32;
                while picked < k && (pos < lane_hi || last) {
                    n += 1;
                    picked += 1;
                    pos = (u + picked as f32) * step;
                }
                if n > 0 {
                    emit(self.first[b] as usize + lane, n as f32 * step * scale / pl);
                }
                lo = lane_hi;
            }
            if picked == k {
                return;
            }
            base = hi;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The picks' weights add up, in expectation over u, to the candidates' sum, for every
    /// candidate separately, whatever the estimates p̂ (positive wherever the contribution is
    /// not zero; here neither proportional to the contributions nor to their channels' sum);
    /// and at most k picks are made, exactly k when any p̂ is positive.
    #[test]
    fn picks_are_unbiased_per_candidate() {
        let mut cands = Candidates::new();
        let cs: [Vec3; 8] = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.01, 0.0),
            Vec3::ZERO,
            Vec3::new(5.0, 2.0, 1.0),
            Vec3::new(0.3, 0.3, 0.3),
            Vec3::new(1e-6, 0.0, 1e-6),
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 2.0),
        ];
        let estimates = [0.5, 2.0, 0.0, 0.7, 3.0, 1e-3, 0.25, 0.1];
        let block = |b: usize| Vec4::from_array(std::array::from_fn(|i| estimates[4 * b + i]));
        cands.push(0, block(0));
        cands.push(100, Vec4::ZERO);
        cands.push(4, block(1));
        assert_eq!(cands.len(), 2);
        for k in [1, 2, 3, 8] {
            let steps = 100_000;
            let mut sum = [glam::DVec3::ZERO; 8];
            for s in 0..steps {
                let u = (s as f32 + 0.5) / steps as f32;
                let mut picks = 0;
                cands.pick(k, u, 2.0, |j, f| {
                    sum[j] += (cs[j] * f / 2.0).as_dvec3();
                    picks += 1;
                });
                assert!(picks <= k);
            }
            for (j, &c) in cs.iter().enumerate() {
                let mean = (sum[j] / steps as f64).as_vec3();
                assert!(
                    (mean - c).abs().max_element() <= 1e-3 * c.max_element().max(1e-3),
                    "k {k} light {j}: {mean} vs {c}"
                );
            }
        }
    }

    #[test]
    fn empty_and_degenerate_candidates_pick_nothing() {
        let mut cands = Candidates::new();
        cands.push(0, Vec4::ZERO);
        cands.push(4, Vec4::splat(f32::NAN));
        cands.push(8, Vec4::new(f32::INFINITY, 0.0, -1.0, 0.0));
        assert_eq!(cands.total(), 0.0);
        let mut n = 0;
        cands.pick(4, 0.5, 1.0, |_, _| n += 1);
        assert_eq!(n, 0);
    }
}
