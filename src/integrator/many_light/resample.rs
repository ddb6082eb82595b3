//! The resampled gather: a receiver estimates the unoccluded contribution of a random window
//! of m candidate lights (cheap: an eight-wide kernel, no ray), then evaluates and traces
//! shadow rays to only k of them, drawn in proportion to those estimates.
//!
//! Two stages, each unbiased given the one before, so the estimate is unbiased for the
//! iteration's full gather Σ_j c_j V_j (c_j the unoccluded contribution of light j with the
//! iteration's bound or radius, V_j its visibility):
//!
//! 1. **The window.** The lights are in `n` blocks (chunks of the lanes, or single spheres);
//!    the window is `w` consecutive blocks, cyclically, from a uniform start. Every block lies
//!    in exactly `w` of the `n` windows, so Σ_{j ∈ window} c_j V_j · n / w is unbiased for the
//!    full sum (Horvitz–Thompson with inclusion probability w / n). The VPLs are stored path
//!    by path, and the light paths of an iteration are independent, so a window is a random
//!    handful of whole light paths: per receiver, a different one. A window of half the
//!    blocks or more is widened to all of them ([`window_blocks`]): that costs at most twice
//!    its candidates, and the blocks it would leave out only add the variance of the factor
//!    n / w (on the Cornell box with 32 light paths, 19 blocks against a window of 16:
//!    `pir-bdpt`'s relative MSE 6.5 % lower at the same time, `docs/measurements.md`).
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

use crate::sampling::Sampler;

/// Most candidates per receiver (`--gather-candidates`).
pub const MAX_CANDIDATES: usize = 1024;

/// A uniform index below `n` (0 when `n` is 0), from one number of `sampler`: Lemire's
/// multiply-shift, uniform up to 2^-64, far below the noise.
fn uniform_index(n: usize, sampler: &mut Sampler) -> usize {
    ((sampler.next_u64() as u128 * n as u128) >> 64) as usize
}

/// Lights per chunk (a block of candidates, a chunk of the lanes of [`super::lanes`]): the
/// width of `Vec4`.
pub const LANES: usize = 4;

/// The resampled gather over `blocks` blocks of [`LANES`] lights with `m` candidates and `k`
/// picks: draws the window's start and the picks' number (two numbers of `sampler`, always,
/// before any the candidates draw), lets `candidate` push the window's blocks in its order
/// ([`Window::blocks`]), then
/// calls `emit(j, factor, sampler)` for every light picked, with the window's scale n / w in
/// the factor ([`Candidates::pick`]); `emit` may draw numbers of its own (a picked sphere's
/// cone integral). With `active` false (a receiver that reflects nothing) only the
/// numbers are drawn.
pub fn resample(
    blocks: usize,
    m: usize,
    k: usize,
    active: bool,
    sampler: &mut Sampler,
    mut candidate: impl FnMut(&mut Candidates, Window, &mut Sampler),
    mut emit: impl FnMut(usize, f32, &mut Sampler),
) {
    let w = window_blocks(blocks, m);
    let window = Window::draw(blocks, w, sampler);
    let u = sampler.next_f32();
    if !active || blocks == 0 {
        return;
    }
    with_candidates(|cands| {
        candidate(cands, window, sampler);
        cands.pick(k, u, blocks as f32 / w as f32, |j, factor| emit(j, factor, sampler));
    });
}

/// The blocks of a window for `m` candidates among `blocks`: ⌈m / [`LANES`]⌉, or all of them
/// when that is half of them or more (see the module docs); at least one.
pub fn window_blocks(blocks: usize, m: usize) -> usize {
    let w = m.div_ceil(LANES).max(1);
    if blocks <= 2 * w { blocks.max(1) } else { w }
}

/// A window of `w` consecutive blocks of `n`, cyclically, from `start`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    start: usize,
    w: usize,
    n: usize,
}

impl Window {
    /// The window of `w` blocks of `n` (at most `n`) from `start`.
    #[cfg(test)]
    pub fn new(start: usize, w: usize, n: usize) -> Window {
        assert!(start < n);
        Window { start, w: w.min(n), n }
    }

    /// A window of `w` blocks of `n` (at most `n`) from a uniform start, one number of
    /// `sampler`.
    fn draw(n: usize, w: usize, sampler: &mut Sampler) -> Window {
        Window { start: uniform_index(n, sampler), w: w.min(n), n }
    }

    /// The blocks in the window's order.
    pub fn blocks(self) -> impl Iterator<Item = usize> {
        (0..self.w).map(move |t| {
            let b = self.start + t;
            if b >= self.n { b - self.n } else { b }
        })
    }

    /// The same blocks as at most two runs of consecutive ones, `(first, count)`, in the
    /// window's order: from the start to the last block, then from block 0 (an empty second
    /// run when the window does not wrap).
    pub fn runs(self) -> [(usize, usize); 2] {
        let first = self.w.min(self.n - self.start);
        [(self.start, first), (0, self.w - first)]
    }
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
    /// factor = n_j T / (k p̂_j) · `scale` (the window's n / w), so that c_j · factor is the
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
    use crate::sampling::Domain;
    use glam::Vec3;

    #[test]
    fn windows_cover_every_block_equally() {
        let (n, w) = (7, 3);
        let mut hits = [0usize; 7];
        let mut s = Sampler::new(1, 0, Domain::LightPath, 0);
        let draws = 70_000;
        for _ in 0..draws {
            let window = Window::draw(n, w, &mut s);
            let runs: Vec<usize> = window.runs().iter().flat_map(|&(b, c)| b..b + c).collect();
            assert_eq!(runs, window.blocks().collect::<Vec<_>>());
            for b in window.blocks() {
                hits[b] += 1;
            }
        }
        for h in hits {
            let expect = draws as f64 * w as f64 / n as f64;
            assert!((h as f64 - expect).abs() < 5.0 * expect.sqrt(), "{hits:?}");
        }
        // A window at least as wide as the blocks is all of them, once each.
        let all: Vec<usize> = Window::draw(4, 9, &mut s).blocks().collect();
        let mut sorted = all.clone();
        sorted.sort();
        assert_eq!(sorted, vec![0, 1, 2, 3]);
    }

    /// m candidates make a window of ⌈m / 4⌉ blocks, widened to all of them when that is at
    /// least half.
    #[test]
    fn wide_windows_take_every_block() {
        assert_eq!(window_blocks(100, 64), 16);
        assert_eq!(window_blocks(33, 64), 16);
        assert_eq!(window_blocks(32, 64), 32);
        assert_eq!(window_blocks(19, 64), 19);
        assert_eq!(window_blocks(3, 64), 3);
        assert_eq!(window_blocks(0, 64), 1);
        assert_eq!(window_blocks(3, 1), 1);
        assert_eq!(window_blocks(2, 1), 2);
        assert_eq!(window_blocks(2, 4), 2);
    }

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
