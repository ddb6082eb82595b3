//! Walker's alias method: a discrete distribution sampled in O(1) from one number (Vose's
//! construction, as pbrt-v4's `AliasTable`). The number picks a bin uniformly (its integer
//! part) and the bin's own outcome or its alias (its fractional part against the bin's
//! threshold); each outcome's total probability over the bins is exactly its weight's share.

use super::reuse::{ONE_BELOW, split};

/// One bin: keep index `i` when the fraction is below `keep`, else take `alias`.
#[derive(Clone, Copy, Debug)]
struct Bin {
    keep: f32,
    alias: u32,
}

#[derive(Clone, Debug)]
pub struct AliasTable {
    bins: Vec<Bin>,
    /// Each index's probability, weight / total.
    pmf: Vec<f32>,
}

impl AliasTable {
    /// `None` when the weights are empty, sum to zero or are not finite (negative weights
    /// count as zero).
    pub fn new(weights: &[f64]) -> Option<Self> {
        let total: f64 = weights.iter().map(|w| w.max(0.0)).sum();
        if weights.is_empty() || weights.len() > u32::MAX as usize || !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let n = weights.len();
        let pmf: Vec<f64> = weights.iter().map(|w| w.max(0.0) / total).collect();
        // Each bin holds probability 1/n: scaled probabilities below 1 go to `small`, others to
        // `large`; a small one is topped up from a large one, whose remainder is sorted again.
        let mut scaled: Vec<f64> = pmf.iter().map(|p| p * n as f64).collect();
        let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
        let mut bins = vec![Bin { keep: 1.0, alias: 0 }; n];
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            bins[s] = Bin { keep: scaled[s] as f32, alias: l as u32 };
            scaled[l] -= 1.0 - scaled[s];
            if scaled[l] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left holds (up to rounding) exactly 1: it keeps its own index, unless
        // rounding left a zero weight there, which must never be drawn.
        let heaviest = (0..n).max_by(|&a, &b| pmf[a].total_cmp(&pmf[b])).unwrap_or(0);
        for i in small.into_iter().chain(large) {
            bins[i] = if pmf[i] > 0.0 {
                Bin { keep: 1.0, alias: i as u32 }
            } else {
                Bin { keep: 0.0, alias: heaviest as u32 }
            };
        }
        Some(AliasTable { bins, pmf: pmf.into_iter().map(|p| p as f32).collect() })
    }

    pub fn len(&self) -> usize {
        self.bins.len()
    }

    pub fn is_empty(&self) -> bool {
        self.bins.is_empty()
    }

    /// Draws an index with probability proportional to its weight from `x` in `[0, 1)`, and
    /// returns what is left of `x` too: a number in `[0, 1)`, uniform given the index when
    /// `x` is uniform, and monotone in `x` within each bin's part for the index, so that
    /// stratified `x` stay stratified in it (pbrt-v4's sample reuse). It has the bits of `x`
    /// below the bins', so `x` needs more than an `f32`'s 24 bits when there are many bins.
    #[inline]
    pub fn sample_reuse(&self, x: f64) -> (usize, f64) {
        let n = self.bins.len();
        let scaled = x * n as f64;
        // `new` keeps n ≤ u32::MAX, so scaled < 2³² and the u32 conversion (a shorter
        // saturating sequence than usize's) gives the same index.
        let i = (scaled as u32 as usize).min(n - 1);
        let bin = self.bins[i];
        let (kept, rest) = split((scaled - i as f64).clamp(0.0, ONE_BELOW), bin.keep as f64);
        (if kept { i } else { bin.alias as usize }, rest)
    }

    /// The probability of drawing `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frequencies_match_the_weights_and_zero_weights_never_come_up() {
        for weights in [vec![0.0, 1.0, 0.0, 3.0], vec![5.0], vec![1.0, 2.0, 3.0, 4.0, 0.5, 0.0, 7.0]] {
            let t = AliasTable::new(&weights).unwrap();
            let total: f64 = weights.iter().sum();
            let n = 1 << 16;
            let mut counts = vec![0usize; weights.len()];
            for k in 0..n {
                counts[t.sample_reuse((k as f64 + 0.5) / n as f64).0] += 1;
            }
            for (i, w) in weights.iter().enumerate() {
                let p = w / total;
                assert!((t.pmf(i) as f64 - p).abs() < 1e-7);
                // Stratified u: the frequencies are exact up to the bins' rounding.
                assert!((counts[i] as f64 / n as f64 - p).abs() < 1e-3, "{weights:?} {i}: {counts:?}");
                if *w == 0.0 {
                    assert_eq!(counts[i], 0);
                }
            }
        }
        assert!(AliasTable::new(&[0.0, 0.0]).is_none());
        assert!(AliasTable::new(&[]).is_none());
        assert!(AliasTable::new(&[1.0, f64::INFINITY]).is_none());
    }

    /// The reused number: indices with the weights' frequencies, and a rest in [0, 1) that is uniform given the index (every tenth of
    /// [0, 1) as often, for stratified x), even at the ends of [0, 1).
    #[test]
    fn the_reused_rest_is_uniform_given_the_index() {
        let weights = [1.0, 2.0, 3.0, 4.0, 0.5, 0.0, 7.0];
        let t = AliasTable::new(&weights).unwrap();
        let total: f64 = weights.iter().sum();
        let n = 1 << 20;
        let mut counts = [[0usize; 10]; 7];
        for k in 0..n {
            let x = (k as f64 + 0.5) / n as f64;
            let (i, rest) = t.sample_reuse(x);
            assert!((0.0..1.0).contains(&rest), "{x}: {rest}");
            counts[i][(rest * 10.0) as usize] += 1;
        }
        for (i, w) in weights.iter().enumerate() {
            let expected = w / total * n as f64 / 10.0;
            for (b, &c) in counts[i].iter().enumerate() {
                assert!(
                    (c as f64 - expected).abs() <= 2.0 + 1e-4 * expected,
                    "index {i}, tenth {b}: {c} against {expected}"
                );
            }
        }
        for x in [0.0, 1.0 - f64::EPSILON / 2.0] {
            let (i, rest) = t.sample_reuse(x);
            assert!(weights[i] > 0.0 && (0.0..1.0).contains(&rest), "{x}: {i} {rest}");
        }
    }
}
